//! A session started with an aged timer (`Timing::session_timer_start`): TIMER(1) is a 32-bit
//! AS real, so a long session's replies step by more than the wire's millisecond — what a
//! client streaming with command 7 must account for.
#![allow(clippy::expect_used)] // test code: a failed expectation is a failed test

use std::time::Duration;

use fs020n_proto::{Status, Timer, TIMER_COARSE_AFTER_S};
use fs020n_sim::{Controller, ControllerConfig, Timing};

fn aged(start_s: u64) -> (Controller, fs020n_sim::SessionId) {
    let mut c = Controller::new(ControllerConfig {
        timing: Timing {
            session_timer_start: Duration::from_secs(start_s),
            ..Timing::default()
        },
        ..ControllerConfig::default()
    });
    let id = c.try_accept().expect("a listening controller accepts");
    (c, id)
}

fn timer(c: &mut Controller, id: fs020n_sim::SessionId) -> f64 {
    let h = c.handle_request(id, b"0 0 0").expect("open session");
    c.reply_sent(id);
    let s = Status::decode(std::str::from_utf8(&h.reply).expect("ASCII")).expect("a reply");
    s.timer.seconds().expect("no overflow")
}

#[test]
fn a_young_session_reads_every_millisecond() {
    let (mut c, id) = aged(0);
    let mut seen = Vec::new();
    for _ in 0..5 {
        c.advance_by(Duration::from_millis(1));
        seen.push(timer(&mut c, id));
    }
    assert_eq!(seen, [0.001, 0.002, 0.003, 0.004, 0.005]);
    assert_eq!(Timer::Seconds(seen[4]).step_s(), Some(0.001));
}

#[test]
fn after_2_to_the_16_seconds_about_18_hours_timer_1_steps_by_7_8_ms() {
    let start = 65_536;
    let (mut c, id) = aged(start);
    let mut distinct = Vec::new();
    for _ in 0..40 {
        c.advance_by(Duration::from_millis(1));
        let t = timer(&mut c, id);
        if distinct.last() != Some(&t) {
            distinct.push(t);
        }
    }
    // 40 ms of session give a handful of values, 1/128 s apart (as printed with 3 decimals).
    assert!(distinct.len() >= 4 && distinct.len() <= 7, "{distinct:?}");
    for w in distinct.windows(2) {
        let step = w[1] - w[0];
        assert!((step - 1.0 / 128.0).abs() <= 0.0011, "{distinct:?}");
    }
    let step = Timer::Seconds(distinct[0]).step_s().expect("a value");
    assert_eq!(step, 1.0 / 128.0);
    assert!(distinct[0] >= TIMER_COARSE_AFTER_S);
}
