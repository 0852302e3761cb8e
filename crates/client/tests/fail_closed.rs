//! Regression tests of the safety review: each would fail without its fix. In-memory emulator
//! on virtual time.

mod common;

use std::time::Duration;

use common::*;
use fs020n_client::{
    ClientError, Completion, LagCompensation, OptionError, SampleError, StreamOptions,
    StreamOutcome, TargetPacing, Trajectory, TrajectoryError, TrajectoryPoint,
};
use fs020n_kin::RobotModel;
use fs020n_proto::{Command, JointsDeg};

/// Home for `secs`, with the given velocity and acceleration at every point.
fn hold_home(secs: f64, velocity: JointsDeg, acceleration: JointsDeg) -> Trajectory {
    let points = (0..=10)
        .map(|k| TrajectoryPoint {
            time_s: secs * k as f64 / 10.0,
            position: home(),
            velocity: Some(velocity),
            acceleration: Some(acceleration),
        })
        .collect();
    Trajectory::new(points).unwrap()
}

fn jt(j: usize, v: f64) -> JointsDeg {
    let mut x = JointsDeg::ZERO;
    x[j - 1] = v;
    x
}

/// The largest |JT1| the emulator reaches within `ms` milliseconds (sampled every 10 ms).
async fn max_jt1_over(emu: &fs020n_sim::Emulator, ms: u64) -> f64 {
    let mut m: f64 = 0.0;
    for _ in 0..ms / 10 {
        sleep_ms(10).await;
        m = m.max(emu.with(|c| c.joints())[0].abs());
    }
    m
}

fn newest(emu: &fs020n_sim::Emulator) -> Option<Command> {
    emu.with(|c| c.native().newest_command())
}

// ------------------------------------------------------------------ 1. command 7 extrapolation

#[tokio::test(start_paused = true)]
async fn a_stream_with_a_given_acceleration_above_the_model_is_refused_before_sending() {
    let emu = emulator();
    let robot = ready(&emu, 100.0).await;
    let before = effective(&emu);
    // Holding position at home, but with 20000 deg/s² on JT1: the controller would
    // extrapolate JT1 far away (review: it reached 69.5° and raised E1088).
    let traj = hold_home(1.0, JointsDeg::ZERO, jt(1, 20_000.0));
    let err = robot
        .stream(traj, StreamOptions::default())
        .await
        .unwrap_err();
    match &err {
        ClientError::Trajectory(TrajectoryError::Sample {
            error:
                SampleError::AccelerationTooHigh {
                    joint: 1,
                    acceleration_deg_s2,
                    max_deg_s2,
                },
            ..
        }) => {
            assert_eq!(*acceleration_deg_s2, 20_000.0);
            assert_eq!(*max_deg_s2, 235.0);
        }
        other => panic!("{other:?}"),
    }
    assert!(err.to_string().contains("JT1 acceleration"), "{err}");
    assert_eq!(effective(&emu), before, "nothing was sent");
    assert_eq!(max_jt1_over(&emu, 1500).await, 0.0);
}

#[tokio::test(start_paused = true)]
async fn a_stream_whose_extrapolation_leaves_the_range_is_refused_before_sending() {
    let emu = emulator();
    let robot = ready(&emu, 100.0).await;
    let before = effective(&emu);
    // JT5 at -90° with a (plausible) -100 deg/s: over dt = 0.5 + 2 x 0.1 s the controller can
    // aim at -160°, beyond JT5's -145°.
    let traj = hold_home(1.0, jt(5, -100.0), JointsDeg::ZERO);
    let err = robot
        .stream(traj, StreamOptions::default())
        .await
        .unwrap_err();
    match &err {
        ClientError::Trajectory(TrajectoryError::Sample {
            error:
                SampleError::ExtrapolatedOutOfRange {
                    joint: 5,
                    value_deg,
                    dt_s,
                    ..
                },
            ..
        }) => {
            assert!((value_deg + 160.0).abs() < 1e-9, "{value_deg}");
            assert!((dt_s - 0.7).abs() < 1e-9, "{dt_s}");
        }
        other => panic!("{other:?}"),
    }
    let text = err.to_string();
    assert!(text.contains("JT5") && text.contains("-160.000"), "{text}");
    assert_eq!(effective(&emu), before, "nothing was sent");
}

#[tokio::test(start_paused = true)]
async fn raw_command_7_gets_the_same_sample_checks() {
    let emu = emulator();
    let robot = ready(&emu, 100.0).await;
    let before = effective(&emu);
    let t = robot.server_time_now().unwrap();
    let raw = |v: JointsDeg, a: JointsDeg| {
        let j = |x: JointsDeg| {
            x.iter()
                .map(|v| format!("{v}"))
                .collect::<Vec<_>>()
                .join(" ")
        };
        format!("1040 7 21 {t:.3} 2 0 {} {} {}", j(home()), j(v), j(a))
    };
    // The review's case: 1000 deg/s² on JT1 at home moved JT1 15.5°.
    let err = robot
        .send_raw(&raw(JointsDeg::ZERO, jt(1, 1000.0)), true)
        .await
        .unwrap_err();
    assert!(
        matches!(
            err,
            ClientError::Sample(SampleError::AccelerationTooHigh { joint: 1, .. })
        ),
        "{err:?}"
    );
    // A velocity whose extrapolation leaves JT5's range.
    let err = robot
        .send_raw(&raw(jt(5, -100.0), JointsDeg::ZERO), true)
        .await
        .unwrap_err();
    assert!(
        matches!(
            err,
            ClientError::Sample(SampleError::ExtrapolatedOutOfRange { joint: 5, .. })
        ),
        "{err:?}"
    );
    // A velocity above the model's maximum.
    let err = robot
        .send_raw(&raw(jt(2, 300.0), JointsDeg::ZERO), true)
        .await
        .unwrap_err();
    assert!(
        matches!(
            err,
            ClientError::Sample(SampleError::TooFast { joint: 2, .. })
        ),
        "{err:?}"
    );
    // A look-ahead the controller would extrapolate seconds ahead with.
    let text = format!(
        "1040 7 21 {t:.3} 1000 0 {} 0 0 0 0 0 0 0 0 0 0 0 0",
        "0 0 -90 0 -90 0"
    );
    assert!(matches!(
        robot.send_raw(&text, true).await.unwrap_err(),
        ClientError::Sample(SampleError::Lookahead { .. })
    ));
    assert_eq!(effective(&emu), before, "nothing was sent");
    assert_eq!(max_jt1_over(&emu, 1000).await, 0.0);
    // A sample that holds the robot where it is passes.
    robot
        .send_raw(&raw(JointsDeg::ZERO, JointsDeg::ZERO), true)
        .await
        .unwrap();
    assert_eq!(effective(&emu), before + 1);
}

#[tokio::test(start_paused = true)]
async fn streamed_spline_accelerations_are_limited_to_the_model() {
    // A coarse trajectory that starts abruptly: the spline's own acceleration at its first
    // knot is about 1000 deg/s² (4x JT1's maximum). It only shapes the extrapolation, so it is
    // limited, not refused; the stream runs and every 7 sent stays within the model.
    let emu = emulator();
    let robot = ready(&emu, 100.0).await;
    let points = (0..=50)
        .map(|k| TrajectoryPoint::new(k as f64 * 0.02, with_jt1(0.1 * k as f64)))
        .collect();
    let traj = Trajectory::new(points).unwrap();
    let model = RobotModel::fs020n();
    assert!(traj.sample(0.001).acceleration[0] > 900.0);
    assert!(traj.sample_for_streaming(0.001, &model).acceleration[0] <= 235.0);
    // Samples the controller extrapolates carry the limited acceleration...
    let options = StreamOptions {
        target_pacing: TargetPacing::Extrapolated,
        ..StreamOptions::default()
    };
    let handle = robot.stream(traj.clone(), options).await.unwrap();
    let mut max_a: f64 = 0.0;
    while !handle.is_finished() {
        if let Some(Command::StreamedMove(s)) = newest(&emu) {
            max_a = max_a.max(s.acceleration[0].abs());
        }
        sleep_ms(5).await;
    }
    let report = handle.wait().await.unwrap();
    assert_eq!(report.outcome, StreamOutcome::Completed);
    assert!(max_a > 0.0 && max_a <= 235.0, "{max_a}");
    // ...held targets (the default) none: each is a point of the trajectory, to stay at.
    robot
        .move_joints_and_wait(home(), Completion::default())
        .await
        .unwrap();
    let handle = robot
        .stream(traj.clone(), StreamOptions::default())
        .await
        .unwrap();
    let mut sent = 0;
    while !handle.is_finished() {
        if let Some(Command::StreamedMove(s)) = newest(&emu) {
            assert_eq!(
                (s.velocity, s.acceleration),
                (JointsDeg::ZERO, JointsDeg::ZERO)
            );
            let jt1 = s.position[0];
            assert!((0.0..=5.0).contains(&jt1), "{jt1}");
            sent += 1;
        }
        sleep_ms(5).await;
    }
    assert_eq!(
        handle.wait().await.unwrap().outcome,
        StreamOutcome::Completed
    );
    assert!(sent > 0);
}

// ------------------------------------------------------------------ 2. cancel after the last sample

/// Streams at 10 % monitor speed (the arm lags far behind: samples extrapolated on every
/// pass, no lead), until every sample is sent.
async fn stream_until_done(
    emu: &fs020n_sim::Emulator,
) -> (fs020n_client::Robot, fs020n_client::StreamHandle) {
    let robot = ready(emu, 10.0).await;
    let options = StreamOptions {
        target_pacing: TargetPacing::Extrapolated,
        lag_compensation: LagCompensation::Off,
        ..StreamOptions::default()
    };
    let handle = robot
        .stream(jt1_ramp(0.0, 12.0, 1.0), options)
        .await
        .unwrap();
    while !handle.progress().done {
        sleep_ms(5).await;
    }
    assert!(!handle.is_finished(), "still settling");
    let j = emu.with(|c| c.joints())[0];
    assert!(j < 9.0, "the arm lags: {j}");
    (robot, handle)
}

#[tokio::test(start_paused = true)]
async fn cancelling_a_stream_while_it_settles_brakes_and_reports_cancelled() {
    let emu = emulator();
    let (_robot, handle) = stream_until_done(&emu).await;
    let at_cancel = emu.with(|c| c.joints())[0];
    handle.cancel().await.unwrap();
    let report = handle.wait().await.unwrap();
    assert_eq!(report.outcome, StreamOutcome::Cancelled);
    assert!(!report.settled);
    assert_eq!(newest(&emu), Some(Command::StopProgram));
    let end = max_jt1_over(&emu, 3000).await;
    assert!(
        end < at_cancel + 3.0 && end < 11.0,
        "braked near {at_cancel}, went on to {end}"
    );
}

#[tokio::test(start_paused = true)]
async fn dropping_a_stream_handle_while_it_settles_brakes() {
    let emu = emulator();
    let (_robot, handle) = stream_until_done(&emu).await;
    let at_drop = emu.with(|c| c.joints())[0];
    drop(handle);
    let end = max_jt1_over(&emu, 3000).await;
    assert_eq!(newest(&emu), Some(Command::StopProgram));
    assert!(
        end < at_drop + 3.0 && end < 11.0,
        "braked near {at_drop}, went on to {end}"
    );
}

// ------------------------------------------------------------------ 3. cancel while starting

#[tokio::test(start_paused = true)]
async fn a_cancel_while_a_stream_starts_stops_it_before_any_sample() {
    let emu = emulator();
    let robot = ready(&emu, 100.0).await;
    let (stream, cancel) = tokio::join!(
        robot.stream(jt1_ramp(0.0, 10.0, 1.0), StreamOptions::default()),
        robot.cancel()
    );
    cancel.unwrap();
    assert!(
        matches!(stream, Err(ClientError::Cancelled(_))),
        "{stream:?}"
    );
    assert_eq!(robot.stats().stream_samples, 0);
    assert_eq!(max_jt1_over(&emu, 2000).await, 0.0);
    assert_eq!(newest(&emu), Some(Command::StopProgram));
    // Motion is accepted again after a start (the cancel ended the program).
    robot.start().await.unwrap();
    assert!(robot.move_joints(with_jt1(1.0)).await.is_ok());
}

#[tokio::test(start_paused = true)]
async fn a_cancel_while_a_pose_move_starts_stops_it() {
    let emu = emulator();
    let robot = ready(&emu, 100.0).await;
    let model = RobotModel::fs020n();
    let pose = model.forward(&with_jt1(20.0).to_rad()).to_xyzoat();
    let (mv, cancel) = tokio::join!(robot.move_pose(pose), robot.cancel());
    cancel.unwrap();
    assert!(matches!(mv, Err(ClientError::Cancelled(_))), "{mv:?}");
    assert_eq!(max_jt1_over(&emu, 2000).await, 0.0);
    assert_eq!(newest(&emu), Some(Command::StopProgram));
}

// ------------------------------------------------------------------ 4. dropped move future

#[tokio::test(start_paused = true)]
async fn a_dropped_move_joints_future_does_not_move_the_robot() {
    let emu = emulator();
    let robot = ready(&emu, 100.0).await;
    let before = effective(&emu);
    let refused = robot.stats().refused_before_sending;
    let r = tokio::time::timeout(Duration::ZERO, robot.move_joints(with_jt1(20.0))).await;
    assert!(r.is_err(), "the timeout elapsed before the reply");
    assert_eq!(max_jt1_over(&emu, 2000).await, 0.0);
    assert_eq!(effective(&emu), before);
    assert_eq!(robot.stats().refused_before_sending, refused + 1);
    // The session is fine.
    assert!(robot.poll().await.is_ok());
}

// ------------------------------------------------------------------ 5. raw speed, raw while streaming

#[tokio::test(start_paused = true)]
async fn raw_speeds_outside_1_to_100_percent_are_refused() {
    let emu = emulator();
    let robot = ready(&emu, 20.0).await;
    let before = effective(&emu);
    for text in ["1040 3 1 500", "1040 3 1 0.0001", "1040 3 1 -5", "1040 3 0"] {
        let err = robot.send_raw(text, false).await.unwrap_err();
        assert!(matches!(err, ClientError::Speed { .. }), "{text}: {err:?}");
    }
    assert_eq!(effective(&emu), before);
    assert_eq!(emu.with(|c| c.monitor_speed()), 20.0);
    robot.send_raw("1040 3 1 100", false).await.unwrap();
    assert_eq!(emu.with(|c| c.monitor_speed()), 100.0);
}

#[tokio::test(start_paused = true)]
async fn raw_requests_that_would_pause_a_stream_are_refused() {
    let emu = emulator();
    let robot = ready(&emu, 100.0).await;
    let handle = robot
        .stream(jt1_ramp(0.0, 10.0, 2.0), StreamOptions::default())
        .await
        .unwrap();
    sleep_ms(300).await;
    for text in ["1040 0 0", "1040 4 0", "1040 9 0", "1040.0 0 0", "1040 1 0"] {
        let err = robot.send_raw(text, false).await.unwrap_err();
        assert!(matches!(err, ClientError::Busy(_)), "{text}: {err:?}");
        assert!(
            matches!(newest(&emu), Some(Command::StreamedMove(_))),
            "{text} reached the controller"
        );
    }
    // Polls with another version are fine.
    assert!(robot.send_raw("0 0 0", false).await.is_ok());
    assert!(robot.send_raw(" 1040 0 0", false).await.is_ok());
    let report = handle.wait().await.unwrap();
    assert_eq!(report.outcome, StreamOutcome::Completed);
    assert!(report.settled, "{report:?}");
    assert_eq!(report.underruns, 0);
    // A raw cancel still ends a stream (and brakes).
    let handle = robot
        .stream(jt1_ramp(10.0, 0.0, 2.0), StreamOptions::default())
        .await
        .unwrap();
    sleep_ms(300).await;
    robot.send_raw("1040 5 0", false).await.unwrap();
    let report = handle.wait().await.unwrap();
    assert_eq!(report.outcome, StreamOutcome::Cancelled);
}

// ------------------------------------------------------------------ 6. timeouts

#[tokio::test(start_paused = true)]
async fn a_huge_move_timeout_does_not_panic() {
    let emu = emulator();
    let robot = ready(&emu, 100.0).await;
    let mv = robot.move_joints(with_jt1(5.0)).await.unwrap();
    let report = mv
        .wait(Completion {
            timeout: Some(Duration::MAX),
            ..Completion::default()
        })
        .await
        .expect("the move completes");
    assert!(report.error_deg <= 0.1);
}

#[tokio::test(start_paused = true)]
async fn an_invalid_completion_is_refused_and_the_move_cancelled() {
    let emu = emulator();
    let robot = ready(&emu, 10.0).await;
    for bad in [
        Completion {
            tolerance_deg: f64::NAN,
            ..Completion::default()
        },
        Completion {
            tolerance_deg: 0.0,
            ..Completion::default()
        },
        Completion {
            settle: Duration::MAX,
            ..Completion::default()
        },
    ] {
        let mv = robot.move_joints(with_jt1(30.0)).await.unwrap();
        let err = mv.wait(bad).await.unwrap_err();
        assert!(matches!(err, ClientError::Config(_)), "{err:?}");
        assert_eq!(newest(&emu), Some(Command::StopProgram));
    }
}

#[tokio::test(start_paused = true)]
async fn a_huge_stream_end_timeout_is_refused_before_sending() {
    let emu = emulator();
    let robot = ready(&emu, 100.0).await;
    let before = effective(&emu);
    let opts = StreamOptions {
        end_timeout: Duration::MAX,
        ..StreamOptions::default()
    };
    let err = robot
        .stream(jt1_ramp(0.0, 5.0, 1.0), opts)
        .await
        .unwrap_err();
    assert!(
        matches!(
            err,
            ClientError::Trajectory(TrajectoryError::Options(OptionError::Timeout {
                option: "end_timeout",
                ..
            }))
        ),
        "{err:?}"
    );
    assert!(err.to_string().contains("end_timeout"), "{err}");
    assert_eq!(effective(&emu), before);
    // One day is accepted (and a stream that settles does not wait for it).
    let opts = StreamOptions {
        end_timeout: Duration::from_secs(86_400),
        ..StreamOptions::default()
    };
    let report = robot
        .stream(jt1_ramp(0.0, 5.0, 1.0), opts)
        .await
        .unwrap()
        .wait()
        .await
        .unwrap();
    assert!(report.settled, "{report:?}");
}
