//! Receive and send behaviour of the robot port over real loopback TCP (spec §2, §2.3): one
//! receive is one request whatever its size, and a client that stops reading loses its session
//! within seconds (the 2 s send timeout), as on the controller.

use std::time::{Duration, Instant};

use fs020n_proto::{ReplyDecoder, Status};
use fs020n_sim::{ControllerConfig, Emulator, SessionEnd};
use tokio::io::{AsyncReadExt, AsyncWriteExt};
use tokio::net::{TcpSocket, TcpStream};

async fn replies_within(s: &mut TcpStream, wait: Duration) -> Vec<Status> {
    let mut d = ReplyDecoder::new();
    let mut buf = [0u8; 8192];
    let mut out = Vec::new();
    let end = tokio::time::Instant::now() + wait;
    while let Ok(Ok(n)) = tokio::time::timeout_at(end, s.read(&mut buf)).await {
        if n == 0 {
            break;
        }
        d.push(&buf[..n]).unwrap();
        while let Some(f) = d.next_reply().unwrap() {
            out.push(f.status);
        }
    }
    out
}

#[tokio::test]
async fn one_receive_of_up_to_4096_bytes_is_one_request_and_one_reply() {
    let emu = Emulator::new(ControllerConfig::default());
    let server = emu.serve_tcp("127.0.0.1:0".parse().unwrap()).await.unwrap();
    let mut s = TcpStream::connect(server.local_addr()).await.unwrap();
    s.set_nodelay(true).unwrap();
    // 3000 bytes in one write: a speed request, then blanks and junk that reach past 255 and
    // past the old 1024-byte receive. Loopback delivers it in one segment.
    let mut req = b"1040 3 1 50".to_vec();
    req.resize(1500, b' ');
    req.extend(std::iter::repeat_n(b'9', 1500));
    s.write_all(&req).await.unwrap();
    let got = replies_within(&mut s, Duration::from_millis(500)).await;
    assert_eq!(got.len(), 1, "one receive, one reply");
    assert_eq!(emu.with(|c| c.monitor_speed()), 50.0);
    assert_eq!(emu.with(|c| c.counters().requests), 1);
    server.stop();
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_client_that_stops_reading_loses_its_session_within_seconds() {
    let emu = Emulator::new(ControllerConfig::default());
    let server = emu.serve_tcp("127.0.0.1:0".parse().unwrap()).await.unwrap();
    // A PC with a small receive buffer (the test's own choice, so that the figure does not
    // depend on this machine's defaults); the emulator's send buffer is what is under test.
    let socket = TcpSocket::new_v4().unwrap();
    socket.set_recv_buffer_size(4096).unwrap();
    let s = socket.connect(server.local_addr()).await.unwrap();
    s.set_nodelay(true).unwrap();
    let (_rd, mut wr) = s.into_split();
    let started = Instant::now();
    // Poll every 2 ms and never read a reply.
    let writer = tokio::spawn(async move {
        loop {
            match tokio::time::timeout(Duration::from_millis(100), wr.write_all(b"0 0 0")).await {
                Ok(Ok(())) => {}
                Ok(Err(_)) => return,
                Err(_) => {} // the emulator no longer reads: keep trying
            }
            tokio::time::sleep(Duration::from_millis(2)).await;
        }
    });
    // The session must have been accepted before its end can be awaited.
    while emu.with(|c| c.native().session()).is_none() {
        assert!(started.elapsed() < Duration::from_secs(5), "never accepted");
        tokio::time::sleep(Duration::from_millis(5)).await;
    }
    let mut ended = None;
    while started.elapsed() < Duration::from_secs(15) {
        if emu.with(|c| c.native().session()).is_none() {
            ended = Some(started.elapsed());
            break;
        }
        tokio::time::sleep(Duration::from_millis(20)).await;
    }
    writer.abort();
    let ended = ended.expect("the session never ended: replies are absorbed by socket buffers");
    assert!(
        ended < Duration::from_secs(8),
        "the session lasted {ended:?} without the client reading"
    );
    assert!(
        ended >= Duration::from_secs(2),
        "the 2 s send timeout ran: {ended:?}"
    );
    let end = emu.with(|c| c.native().last_session_end()).unwrap();
    assert_eq!(end.1, SessionEnd::SendTimeout);
    server.stop();
}
