//! A long session costs streaming accuracy: TIMER(1) is a 32-bit AS real whose step grows
//! with the session's age, and the client's statistics say so (`Stats::timer_step_s`). On
//! virtual time, against an emulator that starts its sessions with an aged timer.

mod common;

use std::time::Duration;

use common::*;
use fs020n_proto::TIMER_WIRE_STEP_S;
use fs020n_sim::{ControllerConfig, Emulator, Timing};

fn aged(start: Duration) -> Emulator {
    Emulator::new(ControllerConfig {
        timing: Timing {
            session_timer_start: start,
            ..Timing::default()
        },
        ..ControllerConfig::default()
    })
}

#[tokio::test(start_paused = true)]
async fn a_young_session_keeps_the_wires_millisecond() {
    let robot = connect(&emulator()).await;
    robot.poll().await.expect("a reply");
    assert_eq!(robot.stats().timer_step_s, Some(TIMER_WIRE_STEP_S));
}

#[tokio::test(start_paused = true)]
async fn after_18_hours_the_stats_say_the_timer_steps_by_7_8_ms() {
    let robot = connect(&aged(Duration::from_secs(65_536))).await;
    let first = robot.poll().await.expect("a reply");
    assert_eq!(robot.stats().timer_step_s, Some(1.0 / 128.0));
    // The replies show it: over 40 ms the timer moves in steps of 1/128 s.
    let mut seen = vec![first.timer.seconds().expect("a timer")];
    for _ in 0..8 {
        sleep_ms(5).await;
        let t = robot
            .poll()
            .await
            .expect("a reply")
            .timer
            .seconds()
            .expect("a timer");
        if seen.last() != Some(&t) {
            seen.push(t);
        }
    }
    assert!(seen.len() >= 2, "{seen:?}");
    for w in seen.windows(2) {
        assert!(((w[1] - w[0]) - 1.0 / 128.0).abs() <= 0.0011, "{seen:?}");
    }
}
