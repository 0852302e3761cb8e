//! Command-7 tracking against the emulator on virtual time: the online lag compensation
//! (`LagCompensation`) against none, and against command-6 waypoints, on the repository's
//! `examples/circle.csv` at 50 Hz.

mod common;

use std::time::Duration;

use common::*;
use fs020n_client::{LagCompensation, StreamMode, StreamOptions};

async fn run(mode: StreamMode, lag: LagCompensation) -> fs020n_client::StreamReport {
    let emu = emulator();
    let robot = ready(&emu, 100.0).await;
    let options = StreamOptions {
        mode,
        lag_compensation: lag,
        ..StreamOptions::default()
    };
    let report = robot
        .stream(circle_csv(), options)
        .await
        .unwrap()
        .wait()
        .await
        .unwrap();
    robot.close().await.unwrap();
    report
}

#[tokio::test(start_paused = true)]
async fn online_lag_compensation_tracks_the_circle() {
    let look = StreamMode::Extrapolated {
        lookahead_passes: 2.0,
    };
    let none = run(look, LagCompensation::Off).await;
    let online = run(look, LagCompensation::default()).await;
    let waypoints = run(StreamMode::Waypoints, LagCompensation::Off).await;
    eprintln!(
        "rms: off {:.3} (lag {:?}), online {:.3} (lag {:?}, lead {:.3}), waypoints {:.3} (lag {:?})",
        none.tracking_error_rms_deg,
        none.lag_s,
        online.tracking_error_rms_deg,
        online.lag_s,
        online.lead_s,
        waypoints.tracking_error_rms_deg,
        waypoints.lag_s
    );
    // Without compensation the arm runs behind by the controller's pipeline lag.
    let lag = none.lag_s.expect("a lag was measured");
    assert!(lag > 0.03, "the controller's pipeline lags: {lag}");
    // The online lead follows it (bounded), and the arm is on the path instead of behind it.
    assert!(
        online.lead_s > 0.02 && online.lead_s <= 0.3,
        "{}",
        online.lead_s
    );
    assert!(
        online.lag_s.unwrap().abs() < 0.3 * lag,
        "{:?}",
        online.lag_s
    );
    assert!(
        online.tracking_error_rms_deg < 0.35 * none.tracking_error_rms_deg,
        "{online:?} vs {none:?}"
    );
    assert!(
        online.tracking_error_rms_deg < 0.25 * waypoints.tracking_error_rms_deg,
        "{online:?} vs {waypoints:?}"
    );
    // Waypoints are measured too.
    assert!(waypoints.lag_s.is_some());
}

#[tokio::test(start_paused = true)]
async fn a_fixed_lead_is_used_as_given() {
    let r = run(
        StreamMode::Extrapolated {
            lookahead_passes: 2.0,
        },
        LagCompensation::Fixed(Duration::from_millis(60)),
    )
    .await;
    assert_eq!(r.lead_s, 0.06);
    assert!(r.tracking_error_rms_deg < 0.3, "{r:?}");
}

#[tokio::test(start_paused = true)]
async fn a_lead_beyond_the_controllers_clamp_is_refused_before_sending() {
    let emu = emulator();
    let robot = ready(&emu, 100.0).await;
    let options = StreamOptions {
        lag_compensation: LagCompensation::Fixed(Duration::from_millis(600)),
        ..StreamOptions::default()
    };
    let before = emu.with(|c| c.counters().effective_requests);
    let err = robot.stream(circle_csv(), options).await.unwrap_err();
    assert!(err.to_string().contains("0.5 s"), "{err}");
    assert_eq!(emu.with(|c| c.counters().effective_requests), before);
}
