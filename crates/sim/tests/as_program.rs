//! The emulator running an AS program (`Controller::with_program`): on a tokio runtime with
//! paused time (in-memory clients) and over loopback TCP; the pendant's `/tasks`; faults; a
//! user's own modified server.
#![allow(clippy::expect_used)] // test code: a failed expectation is a failed test

use std::time::Duration;

use fs020n_proto::{ErrorCode, Status};
use fs020n_sim::ServerProgram;
use fs020n_sim::{ControllerConfig, Emulator, Fault};
use tokio::io::{AsyncReadExt, AsyncWriteExt};

async fn request(s: &mut tokio::io::DuplexStream, text: &str) -> String {
    s.write_all(text.as_bytes()).await.unwrap();
    let mut buf = vec![0u8; 512];
    let mut got = Vec::new();
    loop {
        let n = tokio::time::timeout(Duration::from_secs(10), s.read(&mut buf))
            .await
            .expect("a reply")
            .unwrap();
        assert!(n > 0, "connection closed");
        got.extend_from_slice(&buf[..n]);
        if Status::decode(&String::from_utf8_lossy(&got)).is_ok() {
            return String::from_utf8(got).unwrap();
        }
    }
}

fn server() -> Emulator {
    Emulator::with_program(
        ControllerConfig::default(),
        ServerProgram::server_1040().unwrap(),
    )
}

#[tokio::test(start_paused = true)]
async fn the_interpreted_server_serves_in_memory_clients() {
    let emu = server();
    tokio::time::sleep(Duration::from_millis(10)).await;
    let mut s = emu.connect_program().expect("the program listens");
    // A second client is refused while the session is open.
    tokio::time::sleep(Duration::from_millis(10)).await;
    assert!(emu.connect_program().is_err());
    let r = request(&mut s, "1040 1 0").await;
    assert!(r.starts_with(" 1040 0 -1 -1 0 -1 -1 "), "{r:?}");
    request(&mut s, "1040 3 1 100").await;
    request(&mut s, "1040 6 9 0 0 0 30 0 -90 0 -90 0").await;
    tokio::time::sleep(Duration::from_secs(2)).await;
    let st = Status::decode(&request(&mut s, "0 0 0").await).unwrap();
    assert_eq!(st.joints[0], 30.0);
    let snap = emu.snapshot();
    let program = snap.program.expect("program info");
    assert_eq!(program.served_port, Some(10050));
    assert_eq!(program.tasks[0].program.as_deref(), Some("ros_move"));
    // The server ships quiet (ros_print = 0): a real controller's terminals are not flooded.
    assert!(!program
        .terminal
        .iter()
        .any(|l| l.text.starts_with("ros_move: cmd")));
    assert!(snap.session.open);
    assert_eq!(snap.session.newest_command.unwrap().number, 6.0);
    // The receive timeout ends the session; the robot program stops 50 ms later.
    tokio::time::sleep(Duration::from_secs(6)).await;
    let mut buf = [0u8; 16];
    assert_eq!(s.read(&mut buf).await.unwrap(), 0, "closed by the server");
    assert_eq!(emu.snapshot().task, fs020n_sim::MotionTaskState::NotRunning);
    // And it listens again.
    tokio::time::sleep(Duration::from_millis(10)).await;
    let mut s2 = emu.connect_program().expect("listening again");
    assert!(request(&mut s2, "0 0 0")
        .await
        .starts_with(" 1040 0 -1 -1 0 -1 0     0.0"));
}

#[tokio::test(start_paused = true)]
async fn faults_apply_to_the_programs_replies() {
    let emu = server();
    tokio::time::sleep(Duration::from_millis(10)).await;
    let mut s = emu.connect_program().unwrap();
    emu.with(|c| c.inject(Fault::GarbageReply { text: "#!?".into() }));
    s.write_all(b"0 0 0").await.unwrap();
    let mut buf = [0u8; 64];
    let n = s.read(&mut buf).await.unwrap();
    assert_eq!(&buf[..n], b"#!?");
    emu.with(|c| {
        c.inject(Fault::DelayReplies {
            count: 1,
            delay_ms: 1500,
        })
    });
    let t0 = tokio::time::Instant::now();
    request(&mut s, "0 0 0").await;
    assert!(t0.elapsed() >= Duration::from_millis(1500));
    emu.with(|c| {
        c.inject(Fault::RaiseError {
            code: ErrorCode(-31130),
        })
    });
    let st = Status::decode(&request(&mut s, "0 0 0").await).unwrap();
    assert_eq!(st.error, ErrorCode(-31130));
    emu.with(|c| c.inject(Fault::CloseConnection));
    tokio::time::sleep(Duration::from_millis(10)).await;
    assert_eq!(s.read(&mut buf).await.unwrap(), 0);
}

#[tokio::test]
async fn the_interpreted_server_over_loopback_tcp() {
    let emu = server();
    let srv = emu
        .serve_program_tcp("127.0.0.1:0".parse().unwrap())
        .await
        .unwrap();
    let addr = srv.local_addr();
    let mut stream = None;
    for _ in 0..100 {
        if let Ok(s) = tokio::net::TcpStream::connect(addr).await {
            stream = Some(s);
            break;
        }
        tokio::time::sleep(Duration::from_millis(20)).await;
    }
    let mut s = stream.expect("connected");
    s.set_nodelay(true).unwrap();
    s.write_all(b"1040 0 0").await.unwrap();
    let mut got = Vec::new();
    let mut buf = [0u8; 256];
    while Status::decode(&String::from_utf8_lossy(&got)).is_err() {
        let n = tokio::time::timeout(Duration::from_secs(10), s.read(&mut buf))
            .await
            .unwrap()
            .unwrap();
        assert!(n > 0);
        got.extend_from_slice(&buf[..n]);
    }
    assert!(String::from_utf8_lossy(&got).starts_with(" 1040 0 -1 -1 0 -1 0 "));
    s.write_all(b"1040 255 0").await.unwrap();
    let mut rest = Vec::new();
    let _ = tokio::time::timeout(Duration::from_secs(10), s.read_to_end(&mut rest)).await;
    assert!(!rest.is_empty(), "the reply to 255, then the end");
    srv.stop();
}

/// A user's modification (`crates/as/programs/examples/gripper.as`: the server plus command 8)
/// tested from Rust on virtual time, with the controller directly.
#[test]
fn a_modified_server_with_an_extra_command() {
    use fs020n_sim::Controller;
    let path = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../as/programs/examples/gripper.as"
    );
    let program = ServerProgram::from_file(std::path::Path::new(path)).unwrap();
    let mut c = Controller::with_program(ControllerConfig::default(), program);
    c.advance_by(Duration::from_millis(10));
    let client = c.program_mut().connect(None, [127, 0, 0, 1]).unwrap();
    let request = |c: &mut Controller, text: &str| {
        assert!(c.program_mut().send(client, text.as_bytes()));
        for _ in 0..100 {
            c.advance_by(Duration::from_millis(1));
            let r = c.program_mut().recv(client);
            if !r.bytes.is_empty() {
                return String::from_utf8(r.bytes).unwrap();
            }
        }
        panic!("no reply to {text}");
    };
    let reply = request(&mut c, "1040 8 1 1");
    assert!(reply.starts_with(" 1040 0 -1 -1 0 -1 0 "), "{reply:?}");
    assert_eq!(
        c.program().signal(1),
        Some(true),
        "gripper open: output 1 on"
    );
    assert_eq!(c.program().signal(2), Some(false));
    request(&mut c, "1040 8 1 0");
    assert_eq!(
        (c.program().signal(1), c.program().signal(2)),
        (Some(false), Some(true))
    );
    assert!(c
        .program()
        .terminal()
        .iter()
        .any(|l| l.text == "gripper closed"));
    // Everything else is the protocol-1040 server.
    request(&mut c, "1040 3 1 100");
    request(&mut c, "1040 1 0");
    request(&mut c, "1040 6 9 0 0 0 20 0 -90 0 -90 0");
    c.advance_by(Duration::from_secs(2));
    let st = Status::decode(&request(&mut c, "0 0 0")).unwrap();
    assert_eq!(st.joints[0], 20.0);
    // The example is the server text plus the command: nothing else changed.
    let text = std::fs::read_to_string(path).unwrap();
    let server: Vec<&str> = fs020n_as::SERVER_1040.lines().collect();
    let example: Vec<&str> = text.lines().collect();
    let kept = server.iter().filter(|l| example.contains(l)).count();
    assert!(kept >= server.len() - 1, "only the first line differs");
}
