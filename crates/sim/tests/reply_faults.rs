//! Delayed and split replies against the communication task's timing, fault limits, and the
//! panel rules added after review.

mod common;

use std::time::Duration;

use common::{jmove, ms, running};
use fs020n_proto::{ReplyDecoder, Status};
use fs020n_sim::MAX_FAULT_COUNT;
use fs020n_sim::{ControllerConfig, Emulator, Fault, MotionTaskState, SessionEnd};
use tokio::io::{AsyncReadExt, AsyncWriteExt, DuplexStream};

async fn request(s: &mut DuplexStream, text: &str) -> Option<Status> {
    s.write_all(text.as_bytes()).await.ok()?;
    let mut d = ReplyDecoder::new();
    let mut buf = [0u8; 256];
    loop {
        let n = s.read(&mut buf).await.ok()?;
        if n == 0 {
            return None;
        }
        d.push(&buf[..n]).ok()?;
        if let Some(f) = d.next_reply().ok()? {
            return Some(f.status);
        }
    }
}

#[tokio::test(start_paused = true)]
async fn the_receive_timeout_starts_after_a_delayed_reply_is_sent() {
    let emu = Emulator::new(ControllerConfig::default());
    let mut s = emu.connect().unwrap();
    emu.with(|c| {
        c.inject(Fault::DelayReplies {
            count: 1,
            delay_ms: 3000,
        })
    });
    let t0 = tokio::time::Instant::now();
    assert!(request(&mut s, "0 0 0").await.is_some());
    assert!(t0.elapsed() >= ms(3000));
    // 4.5 s after the reply (7.5 s after the request) the session is still open.
    tokio::time::sleep(ms(4500)).await;
    assert!(request(&mut s, "0 0 0").await.is_some(), "still open");
    // And it still times out 5 s after the last reply.
    tokio::time::sleep(ms(5100)).await;
    assert!(request(&mut s, "0 0 0").await.is_none());
    assert_eq!(
        emu.with(|c| c.native().last_session_end()).map(|e| e.1),
        Some(SessionEnd::ReceiveTimeout)
    );
}

#[tokio::test(start_paused = true)]
async fn a_delay_longer_than_the_receive_timeout_still_delivers() {
    let emu = Emulator::new(ControllerConfig::default());
    let mut s = emu.connect().unwrap();
    emu.with(|c| {
        c.inject(Fault::DelayReplies {
            count: 1,
            delay_ms: 8000,
        })
    });
    assert!(request(&mut s, "0 0 0").await.is_some());
    assert!(emu.with(|c| c.native().session().is_some()));
}

#[tokio::test(start_paused = true)]
async fn closing_during_a_delay_sends_nothing_and_reopens_at_once() {
    let emu = Emulator::new(ControllerConfig::default());
    let mut s = emu.connect().unwrap();
    emu.with(|c| {
        c.inject(Fault::DelayReplies {
            count: 1,
            delay_ms: 8000,
        })
    });
    let e = emu.clone();
    tokio::spawn(async move {
        tokio::time::sleep(ms(1000)).await;
        e.with(|c| c.inject(Fault::CloseConnection));
    });
    let t0 = tokio::time::Instant::now();
    assert!(
        request(&mut s, "0 0 0").await.is_none(),
        "no reply after the close"
    );
    assert!(
        t0.elapsed() < ms(2000),
        "closed without waiting for the delay"
    );
    assert!(emu.connect().is_ok(), "listening again");
}

#[tokio::test(start_paused = true)]
async fn a_split_reply_arrives_whole_and_the_session_goes_on() {
    let emu = Emulator::new(ControllerConfig::default());
    let mut s = emu.connect().unwrap();
    emu.with(|c| {
        c.inject(Fault::SplitReply {
            parts: 5,
            gap_ms: 2000,
        })
    });
    let st = request(&mut s, "0 0 0").await.expect("reply");
    assert_eq!(st.version, 1040);
    tokio::time::sleep(ms(4000)).await;
    assert!(request(&mut s, "0 0 0").await.is_some());
}

#[test]
fn fault_numbers_are_bounded() {
    let huge = Fault::WithholdReplies { count: u32::MAX };
    assert!(huge.validate().is_err());
    assert!(Fault::DelayReplies {
        count: 1,
        delay_ms: u64::MAX
    }
    .validate()
    .is_err());
    assert!(Fault::DelayReplies {
        count: 3,
        delay_ms: 1500
    }
    .validate()
    .is_ok());
    // Injected directly, a huge count is clamped rather than exhausting memory.
    let (mut c, _) = running();
    c.inject(huge);
    c.inject(Fault::WithholdReplies { count: 5 });
    assert_eq!(c.pending_faults(), MAX_FAULT_COUNT as usize);
}

#[test]
fn teach_lock_on_stops_a_running_program() {
    let (mut c, id) = running();
    jmove(&mut c, id, [30.0, 0.0, -90.0, 0.0, -90.0, 0.0]);
    c.advance_by(ms(300));
    c.set_teach_lock(true);
    assert_eq!(c.task(), MotionTaskState::NotRunning);
    let j = c.joints();
    c.advance_by(Duration::from_secs(2));
    assert!(
        c.joints()[0] - j[0] < 5.0,
        "braked, did not go on to the target"
    );
    assert!(c.arm().is_still());
}

#[test]
fn the_pendant_refuses_a_monitor_speed_above_100() {
    let (mut c, _) = running();
    assert!(c.set_monitor_speed(250.0).is_err());
    assert!(c.set_monitor_speed(0.0).is_err());
    assert!(c.set_monitor_speed(55.0).is_ok());
    assert_eq!(c.monitor_speed(), 55.0);
}
