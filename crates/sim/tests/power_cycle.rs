//! `POST /power-cycle` on the pendant API over loopback: the controller restarts, keeps its
//! programs and switches, and the AUTOSTART program serves the protocol port again.
#![cfg(feature = "pendant")]
#![allow(clippy::expect_used)] // test code: a failed expectation is a failed test

use std::net::SocketAddr;
use std::time::Duration;

use fs020n_as::TaskId;
use fs020n_sim::{run_robot, SimOptions};
use tokio::io::{AsyncReadExt, AsyncWriteExt};
use tokio::net::TcpStream;

/// A POST with an empty JSON body; the status code and the body.
async fn post(addr: SocketAddr, path: &str) -> (u16, String) {
    let mut s = TcpStream::connect(addr).await.expect("the pendant answers");
    let req = format!(
        "POST {path} HTTP/1.1\r\nHost: {addr}\r\nConnection: close\r\n\
         Content-Type: application/json\r\nContent-Length: 0\r\n\r\n"
    );
    s.write_all(req.as_bytes()).await.expect("sent");
    let mut out = Vec::new();
    s.read_to_end(&mut out).await.expect("read");
    let text = String::from_utf8_lossy(&out).into_owned();
    let code = text
        .split_whitespace()
        .nth(1)
        .and_then(|c| c.parse().ok())
        .unwrap_or(0);
    (code, text)
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn post_power_cycle_restarts_the_controller_and_runs_autostart_pc() {
    let loopback = SocketAddr::from(([127, 0, 0, 1], 0));
    let robot = run_robot(
        SimOptions::default()
            .ports(fs020n_sim::PortMap::free())
            .listen(loopback)
            .pendant(loopback)
            .bare(),
    )
    .await
    .expect("the emulator starts");
    let pendant = robot.pendant_addr().expect("a pendant");
    let report = robot
        .emulator()
        .with(|c| c.memory_mut().load(fs020n_as::SERVER_1040, false));
    assert_eq!(report.errors, 0);
    // AUTOSTART.PC OFF: the power cycle starts nothing.
    let (code, _) = post(pendant, "/power-cycle").await;
    assert_eq!(code, 200);
    assert!(!robot
        .emulator()
        .with(|c| c.program().task_running(TaskId::Pc(1))));
    robot
        .emulator()
        .with(|c| assert!(c.memory_mut().set_switch("AUTOSTART.PC", true)));
    let (code, body) = post(pendant, "/power-cycle").await;
    assert_eq!(code, 200, "{body}");
    assert!(robot
        .emulator()
        .with(|c| c.program().task_running(TaskId::Pc(1))));
    assert_eq!(
        robot.emulator().with(|c| c.memory().programs()),
        vec!["autostart.pc", "ros_move"]
    );
    let mut answered = false;
    for _ in 0..50 {
        if let Ok(mut s) = TcpStream::connect(robot.robot_addr()).await {
            s.write_all(b"1040 0 0").await.expect("sent");
            let mut buf = [0u8; 512];
            let n = tokio::time::timeout(Duration::from_secs(2), s.read(&mut buf))
                .await
                .expect("a reply")
                .expect("read");
            let fields = String::from_utf8_lossy(&buf[..n])
                .split_whitespace()
                .count();
            assert_eq!(fields, 14);
            answered = true;
            break;
        }
        tokio::time::sleep(Duration::from_millis(100)).await;
    }
    assert!(answered, "the autostart server never listened");
    robot.stop();
}
