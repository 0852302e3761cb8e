//! The fleet's readiness loop (`FleetServer`) against the tokio server (`Emulator::serve_tcp`):
//! the same client scripts over real loopback TCP, the same replies (TIMER(1), a wall-clock
//! reading, left out of the comparison), the same refusals and session ends.

#![allow(clippy::expect_used)] // test code: a failed expectation is a failed test

use std::io::{Read, Write};
use std::net::{SocketAddr, TcpStream};
use std::thread;
use std::time::{Duration, Instant};

use fs020n_proto::{ReplyDecoder, Status};
use fs020n_sim::{Controller, ControllerConfig, Emulator, FleetServer, SessionEnd};

/// One step of a client script.
#[derive(Clone, Copy)]
enum Step {
    /// Send these bytes in one write and read one reply.
    Ask(&'static str),
    /// Send these bytes and expect the connection to close after the reply (command 255).
    AskAndClose(&'static str),
    /// Close the connection.
    Drop,
    /// Connect again (retrying through the listen gap).
    Reconnect,
    /// A second connection while the session is open: refused or closed without a reply.
    SecondClientRefused,
}

/// What a script saw: each reply without its TIMER(1), and each event.
fn run_script(addr: SocketAddr, script: &[Step]) -> Vec<String> {
    let mut seen = Vec::new();
    let mut s = Some(connect(addr));
    for step in script {
        match *step {
            Step::Ask(req) | Step::AskAndClose(req) => {
                let conn = s.as_mut().expect("connected");
                conn.write_all(req.as_bytes()).expect("write");
                let status = read_reply(conn).expect("a reply");
                seen.push(format!(
                    "{} {:?} run={} task={} {}",
                    status.version, status.error, status.run, status.task_running, status.joints
                ));
                if matches!(step, Step::AskAndClose(_)) {
                    let mut rest = [0u8; 16];
                    conn.set_read_timeout(Some(Duration::from_secs(2))).ok();
                    let n = conn.read(&mut rest).unwrap_or(0);
                    seen.push(format!("closed after the reply: {}", n == 0));
                    s = None;
                }
            }
            Step::Drop => {
                s = None;
                seen.push("dropped".into());
            }
            Step::Reconnect => {
                s = Some(connect(addr));
                seen.push("connected".into());
            }
            Step::SecondClientRefused => {
                let refused = match TcpStream::connect_timeout(&addr, Duration::from_secs(1)) {
                    Err(_) => true,
                    Ok(mut other) => {
                        other
                            .set_read_timeout(Some(Duration::from_millis(300)))
                            .ok();
                        let _ = other.write_all(b"0 0 0");
                        let mut b = [0u8; 64];
                        !matches!(other.read(&mut b), Ok(n) if n > 0)
                    }
                };
                seen.push(format!("second client refused: {refused}"));
            }
        }
    }
    seen
}

fn connect(addr: SocketAddr) -> TcpStream {
    let deadline = Instant::now() + Duration::from_secs(10);
    loop {
        if let Ok(s) = TcpStream::connect_timeout(&addr, Duration::from_secs(1)) {
            s.set_nodelay(true).ok();
            s.set_read_timeout(Some(Duration::from_secs(5))).ok();
            return s;
        }
        assert!(Instant::now() < deadline, "the robot port never listened");
        thread::sleep(Duration::from_millis(20));
    }
}

fn read_reply(s: &mut TcpStream) -> Option<Status> {
    let mut d = ReplyDecoder::new();
    let mut buf = [0u8; 4096];
    loop {
        let n = s.read(&mut buf).ok()?;
        if n == 0 {
            return None;
        }
        d.push(&buf[..n]).ok()?;
        if let Some(f) = d.next_reply().ok()? {
            return Some(f.status);
        }
    }
}

/// The script against the tokio server; the controller's last session end.
fn with_tokio(script: &[Step]) -> (Vec<String>, Option<SessionEnd>) {
    let rt = tokio::runtime::Builder::new_current_thread()
        .enable_all()
        .build()
        .expect("runtime");
    let emu = rt.block_on(async { Emulator::new(ControllerConfig::default()) });
    let server = rt
        .block_on(emu.serve_tcp("127.0.0.1:0".parse().expect("address")))
        .expect("bind");
    let addr = server.local_addr();
    let driver = thread::spawn(move || {
        rt.block_on(async {
            tokio::time::sleep(Duration::from_secs(3600)).await;
        })
    });
    let seen = run_script(addr, script);
    thread::sleep(Duration::from_millis(100));
    let end = emu.with(|c| c.native().last_session_end().map(|(_, why)| why));
    drop(driver);
    (seen, end)
}

/// One default controller on the fleet's loop, running on its own thread.
fn one_robot_fleet() -> (
    SocketAddr,
    fs020n_sim::FleetStop,
    thread::JoinHandle<std::io::Result<Vec<Controller>>>,
) {
    let fleet = FleetServer::bind(vec![(
        Controller::new(ControllerConfig::default()),
        "127.0.0.1:0".parse().expect("address"),
    )])
    .expect("bind");
    let addr = fleet.local_addrs()[0];
    let stop = fleet.stopper();
    (addr, stop, thread::spawn(move || fleet.run()))
}

/// The same against the fleet's loop.
fn with_fleet(script: &[Step]) -> (Vec<String>, Option<SessionEnd>) {
    let (addr, stop, running) = one_robot_fleet();
    let seen = run_script(addr, script);
    thread::sleep(Duration::from_millis(100));
    stop.stop();
    let controllers = running.join().expect("the loop").expect("served");
    let end = controllers[0]
        .native()
        .last_session_end()
        .map(|(_, why)| why);
    (seen, end)
}

fn same_on_both(script: &[Step]) -> Vec<String> {
    let (tokio_seen, tokio_end) = with_tokio(script);
    let (fleet_seen, fleet_end) = with_fleet(script);
    assert_eq!(fleet_seen, tokio_seen, "what the client saw");
    assert_eq!(fleet_end, tokio_end, "how the last session ended");
    fleet_seen
}

#[test]
fn polls_speed_start_and_the_end_command_are_answered_alike() {
    let seen = same_on_both(&[
        Step::Ask("0 0 0"),
        Step::Ask("1040 3 1 50"),
        Step::Ask("1040 1 0"),
        Step::Ask("1040 6 9 0 0 0 10 0 -90 0 -90 0"),
        Step::Ask("0 0 0"),
        Step::SecondClientRefused,
        Step::AskAndClose("1040 255 0"),
    ]);
    assert!(
        seen.contains(&"closed after the reply: true".to_string()),
        "{seen:?}"
    );
    assert!(
        seen.contains(&"second client refused: true".to_string()),
        "{seen:?}"
    );
}

#[test]
fn a_dropped_client_ends_the_session_and_the_port_listens_again() {
    let seen = same_on_both(&[
        Step::Ask("0 0 0"),
        Step::Drop,
        Step::Reconnect,
        Step::Ask("0 0 0"),
        Step::Ask("garbage that is no request"),
        Step::Drop,
    ]);
    assert_eq!(seen.iter().filter(|s| s.starts_with("1040")).count(), 3);
}

#[test]
fn many_robots_are_served_by_one_loop() {
    let fleet = FleetServer::bind(
        (0..20)
            .map(|_| {
                (
                    Controller::new(ControllerConfig::default()),
                    "127.0.0.1:0".parse().expect("address"),
                )
            })
            .collect(),
    )
    .expect("bind");
    let addrs = fleet.local_addrs();
    let stop = fleet.stopper();
    let running = thread::spawn(move || fleet.run());
    let mut conns: Vec<TcpStream> = addrs.iter().map(|&a| connect(a)).collect();
    for round in 0..5 {
        for (k, c) in conns.iter_mut().enumerate() {
            let req = if round == 1 {
                format!("1040 3 1 {}", 10 + k)
            } else {
                "0 0 0".into()
            };
            c.write_all(req.as_bytes()).expect("write");
        }
        for c in conns.iter_mut() {
            assert!(
                read_reply(c).is_some(),
                "every robot answers in round {round}"
            );
        }
    }
    drop(conns);
    thread::sleep(Duration::from_millis(100));
    stop.stop();
    let controllers = running.join().expect("the loop").expect("served");
    for (k, c) in controllers.iter().enumerate() {
        assert_eq!(
            c.monitor_speed(),
            10.0 + k as f64,
            "robot {k} got its own speed"
        );
        assert_eq!(c.counters().requests, 5);
        assert_eq!(
            c.native().last_session_end().map(|(_, why)| why),
            Some(SessionEnd::Disconnected)
        );
    }
}

#[test]
fn a_client_that_stops_reading_loses_its_session_to_the_send_timeout() {
    let (addr, stop, running) = one_robot_fleet();
    // A small receive buffer of the test's own, so that the figure does not depend on this
    // machine's defaults; the emulator's 4096-byte send buffer is what is under test.
    let socket =
        socket2::Socket::new(socket2::Domain::IPV4, socket2::Type::STREAM, None).expect("socket");
    socket.set_recv_buffer_size(4096).expect("buffer");
    socket.connect(&addr.into()).expect("connect");
    let mut s: TcpStream = socket.into();
    s.set_nodelay(true).ok();
    s.set_write_timeout(Some(Duration::from_millis(100))).ok();
    let started = Instant::now();
    // Poll every 2 ms and never read a reply, until the emulator stops taking requests.
    let mut closed = false;
    while started.elapsed() < Duration::from_secs(15) {
        if s.write_all(b"0 0 0").is_err() {
            closed = true;
            break;
        }
        thread::sleep(Duration::from_millis(2));
    }
    stop.stop();
    let controllers = running.join().expect("the loop").expect("served");
    assert!(closed, "the session was never dropped");
    assert_eq!(
        controllers[0]
            .native()
            .last_session_end()
            .map(|(_, why)| why),
        Some(SessionEnd::SendTimeout)
    );
}
