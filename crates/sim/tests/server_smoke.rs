use std::time::Duration;

use fs020n_proto::{ReplyDecoder, Status};
use fs020n_sim::{ControllerConfig, Emulator, SessionEnd};
use tokio::io::{AsyncReadExt, AsyncWriteExt};

async fn roundtrip<S: tokio::io::AsyncRead + tokio::io::AsyncWrite + Unpin>(
    s: &mut S,
    req: &str,
) -> Status {
    s.write_all(req.as_bytes()).await.unwrap();
    let mut d = ReplyDecoder::new();
    let mut buf = [0u8; 256];
    loop {
        let n = s.read(&mut buf).await.unwrap();
        assert!(n > 0, "eof");
        d.push(&buf[..n]).unwrap();
        if let Some(f) = d.next_reply().unwrap() {
            return f.status;
        }
    }
}

#[tokio::test(start_paused = true)]
async fn in_memory_session_times_out_after_5s_of_silence() {
    let emu = Emulator::new(ControllerConfig::default());
    let mut s = emu.connect().unwrap();
    assert!(emu.connect().is_err(), "second client refused");
    let st = roundtrip(&mut s, "0 0 0").await;
    assert_eq!(st.version, 1040);
    tokio::time::sleep(Duration::from_millis(4900)).await;
    roundtrip(&mut s, "1040 1 0").await;
    assert!(emu.with(|c| c.task()) == fs020n_sim::MotionTaskState::Running);
    tokio::time::sleep(Duration::from_millis(5100)).await;
    let mut buf = [0u8; 16];
    assert_eq!(s.read(&mut buf).await.unwrap(), 0, "closed");
    let end = emu.with(|c| c.native().last_session_end());
    assert_eq!(end.map(|e| e.1), Some(SessionEnd::ReceiveTimeout));
    assert_eq!(
        emu.with(|c| c.task()),
        fs020n_sim::MotionTaskState::NotRunning
    );
}

#[tokio::test]
async fn tcp_loopback_round_trip() {
    let emu = Emulator::new(ControllerConfig::default());
    let server = emu.serve_tcp("127.0.0.1:0".parse().unwrap()).await.unwrap();
    let mut s = tokio::net::TcpStream::connect(server.local_addr())
        .await
        .unwrap();
    let st = roundtrip(&mut s, "0 0 0").await;
    assert!(st.power && st.run && st.repeat);
    // While the session is open, the port is closed.
    tokio::time::sleep(Duration::from_millis(20)).await;
    assert!(tokio::net::TcpStream::connect(server.local_addr())
        .await
        .is_err());
    roundtrip(&mut s, "1040 255 0").await;
    let mut buf = [0u8; 16];
    assert_eq!(s.read(&mut buf).await.unwrap(), 0);
    // Listening again.
    let mut again = None;
    for _ in 0..50 {
        if let Ok(c) = tokio::net::TcpStream::connect(server.local_addr()).await {
            again = Some(c);
            break;
        }
        tokio::time::sleep(Duration::from_millis(10)).await;
    }
    let mut s2 = again.expect("reconnect");
    roundtrip(&mut s2, "0 0 0").await;
    server.stop();
}
