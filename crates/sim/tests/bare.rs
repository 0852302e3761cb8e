//! A bare controller over loopback, as a user meets it: `fs020n sim --bare --terminal ADDR`,
//! the terminal client loads and starts the project's server text, and the protocol port
//! answers; the AUTOSTART switch and a power cycle; the refusals of the real controller.

#![allow(clippy::expect_used)] // test code: a failed expectation is a failed test

use std::net::SocketAddr;
use std::time::Duration;

use fs020n_sim::{run_robot, RunningRobot, SimOptions};
use fs020n_term::connection::TerminalConnection;
use fs020n_term::ClientConfig;
use tokio::io::{AsyncReadExt, AsyncWriteExt};
use tokio::net::TcpStream;

fn loopback() -> SocketAddr {
    SocketAddr::from(([127, 0, 0, 1], 0))
}

async fn start() -> RunningRobot {
    run_robot(
        SimOptions::default()
            .ports(fs020n_sim::PortMap::free())
            .listen(loopback())
            .terminal(loopback())
            .bare(),
    )
    .await
    .expect("the emulator starts")
}

async fn terminal(robot: &RunningRobot) -> TerminalConnection {
    let addr = robot.terminal_addr().expect("a terminal").to_string();
    TerminalConnection::connect(&addr, ClientConfig::default(), Duration::from_secs(5))
        .await
        .expect("logged in")
}

/// A side-effect-free poll (command 0) at the robot port: the reply's fields, or `None` when
/// nothing answers within a few seconds.
async fn poll(addr: SocketAddr) -> Option<Vec<String>> {
    let deadline = tokio::time::Instant::now() + Duration::from_secs(5);
    while tokio::time::Instant::now() < deadline {
        if let Ok(mut s) = TcpStream::connect(addr).await {
            if s.write_all(b"1040 0 0").await.is_ok() {
                let mut buf = vec![0u8; 1024];
                if let Ok(Ok(n)) =
                    tokio::time::timeout(Duration::from_secs(2), s.read(&mut buf)).await
                {
                    if n > 0 {
                        return Some(
                            String::from_utf8_lossy(&buf[..n])
                                .split_whitespace()
                                .map(str::to_owned)
                                .collect(),
                        );
                    }
                }
            }
        }
        tokio::time::sleep(Duration::from_millis(100)).await;
    }
    None
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_bare_controller_serves_the_loaded_server_after_pcexecute_and_after_a_power_cycle() {
    let robot = start().await;
    assert!(
        TcpStream::connect(robot.robot_addr()).await.is_err(),
        "no protocol port before a program is loaded"
    );
    let mut term = terminal(&robot).await;
    assert_eq!(term.terminal(), Some("AUX1"));
    let report = term
        .load("server1040.as", fs020n_as::SERVER_1040.as_bytes())
        .await
        .unwrap();
    assert_eq!(report.errors, 0, "{}", report.output);
    assert_eq!(
        term.command("PCEXECUTE 1: autostart.pc", false)
            .await
            .unwrap(),
        ""
    );
    let fields = poll(robot.robot_addr()).await.expect("the server answers");
    assert_eq!(fields.len(), 14, "{fields:?}");
    assert_eq!(term.command("TYPE TASK (1001)", false).await.unwrap(), " 1");

    assert_eq!(
        term.command("SWITCH AUTOSTART.PC = ON", false)
            .await
            .unwrap(),
        ""
    );
    robot.emulator().with(|c| c.power_cycle());
    assert_eq!(term.command("TYPE TASK (1001)", false).await.unwrap(), " 1");
    let fields = poll(robot.robot_addr())
        .await
        .expect("the server answers again");
    assert_eq!(fields.len(), 14, "{fields:?}");
    robot.stop();
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_connection_dropped_mid_load_leaves_p2076_for_the_next_session() {
    let robot = start().await;
    let addr = robot.terminal_addr().unwrap();
    let mut raw = TcpStream::connect(addr).await.unwrap();
    raw.write_all(b"as\r\nLOAD x.as\r\n").await.unwrap();
    // Wait for the controller's A frame, then drop the link mid-transfer.
    let mut seen = Vec::new();
    let mut buf = [0u8; 256];
    while !seen.windows(2).any(|w| w == [0x05, 0x02]) {
        let n = tokio::time::timeout(Duration::from_secs(5), raw.read(&mut buf))
            .await
            .expect("the controller answers")
            .unwrap();
        assert!(n > 0);
        seen.extend_from_slice(&buf[..n]);
    }
    drop(raw);
    tokio::time::sleep(Duration::from_millis(200)).await;
    let mut term = terminal(&robot).await;
    let err = term
        .load("y.as", b".PROGRAM y()\n.END\n")
        .await
        .expect_err("P2076");
    assert!(err.to_string().contains("P2076"), "{err}");
    robot.stop();
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn kill_of_a_running_program_is_refused_over_the_network() {
    let robot = start().await;
    let mut term = terminal(&robot).await;
    term.load("server1040.as", fs020n_as::SERVER_1040.as_bytes())
        .await
        .unwrap();
    term.command("PCEXECUTE 1: autostart.pc", false)
        .await
        .unwrap();
    let out = term.command("PCKILL 1:", true).await.unwrap();
    assert!(
        out.contains("(P1026)Cannot KILL program that is running."),
        "{out}"
    );
    robot.stop();
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_fourth_terminal_session_is_refused() {
    let robot = start().await;
    let mut sessions = Vec::new();
    for name in ["AUX1", "AUX2", "AUX3"] {
        let t = terminal(&robot).await;
        assert_eq!(t.terminal(), Some(name));
        sessions.push(t);
    }
    let addr = robot.terminal_addr().unwrap().to_string();
    let fourth =
        TerminalConnection::connect(&addr, ClientConfig::default(), Duration::from_secs(2)).await;
    assert!(fourth.is_err(), "a fourth session logs in");
    drop(sessions.pop());
    tokio::time::sleep(Duration::from_millis(200)).await;
    assert_eq!(terminal(&robot).await.terminal(), Some("AUX3"));
    robot.stop();
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn output_in_small_pieces_still_serves_a_load() {
    let robot = run_robot(SimOptions {
        terminal_piece: Some(3),
        ..SimOptions::default()
            .ports(fs020n_sim::PortMap::free())
            .listen(loopback())
            .terminal(loopback())
            .bare()
    })
    .await
    .unwrap();
    let mut term = terminal(&robot).await;
    let report = term
        .load("server1040.as", fs020n_as::SERVER_1040.as_bytes())
        .await
        .unwrap();
    assert_eq!(report.errors, 0);
    let dir = term.command("DIRECTORY/P", false).await.unwrap();
    assert!(dir.contains("autostart.pc"), "{dir}");
    robot.stop();
}

/// Two PC programs, each listening on its own port, started from the terminal one after the
/// other; the ports are 9111 (the served port) and 9112.
const TWO_LISTENERS: &str = ".PROGRAM first.pc()\n\
  TCP_LISTEN .ret, 9111\n\
  WHILE TRUE DO\n    TWAIT 0.1\n  END\n\
.END\n\
.PROGRAM second.pc()\n\
  TCP_LISTEN .ret, 9112\n\
  WHILE TRUE DO\n    TWAIT 0.1\n  END\n\
.END\n";

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn every_port_a_pcexecute_made_listen_accepts_a_connection_as_soon_as_the_prompt_returns() {
    let robot = start().await;
    let mut term = terminal(&robot).await;
    let report = term.load("two.as", TWO_LISTENERS.as_bytes()).await.unwrap();
    assert_eq!(report.errors, 0, "{}", report.output);
    let emu = robot.emulator();
    assert!(emu.program_listeners_ready(), "nothing listens yet");

    assert_eq!(
        term.command("PCEXECUTE 1: first.pc", false).await.unwrap(),
        ""
    );
    // No wait and no retry: the prompt came back only once the host socket listened.
    assert!(emu.program_listeners_ready());
    TcpStream::connect(robot.robot_addr())
        .await
        .expect("the served port accepts at once");

    assert_eq!(
        term.command("PCEXECUTE 2: second.pc", false).await.unwrap(),
        ""
    );
    assert!(emu.program_listeners_ready());
    let second = *emu
        .program_ports()
        .get(&9112)
        .expect("port 9112 is served on the host");
    TcpStream::connect(second)
        .await
        .expect("the second port accepts at once");
    robot.stop();
}
