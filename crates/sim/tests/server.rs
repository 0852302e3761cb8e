//! The tokio emulator on virtual time (`start_paused`) with in-memory clients: session timing,
//! the send timeout and every fault kind.

use std::time::Duration;

use fs020n_proto::{ErrorCode, ReplyDecoder, Status};
use fs020n_sim::{ControllerConfig, Emulator, Fault, MotionTaskState, SessionEnd};
use tokio::io::{AsyncRead, AsyncReadExt, AsyncWrite, AsyncWriteExt};
use tokio::time::{sleep, timeout, Instant};

async fn read_reply<S: AsyncRead + Unpin>(s: &mut S) -> Status {
    let mut d = ReplyDecoder::new();
    let mut buf = [0u8; 256];
    loop {
        let n = s.read(&mut buf).await.unwrap();
        assert!(n > 0, "connection closed");
        d.push(&buf[..n]).unwrap();
        if let Some(f) = d.next_reply().unwrap() {
            return f.status;
        }
    }
}

async fn roundtrip<S: AsyncRead + AsyncWrite + Unpin>(s: &mut S, req: &str) -> Status {
    s.write_all(req.as_bytes()).await.unwrap();
    read_reply(s).await
}

fn emulator() -> Emulator {
    Emulator::new(ControllerConfig::default())
}

#[tokio::test(start_paused = true)]
async fn silence_closes_the_session_and_stops_the_robot() {
    let emu = emulator();
    let mut s = emu.connect().unwrap();
    roundtrip(&mut s, "1040 1 0").await;
    roundtrip(&mut s, "1040 6 9 0 0 0 150 0 -90 0 -90 0").await;
    sleep(Duration::from_secs(1)).await;
    assert!(emu.with(|c| c.velocity()[0]) > 0.0);
    let t = Instant::now();
    let mut buf = [0u8; 16];
    assert_eq!(
        s.read(&mut buf).await.unwrap(),
        0,
        "closed by the controller"
    );
    assert_eq!(
        t.elapsed(),
        Duration::from_secs(4),
        "5 s after the last request"
    );
    let snap = emu.snapshot();
    assert_eq!(
        snap.session.last_end.unwrap().reason,
        SessionEnd::ReceiveTimeout
    );
    assert!(!snap.session.open && snap.session.listening);
    // signal 2007 is raised; the program's ONI fires once it has been stable for 50 ms: the
    // program ends, the arm brakes (TASK(1) = 3 until it stands)
    assert!(emu.with(|c| c.native().stop_signal()));
    sleep(fs020n_sim::SIGNAL_EDGE + Duration::from_millis(2)).await;
    assert_eq!(emu.snapshot().task, MotionTaskState::Finishing);
    sleep(Duration::from_secs(1)).await;
    assert_eq!(emu.snapshot().task, MotionTaskState::NotRunning);
    let stop = emu.with(|c| c.joints());
    sleep(Duration::from_secs(1)).await;
    assert_eq!(emu.with(|c| c.joints()), stop);
    assert!(stop[0] < 149.0, "stopped short of the target: {stop}");
}

#[tokio::test(start_paused = true)]
async fn listen_gap_and_second_client_over_in_memory_connect() {
    let emu = emulator();
    sleep(Duration::from_millis(3000)).await;
    let e = emu.connect().unwrap_err();
    assert_eq!(e.kind(), std::io::ErrorKind::ConnectionRefused);
    sleep(Duration::from_millis(100)).await;
    let mut s = emu.connect().expect("next window");
    assert!(emu.connect().is_err(), "one client at a time");
    sleep(Duration::from_millis(1500)).await;
    let st = roundtrip(&mut s, "0 0 0").await;
    assert_eq!(
        st.timer.seconds(),
        Some(1.5),
        "TIMER(1) counts from this accept"
    );
    roundtrip(&mut s, "1040 255 0").await;
    let mut buf = [0u8; 8];
    assert_eq!(s.read(&mut buf).await.unwrap(), 0);
    let mut s2 = emu.connect().expect("listening again at once");
    sleep(Duration::from_millis(250)).await;
    let st = roundtrip(&mut s2, "0 0 0").await;
    assert_eq!(st.timer.seconds(), Some(0.25), "timer reset on accept");
}

#[tokio::test(start_paused = true)]
async fn send_timeout_ends_the_session_when_the_client_does_not_read() {
    let emu = emulator();
    let mut s = emu.connect().unwrap();
    roundtrip(&mut s, "1040 1 0").await;
    // Requests, never reading the replies: the 4096-byte pipe fills after ~45 replies of 91
    // bytes, the next send blocks, and 2 s later the controller gives up.
    let start = Instant::now();
    let mut last_count = 0;
    let mut last_growth = start;
    let mut ended_at = None;
    for _ in 0..400 {
        if ended_at.is_none() {
            s.write_all(b"0 0 0").await.unwrap();
        }
        sleep(Duration::from_millis(10)).await;
        let (n, open) = emu.with(|c| (c.counters().requests, c.native().session().is_some()));
        if n > last_count {
            last_count = n;
            last_growth = Instant::now();
        }
        if !open {
            ended_at = Some(Instant::now());
            break;
        }
    }
    let ended_at = ended_at.expect("the session ended");
    assert!(
        (40..=50).contains(&last_count),
        "stuck after {last_count} replies"
    );
    let stuck = ended_at - last_growth;
    assert!(
        stuck >= Duration::from_millis(1990) && stuck <= Duration::from_millis(2020),
        "ended {stuck:?} after the blocked send"
    );
    let end = emu.with(|c| c.native().last_session_end()).expect("ended");
    assert_eq!(end.1, SessionEnd::SendTimeout);
    sleep(fs020n_sim::SIGNAL_EDGE + Duration::from_millis(2)).await;
    assert_eq!(emu.with(|c| c.task()), MotionTaskState::NotRunning);
}

#[tokio::test(start_paused = true)]
async fn fault_delay_replies() {
    let emu = emulator();
    let mut s = emu.connect().unwrap();
    emu.with(|c| {
        c.inject(Fault::DelayReplies {
            count: 2,
            delay_ms: 1500,
        })
    });
    for expected in [1500, 1500, 0] {
        let t = Instant::now();
        let st = roundtrip(&mut s, "0 0 0").await;
        assert_eq!(t.elapsed(), Duration::from_millis(expected));
        assert!(st.timer.seconds().is_some());
    }
}

#[tokio::test(start_paused = true)]
async fn fault_withhold_reply() {
    let emu = emulator();
    let mut s = emu.connect().unwrap();
    emu.with(|c| c.inject(Fault::WithholdReplies { count: 1 }));
    s.write_all(b"1040 1 0").await.unwrap();
    let mut buf = [0u8; 128];
    assert!(
        timeout(Duration::from_secs(1), s.read(&mut buf))
            .await
            .is_err(),
        "no reply"
    );
    assert_eq!(
        emu.with(|c| c.task()),
        MotionTaskState::Running,
        "the request took effect"
    );
    let st = roundtrip(&mut s, "0 0 0").await;
    assert!(st.task_running);
}

#[tokio::test(start_paused = true)]
async fn fault_garbage_reply() {
    let emu = emulator();
    let mut s = emu.connect().unwrap();
    emu.with(|c| {
        c.inject(Fault::GarbageReply {
            text: "#!garbage".into(),
        })
    });
    s.write_all(b"0 0 0").await.unwrap();
    let mut buf = [0u8; 128];
    let n = s.read(&mut buf).await.unwrap();
    assert_eq!(&buf[..n], b"#!garbage");
    roundtrip(&mut s, "0 0 0").await; // the next one is normal
}

#[tokio::test(start_paused = true)]
async fn fault_split_reply() {
    let emu = emulator();
    let mut s = emu.connect().unwrap();
    let normal = emu.with(|c| c.status().encode());
    emu.with(|c| {
        c.inject(Fault::SplitReply {
            parts: 3,
            gap_ms: 50,
        })
    });
    s.write_all(b"0 0 0").await.unwrap();
    let t = Instant::now();
    let mut got = Vec::new();
    let mut reads = 0;
    let mut buf = [0u8; 256];
    while got.len() < normal.len() {
        let n = s.read(&mut buf).await.unwrap();
        assert!(n > 0);
        got.extend_from_slice(&buf[..n]);
        reads += 1;
    }
    assert_eq!(reads, 3, "three pieces");
    assert_eq!(t.elapsed(), Duration::from_millis(100));
    assert_eq!(String::from_utf8(got).unwrap(), normal);
}

#[tokio::test(start_paused = true)]
async fn fault_close_connection() {
    let emu = emulator();
    let mut s = emu.connect().unwrap();
    roundtrip(&mut s, "1040 1 0").await;
    emu.with(|c| c.inject(Fault::CloseConnection));
    let mut buf = [0u8; 16];
    assert_eq!(s.read(&mut buf).await.unwrap(), 0);
    let snap = emu.snapshot();
    assert_eq!(snap.session.last_end.unwrap().reason, SessionEnd::Fault);
    sleep(fs020n_sim::SIGNAL_EDGE + Duration::from_millis(2)).await;
    assert_eq!(emu.snapshot().task, MotionTaskState::NotRunning);
    assert!(emu.connect().is_ok(), "listening again");
}

#[tokio::test(start_paused = true)]
async fn fault_stop_reading_stalls_the_client() {
    let emu = emulator();
    let mut s = emu.connect().unwrap();
    emu.with(|c| c.inject(Fault::StopReading { duration_ms: 3000 }));
    assert!(emu.snapshot().session.reading_paused);
    let t = Instant::now();
    let st = roundtrip(&mut s, "0 0 0").await;
    assert_eq!(
        t.elapsed(),
        Duration::from_secs(3),
        "answered once reading resumes"
    );
    assert_eq!(st.timer.seconds(), Some(3.0));
    // a long pause: the client's writes stall once the pipe is full, and the receive timeout
    // runs on: 5 s without a read request ends the session
    emu.with(|c| {
        c.inject(Fault::StopReading {
            duration_ms: 60_000,
        })
    });
    let big = vec![b'0'; 10_000];
    assert!(
        timeout(Duration::from_secs(1), s.write_all(&big))
            .await
            .is_err(),
        "write stalled"
    );
    sleep(Duration::from_secs(5)).await;
    assert_eq!(
        emu.with(|c| c.native().last_session_end()).unwrap().1,
        SessionEnd::ReceiveTimeout
    );
}

#[tokio::test(start_paused = true)]
async fn fault_raise_error() {
    let emu = emulator();
    let mut s = emu.connect().unwrap();
    roundtrip(&mut s, "1040 1 0").await;
    emu.with(|c| {
        c.inject(Fault::RaiseError {
            code: ErrorCode(-31130),
        })
    });
    let st = roundtrip(&mut s, "0 0 0").await;
    assert_eq!(st.error.raw(), -31130);
    assert!(!st.task_running);
    let snap = emu.snapshot();
    assert_eq!(snap.error.name, "E1130");
    assert_eq!(snap.error.message.as_deref(), Some("Collision detected"));
}

#[tokio::test(start_paused = true)]
async fn faults_are_dropped_with_the_session() {
    let emu = emulator();
    let mut s = emu.connect().unwrap();
    emu.with(|c| c.inject(Fault::WithholdReplies { count: 5 }));
    assert_eq!(emu.snapshot().pending_faults, 5);
    s.write_all(b"1040 255 0").await.unwrap();
    let mut buf = [0u8; 16];
    assert_eq!(s.read(&mut buf).await.unwrap(), 0);
    assert_eq!(emu.snapshot().pending_faults, 0);
    let mut s = emu.connect().unwrap();
    roundtrip(&mut s, "0 0 0").await;
}

#[tokio::test(start_paused = true)]
async fn streaming_over_the_emulator_runs_on_virtual_time() {
    let emu = emulator();
    let mut s = emu.connect().unwrap();
    roundtrip(&mut s, "1040 1 0").await;
    roundtrip(&mut s, "1040 3 1 100").await;
    // 10 s of a 100 Hz stream of a slow sine on JT1, in a blink of wall time
    let mut st = roundtrip(&mut s, "0 0 0").await;
    for k in 0..1000 {
        let t = st.timer.seconds().unwrap();
        let w = 0.5;
        let p = 20.0 * (w * t).sin();
        let v = 20.0 * w * (w * t).cos();
        let req =
            format!("1040 7 21 {t:.3} 1 0 {p:.3} 10 -80 0 -80 0 {v:.3} 0 0 0 0 0 0 0 0 0 0 0");
        st = roundtrip(&mut s, &req).await;
        if k > 100 {
            let err = st.joints[0] - 20.0 * (w * t).sin();
            assert!(err.abs() < 3.0, "tracking error {err} at {t}");
        }
        sleep(Duration::from_millis(10)).await;
    }
    assert!(st.error.is_none());
}
