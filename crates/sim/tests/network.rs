//! The emulated controller on a network: `TCP_CONNECT` and `UDP_SENDTO` to the cell's hosts
//! through the host map (real servers on loopback), E4023 for an address nobody answers for,
//! every port a program listens on served on the host and driven by a plain client, and a
//! mapped client seen at its cell address. The pick-and-place client example is played on
//! virtual time with the test as the PC.
#![allow(clippy::expect_used, clippy::unwrap_used)] // test code: a failure is a failed test

use std::net::{IpAddr, Ipv4Addr, SocketAddr, UdpSocket};
use std::time::Duration;

use fs020n_sim::{
    Controller, ControllerConfig, Emulator, Network, PortMap, ProgramDial, ServerProgram,
};
use tokio::io::{AsyncBufReadExt, AsyncReadExt, AsyncWriteExt, BufReader};
use tokio::net::{TcpListener, TcpStream};

const PC: Ipv4Addr = Ipv4Addr::new(192, 168, 0, 10);
const LOOPBACK: IpAddr = IpAddr::V4(Ipv4Addr::LOCALHOST);

fn examples(name: &str) -> std::path::PathBuf {
    std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../as/programs/examples")
        .join(name)
}

fn config(network: Network) -> ControllerConfig {
    ControllerConfig {
        network,
        monitor_speed_percent: 100.0,
        ..ControllerConfig::default()
    }
}

fn mapped() -> Network {
    Network::default().host(PC, LOOPBACK)
}

fn program(text: &str) -> ServerProgram {
    match ServerProgram::from_source("net.as", text) {
        Ok(p) => p,
        Err(e) => panic!("load failed:\n{e}"),
    }
}

/// A program that connects to `192.168.0.10:port`, sends HELLO, keeps the answer's length and
/// first byte.
fn hello_client(port: u16, timeout_s: u32) -> String {
    format!(
        ".PROGRAM autostart.pc()\n\
  ip[1] = 192\n  ip[2] = 168\n  ip[3] = 0\n  ip[4] = 10\n\
  TCP_CONNECT sock, {port}, ip[1], {timeout_s}\n\
  IF sock >= 0 THEN\n\
    $out[1] = \"HELLO\"\n\
    TCP_SEND sret, sock, $out[1], 1, 5\n\
    TCP_RECV rret, sock, $in[1], n, 5\n\
    answer = ASC($in[1])\n\
    answer_len = LEN($in[1])\n\
    TCP_CLOSE cret, sock\n\
  END\n\
  done = 1\n\
.END\n"
    )
}

/// Advances a controller on real time until `done` is set (or 10 s pass: the test then fails
/// on its assertions).
async fn until_done(emu: &Emulator, name: &str) {
    for _ in 0..1000 {
        if emu.with(|c| c.program().real(name)).is_some() {
            return;
        }
        tokio::time::sleep(Duration::from_millis(10)).await;
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn tcp_connect_to_a_mapped_host_reaches_the_real_server_behind_it() {
    let pc = TcpListener::bind("127.0.0.1:0").await.unwrap();
    let port = pc.local_addr().unwrap().port();
    let emu = Emulator::with_program(config(mapped()), program(&hello_client(port, 5)));
    let (mut s, peer) = tokio::time::timeout(Duration::from_secs(10), pc.accept())
        .await
        .expect("the program connects")
        .unwrap();
    assert!(peer.ip().is_loopback());
    let mut buf = [0u8; 5];
    s.read_exact(&mut buf).await.unwrap();
    assert_eq!(&buf, b"HELLO");
    s.write_all(b"WORLD").await.unwrap();
    until_done(&emu, "done").await;
    assert_eq!(
        emu.with(|c| c.program().real("sock")).map(|v| v >= 0.0),
        Some(true)
    );
    assert_eq!(emu.with(|c| c.program().real("sret")), Some(0.0));
    assert_eq!(emu.with(|c| c.program().real("rret")), Some(0.0));
    assert_eq!(
        emu.with(|c| c.program().real("answer")),
        Some(f32::from(b'W'))
    );
    assert_eq!(emu.with(|c| c.program().real("answer_len")), Some(5.0));
    // TCP_CLOSE closes the real connection.
    let mut rest = Vec::new();
    let n = tokio::time::timeout(Duration::from_secs(10), s.read_to_end(&mut rest))
        .await
        .expect("the program closes")
        .unwrap();
    assert_eq!(n, 0);
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_mapped_host_that_refuses_the_connection_gives_e4025() {
    // A port nobody listens on.
    let port = {
        let l = std::net::TcpListener::bind("127.0.0.1:0").unwrap();
        l.local_addr().unwrap().port()
    };
    let emu = Emulator::with_program(config(mapped()), program(&hello_client(port, 5)));
    until_done(&emu, "done").await;
    assert_eq!(emu.with(|c| c.program().real("sock")), Some(-34025.0));
}

#[test]
fn tcp_connect_to_an_unmapped_address_fails_with_e4023_and_dials_nothing() {
    let mut c =
        Controller::with_program(config(Network::default()), program(&hello_client(48200, 5)));
    c.advance_by(Duration::from_millis(50));
    assert_eq!(
        c.program().real("sock"),
        Some(-34023.0),
        "cannot reach the host"
    );
    assert_eq!(c.program().real("done"), Some(1.0));
    assert!(c.program_mut().take_dials().is_empty());
}

#[test]
fn tcp_connect_to_the_controllers_own_address_reaches_its_own_listener() {
    let text = ".PROGRAM autostart.pc()\n\
  TCP_LISTEN lret, 9300\n\
  ip[1] = 10\n  ip[2] = 0\n  ip[3] = 0\n  ip[4] = 7\n\
  TCP_CONNECT sock, 9300, ip[1], 1\n\
  TCP_ACCEPT asock, 9300, 1\n\
  done = 1\n\
.END\n";
    let own = Network::default().address(Ipv4Addr::new(10, 0, 0, 7));
    let mut c = Controller::with_program(config(own), program(text));
    c.advance_by(Duration::from_millis(50));
    assert_eq!(c.program().real("done"), Some(1.0));
    assert!(c.program().real("sock").unwrap() >= 0.0);
    assert!(c.program().real("asock").unwrap() >= 0.0);
    assert!(c.program_mut().take_dials().is_empty());
}

#[test]
fn a_tcp_connect_that_times_out_gives_e4024_and_refuses_the_late_connection() {
    let mut c = Controller::with_program(config(mapped()), program(&hello_client(48200, 1)));
    c.advance_by(Duration::from_millis(10));
    let dials = c.program_mut().take_dials();
    assert_eq!(dials.len(), 1);
    let ProgramDial { client, cell, to } = dials[0];
    assert_eq!(cell, std::net::SocketAddrV4::new(PC, 48200));
    assert_eq!(to, SocketAddr::new(LOOPBACK, 48200));
    c.advance_by(Duration::from_millis(1100));
    assert_eq!(c.program().real("sock"), Some(-34024.0));
    // The host answers too late: the network layer is told to close it.
    assert!(!c.program_mut().dialed(client, Ok(())));
}

/// Reads what the program sent to `client` until `want` appears (virtual time, 2 ms steps, at
/// most `limit_s` seconds).
fn read_until(
    c: &mut Controller,
    client: fs020n_sim::ClientId,
    want: &str,
    limit_s: u64,
) -> String {
    let mut got = String::new();
    let mut t = Duration::ZERO;
    while !got.contains(want) && t < Duration::from_secs(limit_s) {
        c.advance_by(Duration::from_millis(2));
        t += Duration::from_millis(2);
        got.push_str(&String::from_utf8_lossy(
            &c.program_mut().recv(client).bytes,
        ));
    }
    got
}

#[test]
fn the_pick_and_place_client_connects_to_the_pc_and_reports_each_part_it_moved() {
    let program = ServerProgram::from_file(&examples("pick_place_client.as")).unwrap();
    assert!(program.warnings().is_empty(), "{:?}", program.warnings());
    let mut c = Controller::with_program(config(mapped()), program);
    c.advance_by(Duration::from_millis(20));
    let dials = c.program_mut().take_dials();
    assert_eq!(dials.len(), 1, "one TCP_CONNECT to the PC");
    assert_eq!(dials[0].cell, std::net::SocketAddrV4::new(PC, 48200));
    let pc = dials[0].client;
    assert!(c.program_mut().dialed(pc, Ok(())));
    assert_eq!(read_until(&mut c, pc, "\r\n", 2), "READY\r\n");
    let home = c.joints();
    assert!(c.program_mut().send(pc, b"PICK\r\n"));
    let mut closed_hand = false;
    let mut got = String::new();
    let mut t = 0;
    while !got.contains("\r\n") && t < 30_000 {
        c.advance_by(Duration::from_millis(2));
        t += 2;
        closed_hand |= c.program().signal(2) == Some(true);
        got.push_str(&String::from_utf8_lossy(&c.program_mut().recv(pc).bytes));
    }
    assert_eq!(got, "PLACED 1\r\n");
    assert!(closed_hand, "CLOSEI at the pick");
    assert_eq!(c.program().signal(1), Some(true), "OPENI at the place");
    assert_ne!(c.joints(), home, "the arm moved (it ends above the place)");
    assert!(c.program_mut().send(pc, b"PICK\r\n"));
    assert_eq!(read_until(&mut c, pc, "\r\n", 30), "PLACED 2\r\n");
    assert!(c.program_mut().send(pc, b"QUIT\r\n"));
    assert_eq!(read_until(&mut c, pc, "\r\n", 2), "BYE\r\n");
    let mut closed = false;
    for _ in 0..100 {
        c.advance_by(Duration::from_millis(2));
        closed |= c.program_mut().recv(pc).closed;
    }
    assert!(closed, "TCP_CLOSE ends the connection");
}

#[test]
fn the_pick_and_place_client_tries_again_while_the_pc_refuses() {
    let program = ServerProgram::from_file(&examples("pick_place_client.as")).unwrap();
    let mut c = Controller::with_program(config(mapped()), program);
    c.advance_by(Duration::from_millis(20));
    let first = c.program_mut().take_dials();
    assert_eq!(first.len(), 1);
    assert!(c.program_mut().dialed(first[0].client, Err(-34025)));
    c.advance_by(Duration::from_millis(1100));
    let second = c.program_mut().take_dials();
    assert_eq!(second.len(), 1, "a second TCP_CONNECT a second later");
    assert_ne!(second[0].client, first[0].client);
}

/// A line from a reader, with a bound so that a broken program fails the test, not hangs it.
async fn line<R: tokio::io::AsyncBufRead + Unpin>(r: &mut R) -> String {
    let mut s = String::new();
    tokio::time::timeout(Duration::from_secs(10), r.read_line(&mut s))
        .await
        .expect("a line in time")
        .unwrap();
    s
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn every_port_a_program_listens_on_is_served_and_a_plain_client_drives_both() {
    let program = ServerProgram::from_file(&examples("two_ports.as")).unwrap();
    let emu = Emulator::with_program(config(Network::default()), program);
    let ports = emu.serve_program_ports(LOOPBACK, PortMap::free(), None);
    let commands = emu
        .wait_program_port(9111, Duration::from_secs(10))
        .await
        .expect("port 9111 is served");
    let state = emu
        .wait_program_port(9112, Duration::from_secs(10))
        .await
        .expect("port 9112 is served");
    assert_ne!(commands.port(), state.port());
    assert_eq!(emu.program_ports().len(), 2);

    let cmd = TcpStream::connect(commands).await.unwrap();
    let (rd, mut wr) = cmd.into_split();
    let mut rd = BufReader::new(rd);
    wr.write_all(b"OUT 5\r\n").await.unwrap();
    assert_eq!(line(&mut rd).await, "OK\r\n");
    assert_eq!(emu.with(|c| c.program().signal(5)), Some(true));
    wr.write_all(b"SPEED 30\r\n").await.unwrap();
    assert_eq!(line(&mut rd).await, "OK\r\n");
    assert_eq!(emu.with(|c| c.monitor_speed()), 30.0);
    wr.write_all(b"JUMP\r\n").await.unwrap();
    assert_eq!(line(&mut rd).await, "ERR\r\n");
    wr.write_all(b"COUNT\r\n").await.unwrap();
    assert_eq!(line(&mut rd).await, "OK 4\r\n");

    // The state port, at the same time.
    let st = TcpStream::connect(state).await.unwrap();
    let mut st = BufReader::new(st);
    let first = line(&mut st).await;
    assert!(first.starts_with("STATE 4"), "{first:?}");
    let second = line(&mut st).await;
    assert!(second.starts_with("STATE"), "{second:?}");
    ports.stop();
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_client_from_a_mapped_host_appears_to_the_program_at_its_cell_address() {
    let text = ".PROGRAM autostart.pc()\n\
  TCP_LISTEN lret, 9400\n\
  TCP_ACCEPT sock, 9400, 60, ip[1]\n\
  a = ip[1]\n  b = ip[2]\n  c = ip[3]\n  d = ip[4]\n\
  done = 1\n\
.END\n";
    let emu = Emulator::with_program(config(mapped()), program(text));
    let ports = emu.serve_program_ports(LOOPBACK, PortMap::same().map(9400, 0), None);
    let at = emu
        .wait_program_port(9400, Duration::from_secs(10))
        .await
        .expect("served");
    let _client = TcpStream::connect(at).await.unwrap();
    until_done(&emu, "done").await;
    let got: Vec<Option<f32>> = ["a", "b", "c", "d"]
        .iter()
        .map(|v| emu.with(|c| c.program().real(v)))
        .collect();
    assert_eq!(got, [Some(192.0), Some(168.0), Some(0.0), Some(10.0)]);
    ports.stop();
}

#[test]
fn udp_sendto_a_mapped_host_reaches_the_real_socket_and_an_unmapped_one_gives_e4023() {
    let peer = UdpSocket::bind("127.0.0.1:0").unwrap();
    peer.set_read_timeout(Some(Duration::from_secs(5))).unwrap();
    let port = peer.local_addr().unwrap().port();
    let text = format!(
        ".PROGRAM autostart.pc()\n\
  ip[1] = 192\n  ip[2] = 168\n  ip[3] = 0\n  ip[4] = 10\n\
  $out[1] = \"PING\"\n\
  UDP_SENDTO mapped, ip[1], {port}, $out[1], 1, 1\n\
  ip[4] = 11\n\
  UDP_SENDTO unmapped, ip[1], {port}, $out[1], 1, 1\n\
  done = 1\n\
.END\n"
    );
    let mut c = Controller::with_program(config(mapped()), program(&text));
    c.advance_by(Duration::from_millis(50));
    assert_eq!(c.program().real("mapped"), Some(0.0));
    assert_eq!(c.program().real("unmapped"), Some(-34023.0));
    let mut buf = [0u8; 16];
    let (n, _) = peer.recv_from(&mut buf).expect("the datagram");
    assert_eq!(&buf[..n], b"PING");
}

/// PCABORT while a `TCP_CONNECT` to a real host is pending: the task stops once the connect's
/// own timeout has passed (the abort waits for the step, AS-E p.10-4), and a connection the
/// network layer makes after that is refused to the program — `dialed` says "close it".
#[test]
fn an_outgoing_connection_made_after_its_task_was_aborted_is_closed() {
    let mut c = Controller::with_program(config(mapped()), program(&hello_client(5000, 2)));
    c.advance_by(Duration::from_millis(20));
    let dials = c.program_mut().take_dials();
    assert_eq!(
        dials.len(),
        1,
        "the TCP_CONNECT waits for the network layer"
    );
    let task = fs020n_as::TaskId::Pc(1);
    assert!(c.program().task_running(task));
    assert_eq!(c.program_mut().pc_abort(1), fs020n_sim::Abort::AfterStep);
    c.advance_by(Duration::from_millis(2100));
    assert!(
        !c.program().task_running(task),
        "stopped after its TCP_CONNECT gave up"
    );
    assert_eq!(
        c.program().real("done"),
        None,
        "the program went no further"
    );
    assert!(
        !c.program_mut().dialed(dials[0].client, Ok(())),
        "a connection made now is closed by the network layer"
    );
}

#[tokio::test(flavor = "current_thread")]
async fn the_listeners_are_ready_only_once_each_port_the_program_listens_on_accepts_on_the_host() {
    let program = ServerProgram::from_file(&examples("two_ports.as")).unwrap();
    let emu = Emulator::with_program(config(Network::default()), program);
    assert!(
        emu.program_listeners_ready(),
        "no port is served on the host yet, so none is waited for"
    );
    let ports = emu.serve_program_ports(LOOPBACK, PortMap::free(), None);
    // The program runs on the emulator's clock: let it reach its TCP_LISTEN without
    // yielding, so that the serving task cannot run on this one thread.
    for _ in 0..200 {
        if emu.with(|c| c.program().listening(Some(9111))) {
            break;
        }
        std::thread::sleep(Duration::from_millis(10));
    }
    assert!(emu.with(|c| c.program().listening(Some(9111))));
    // The program listens, the host does not yet.
    assert!(!emu.program_listeners_ready());
    assert!(emu.wait_program_listeners(Duration::from_secs(10)).await);
    for port in [9111, 9112] {
        let addr = *emu.program_ports().get(&port).expect("served");
        TcpStream::connect(addr).await.expect("accepts at once");
    }
    ports.stop();
}

#[tokio::test(flavor = "current_thread")]
async fn a_program_started_with_the_emulator_is_served_at_its_mapped_port_when_run_robot_returns() {
    // A program started with the emulator listens at its mapped host port when run_robot
    // returns: a client connects once, no wait_port (the robot address, which serves the
    // first port too, does not count for the port's own host socket).
    let file = std::env::temp_dir().join(format!("fs020n-mapped-{}.as", std::process::id()));
    std::fs::write(
        &file,
        ".PROGRAM srv()\n  TCP_LISTEN .r, 9200\n  TCP_ACCEPT .s, 9200, 60\n.END\n",
    )
    .unwrap();
    let opts = fs020n_sim::SimOptions {
        listen: SocketAddr::from(([127, 0, 0, 1], 0)),
        program: Some(file.clone()),
        ports: fs020n_sim::PortMap::default().map(9200, 0),
        start: vec![fs020n_sim::ProgramStart::pc("2: srv").unwrap()],
        ..fs020n_sim::SimOptions::default()
    };
    let robot = fs020n_sim::run_robot(opts).await.unwrap();
    let _ = std::fs::remove_file(&file);
    let ports = robot.emulator().program_ports();
    let host = *ports.get(&9200).expect("served at its mapped port");
    assert_ne!(host.port(), robot.robot_addr().port());
    TcpStream::connect(host).await.expect("accepts at once");
    robot.stop();
}
