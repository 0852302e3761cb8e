//! Online servoing against the in-memory emulator on virtual time.
#![allow(clippy::expect_used)]

mod common;

use std::time::Duration;

use common::*;
use fs020n_client::{
    Blocker, ClientError, JointsDeg, SampleError, ServoHandle, ServoOptions, ServoOutcome,
    ServoSample, TrajectoryError, WatchdogAction,
};
use fs020n_proto::Command;
use fs020n_sim::{Emulator, Fault, MotionTaskState};

/// JT1 position and velocity of a smooth move from 0 to `amp` degrees over `secs`.
fn cosine(amp: f64, secs: f64, t: f64) -> (f64, f64) {
    let w = std::f64::consts::PI / secs;
    let t = t.clamp(0.0, secs);
    (
        amp * (0.5 - 0.5 * (w * t).cos()),
        amp * 0.5 * w * (w * t).sin(),
    )
}

/// Pushes the cosine move at `hz` for `secs` (with or without velocities); returns the last
/// position pushed.
async fn push_cosine(
    servo: &ServoHandle,
    amp: f64,
    secs: f64,
    hz: f64,
    with_velocity: bool,
) -> JointsDeg {
    let n = (secs * hz).round() as usize;
    let mut last = home();
    for k in 0..=n {
        let t = k as f64 / hz;
        let (p, v) = cosine(amp, secs, t);
        last = with_jt1(p);
        let mut s = ServoSample::new(last);
        if with_velocity {
            let mut vel = JointsDeg::ZERO;
            vel[0] = v;
            s = s.with_velocity(vel);
        }
        servo.push(s).expect("a valid sample is accepted");
        tokio::time::sleep(Duration::from_secs_f64(1.0 / hz)).await;
    }
    last
}

fn newest(emu: &Emulator) -> Option<Command> {
    emu.with(|c| c.native().newest_command())
}

#[tokio::test(start_paused = true)]
async fn pushed_samples_are_followed_and_stop_halts() {
    let emu = emulator();
    let robot = ready(&emu, 100.0).await;
    let servo = robot.servo(ServoOptions::default()).await.unwrap();
    let last = push_cosine(&servo, 20.0, 2.0, 50.0, true).await;
    // Keep holding the last position while the arm settles.
    for _ in 0..25 {
        servo.push(last).unwrap();
        sleep_ms(20).await;
    }
    let live = servo.stats();
    assert!(live.pushes >= 125, "{live:?}");
    servo.stop();
    let report = servo.wait().await.unwrap();
    println!("{report:#?}");
    assert_eq!(report.outcome, ServoOutcome::Stopped);
    let s = report.stats;
    assert_eq!(s.pushes, 126);
    assert_eq!(s.refused, 0);
    // Pushed every 20 ms, each sent before the next push.
    assert_eq!(s.sent + s.coalesced + s.unsent, s.pushes, "{s:?}");
    assert!(s.unsent <= 1, "{s:?}");
    assert!(s.sent >= 120, "{s:?}");
    assert!(s.push_to_send_max < Duration::from_millis(20), "{s:?}");
    assert!(s.tracking_samples >= 120);
    assert!(s.tracking_error_max_deg < 1.5, "{s:?}");
    let j = emu.with(|c| c.joints());
    assert!((j[0] - 20.0).abs() < 0.3, "{j}");
    // The stop braked and ended the program (5 then 2): a sure stop.
    assert_eq!(newest(&emu), Some(Command::StopProgram));
    sleep_ms(100).await; // signal 2007 acts once stable for 50 ms
    assert_eq!(emu.with(|c| c.task()), MotionTaskState::NotRunning);
    assert_eq!(robot.stats().stream_samples, s.sent);
    // The motion channel is free again.
    robot.start().await.unwrap();
    assert!(robot.move_joints(home()).await.is_ok());
}

#[tokio::test(start_paused = true)]
async fn samples_are_stamped_with_the_controller_time_of_the_push() {
    let emu = emulator();
    let robot = ready(&emu, 100.0).await;
    // Let the clock estimate gather a few keep-alive round trips.
    sleep_ms(600).await;
    let servo = robot.servo(ServoOptions::default()).await.unwrap();
    let timer_at_push = emu.with(|c| c.native().timer1_s());
    servo.push(home()).unwrap();
    sleep_ms(5).await;
    match newest(&emu) {
        Some(Command::StreamedMove(s)) => {
            assert!(
                (s.t0_s - timer_at_push).abs() < 0.002,
                "stamp {} vs TIMER(1) {timer_at_push}",
                s.t0_s
            );
            assert_eq!(s.lookahead_passes, 2.0);
            assert_eq!(s.position, home());
            assert_eq!(s.velocity, JointsDeg::ZERO);
        }
        other => panic!("expected a command 7, got {other:?}"),
    }
    // Without a velocity, the velocity is the backward difference of the last two pushes.
    sleep_ms(15).await; // 20 ms after the first push
    servo.push(with_jt1(0.2)).unwrap();
    sleep_ms(5).await;
    match newest(&emu) {
        Some(Command::StreamedMove(s)) => {
            assert!((s.velocity[0] - 10.0).abs() < 1e-6, "{}", s.velocity);
            assert_eq!(s.velocity[1], 0.0);
        }
        other => panic!("expected a command 7, got {other:?}"),
    }
    servo.finish().await.unwrap();
}

#[tokio::test(start_paused = true)]
async fn pushes_faster_than_round_trips_are_coalesced() {
    let emu = emulator();
    let robot = ready(&emu, 100.0).await;
    let servo = robot.servo(ServoOptions::default()).await.unwrap();
    // Ten pushes without yielding: the sending task cannot run in between, so only the newest
    // is sent.
    for k in 0..10 {
        servo.push(with_jt1(k as f64 * 0.01)).unwrap();
    }
    sleep_ms(10).await;
    let s = servo.stats();
    assert_eq!((s.pushes, s.sent, s.coalesced), (10, 1, 9), "{s:?}");
    match newest(&emu) {
        Some(Command::StreamedMove(sample)) => {
            assert!(sample.position.max_abs_diff(&with_jt1(0.09)) < 1e-6)
        }
        other => panic!("{other:?}"),
    }
    servo.finish().await.unwrap();
}

#[tokio::test(start_paused = true)]
async fn the_watchdog_stops_the_program_when_the_pushes_stop() {
    let emu = emulator();
    let robot = ready(&emu, 100.0).await;
    let servo = robot.servo(ServoOptions::default()).await.unwrap();
    // Moving at 10 deg/s when the source goes silent.
    let mut q = home();
    let mut v = JointsDeg::ZERO;
    v[0] = 10.0;
    for k in 0..50 {
        q[0] = k as f64 * 0.2;
        servo.push(ServoSample::new(q).with_velocity(v)).unwrap();
        sleep_ms(20).await;
    }
    let last_pushed = q[0];
    sleep_ms(1000).await;
    assert!(servo.is_finished());
    // Later pushes say what happened and what to do.
    let err = servo.push(q).unwrap_err();
    let text = err.to_string();
    assert!(
        text.contains("watchdog") && text.contains("Robot::start"),
        "{text}"
    );
    let report = servo.wait().await.unwrap();
    assert_eq!(report.outcome, ServoOutcome::Watchdog);
    assert_eq!(newest(&emu), Some(Command::StopProgram));
    assert_eq!(emu.with(|c| c.task()), MotionTaskState::NotRunning);
    // Stopped soon after the last sample: at most the watchdog's 0.2 s plus the look-ahead
    // of extrapolation at 10 deg/s beyond the last pushed position.
    let j = emu.with(|c| c.joints())[0];
    assert!(j < last_pushed + 3.5, "ran on to {j} after {last_pushed}");
    let still = emu.with(|c| c.joints());
    sleep_ms(2000).await;
    assert_eq!(emu.with(|c| c.joints()), still, "the arm stays still");
    // Motion needs start() again.
    assert!(matches!(
        robot.move_joints(home()).await,
        Err(ClientError::Blocked(b)) if b == vec![Blocker::ProgramNotRunning]
    ));
    robot.start().await.unwrap();
    assert!(robot.servo(ServoOptions::default()).await.is_ok());
}

#[tokio::test(start_paused = true)]
async fn the_watchdog_can_brake_instead() {
    let emu = emulator();
    let robot = ready(&emu, 100.0).await;
    let servo = robot
        .servo(ServoOptions {
            on_watchdog: WatchdogAction::Brake,
            watchdog: Duration::from_millis(100),
            ..ServoOptions::default()
        })
        .await
        .unwrap();
    push_cosine(&servo, 5.0, 0.5, 50.0, false).await;
    sleep_ms(300).await;
    let report = servo.wait().await.unwrap();
    assert_eq!(report.outcome, ServoOutcome::Watchdog);
    assert_eq!(newest(&emu), Some(Command::CancelMotion));
    assert_eq!(emu.with(|c| c.task()), MotionTaskState::Running);
}

#[tokio::test(start_paused = true)]
async fn no_watchdog_before_the_first_push() {
    let emu = emulator();
    let robot = ready(&emu, 100.0).await;
    let servo = robot.servo(ServoOptions::default()).await.unwrap();
    sleep_ms(2000).await;
    assert!(!servo.is_finished());
    assert_eq!(emu.with(|c| c.task()), MotionTaskState::Running);
    servo.push(home()).unwrap();
    servo.finish().await.unwrap();
}

#[tokio::test(start_paused = true)]
async fn bad_pushes_are_refused_before_sending() {
    let emu = emulator();
    let robot = ready(&emu, 100.0).await;
    let servo = robot.servo(ServoOptions::default()).await.unwrap();
    let before = effective(&emu);
    // The first sample must start where the robot is.
    assert!(matches!(
        servo.push(with_jt1(5.0)),
        Err(ClientError::Trajectory(TrajectoryError::StartTooFar {
            joint: 1,
            ..
        }))
    ));
    // Out of range, not finite.
    assert!(matches!(
        servo.push(with_jt1(170.0)),
        Err(ClientError::Limit(_))
    ));
    assert!(matches!(
        servo.push(with_jt1(f64::NAN)),
        Err(ClientError::NonFinite { .. })
    ));
    // Velocity and acceleration above the model's.
    let mut fast = JointsDeg::ZERO;
    fast[0] = 500.0;
    assert!(matches!(
        servo.push(ServoSample::new(home()).with_velocity(fast)),
        Err(ClientError::Sample(SampleError::TooFast { joint: 1, .. }))
    ));
    assert!(matches!(
        servo.push(ServoSample::new(home()).with_acceleration(fast)),
        Err(ClientError::Sample(SampleError::AccelerationTooHigh {
            joint: 1,
            ..
        }))
    ));
    sleep_ms(50).await;
    assert_eq!(effective(&emu), before, "nothing was sent");
    // A valid one is accepted after the refusals.
    servo.push(home()).unwrap();
    sleep_ms(20).await;
    // A jump beyond max_step + max speed x gap (JT1: 190 deg/s x 20 ms = 3.8 deg, + 2 deg).
    assert!(matches!(
        servo.push(with_jt1(6.0)),
        Err(ClientError::Trajectory(TrajectoryError::StepTooLarge {
            joint: 1,
            ..
        }))
    ));
    // Within it (with a velocity given: the estimate, 250 deg/s, would be too fast).
    assert!(matches!(
        servo.push(with_jt1(5.0)),
        Err(ClientError::Sample(SampleError::TooFast { joint: 1, .. }))
    ));
    servo
        .push(ServoSample::new(with_jt1(5.0)).with_velocity(JointsDeg::ZERO))
        .unwrap();
    sleep_ms(20).await;
    let stats = servo.stats();
    assert_eq!((stats.pushes, stats.refused), (2, 7), "{stats:?}");
    assert_eq!(robot.stats().refused_before_sending, 7);
    servo.finish().await.unwrap();
}

#[tokio::test(start_paused = true)]
async fn an_extrapolation_that_could_leave_the_range_is_refused() {
    let model = fs020n_kin::RobotModel::fs020n();
    let max1 = model.joints[0].max_deg;
    let cfg = fs020n_sim::ControllerConfig {
        joints: with_jt1(max1 - 1.0),
        ..fs020n_sim::ControllerConfig::default()
    };
    let emu = Emulator::new(cfg);
    let robot = ready(&emu, 100.0).await;
    let servo = robot.servo(ServoOptions::default()).await.unwrap();
    let mut v = JointsDeg::ZERO;
    v[0] = 10.0; // 1 deg from the limit, 10 deg/s: out within 0.1 s
    let err = servo
        .push(ServoSample::new(with_jt1(max1 - 1.0)).with_velocity(v))
        .unwrap_err();
    assert!(
        matches!(
            err,
            ClientError::Sample(SampleError::ExtrapolatedOutOfRange { joint: 1, .. })
        ),
        "{err:?}"
    );
    servo.finish().await.unwrap();
}

#[tokio::test(start_paused = true)]
async fn one_motion_source_at_a_time() {
    let emu = emulator();
    let robot = ready(&emu, 100.0).await;
    let servo = robot.servo(ServoOptions::default()).await.unwrap();
    assert!(matches!(
        robot.move_joints(home()).await,
        Err(ClientError::Busy(_))
    ));
    assert!(matches!(
        robot.servo(ServoOptions::default()).await,
        Err(ClientError::Busy(_))
    ));
    assert!(matches!(
        robot.set_speed(50.0).await,
        Err(ClientError::Busy(_))
    ));
    servo.finish().await.unwrap();
    robot.start().await.unwrap();
    assert!(robot.servo(ServoOptions::default()).await.is_ok());
}

#[tokio::test(start_paused = true)]
async fn a_servo_is_refused_while_the_status_blocks_motion() {
    let emu = emulator();
    let robot = connect(&emu).await;
    assert!(matches!(
        robot.servo(ServoOptions::default()).await,
        Err(ClientError::Blocked(b)) if b == vec![Blocker::ProgramNotRunning]
    ));
    robot.start().await.unwrap();
    assert!(matches!(
        robot
            .servo(ServoOptions {
                watchdog: Duration::from_secs(2),
                ..ServoOptions::default()
            })
            .await,
        Err(ClientError::Trajectory(TrajectoryError::Options(_)))
    ));
}

#[tokio::test(start_paused = true)]
async fn hold_mid_servo_aborts_and_does_not_resume() {
    let emu = emulator();
    let robot = ready(&emu, 100.0).await;
    let servo = robot
        .servo(ServoOptions {
            watchdog: Duration::from_millis(500),
            ..ServoOptions::default()
        })
        .await
        .unwrap();
    let mut q = home();
    for k in 0..25 {
        q[0] = k as f64 * 0.4;
        servo.push(q).unwrap();
        sleep_ms(20).await;
    }
    emu.with(|c| c.set_run(false));
    // The source keeps pushing; the next reply shows HOLD.
    let mut err = None;
    for k in 25..60 {
        q[0] = k as f64 * 0.4;
        if let Err(e) = servo.push(q) {
            err = Some(e);
            break;
        }
        sleep_ms(20).await;
    }
    let err = err.expect("a push fails once the servo is aborted");
    assert_eq!(
        err,
        ClientError::Aborted {
            during: "servo",
            blockers: vec![Blocker::Hold]
        }
    );
    assert!(err.to_string().contains("switch RUN/HOLD to RUN"), "{err}");
    assert_eq!(servo.wait().await.unwrap_err(), err);
    assert_eq!(newest(&emu), Some(Command::StopProgram));
    let held = emu.with(|c| c.joints());
    emu.with(|c| c.set_run(true));
    sleep_ms(3000).await;
    let j = emu.with(|c| c.joints());
    assert!(j.max_abs_diff(&held) < 1.0, "resumed: {held} -> {j}");
}

#[tokio::test(start_paused = true)]
async fn robot_cancel_ends_the_servo() {
    let emu = emulator();
    let robot = ready(&emu, 100.0).await;
    let servo = robot.servo(ServoOptions::default()).await.unwrap();
    servo.push(home()).unwrap();
    sleep_ms(20).await;
    robot.cancel().await.unwrap();
    assert!(matches!(servo.push(home()), Err(ClientError::Cancelled(_))));
    let report = servo.wait().await.unwrap();
    assert_eq!(report.outcome, ServoOutcome::Cancelled);
    // Robot::cancel stops for sure (5 then 2); the servo adds nothing.
    assert_eq!(newest(&emu), Some(Command::StopProgram));
}

#[tokio::test(start_paused = true)]
async fn dropping_the_handle_halts() {
    let emu = emulator();
    let robot = ready(&emu, 100.0).await;
    let servo = robot.servo(ServoOptions::default()).await.unwrap();
    push_cosine(&servo, 10.0, 0.5, 50.0, true).await;
    drop(servo);
    sleep_ms(50).await;
    assert_eq!(newest(&emu), Some(Command::StopProgram));
    robot.start().await.unwrap();
    assert!(robot.move_joints(home()).await.is_ok(), "channel freed");
}

#[tokio::test(start_paused = true)]
async fn a_lost_link_mid_servo_is_reported_to_push_and_wait() {
    let emu = emulator();
    let robot = ready(&emu, 100.0).await;
    let servo = robot.servo(ServoOptions::default()).await.unwrap();
    servo.push(home()).unwrap();
    sleep_ms(20).await;
    emu.with(|c| c.inject(Fault::CloseConnection));
    servo.push(home()).unwrap();
    sleep_ms(50).await;
    let err = servo.push(home()).unwrap_err();
    assert!(err.is_link_dead(), "{err:?}");
    assert!(servo.wait().await.unwrap_err().is_link_dead());
}

#[tokio::test(start_paused = true)]
async fn estop_mid_servo_names_e3808() {
    let emu = emulator();
    let robot = ready(&emu, 100.0).await;
    let servo = robot.servo(ServoOptions::default()).await.unwrap();
    servo.push(home()).unwrap();
    sleep_ms(20).await;
    emu.with(|c| c.set_estop(true));
    servo.push(home()).unwrap();
    let err = servo.wait().await.unwrap_err();
    let text = err.to_string();
    assert!(text.contains("E3808") && text.contains("servo"), "{text}");
    assert!(err.blockers().contains(&Blocker::ControllerError(
        fs020n_proto::ErrorCode::EMERGENCY_STOP
    )));
}
