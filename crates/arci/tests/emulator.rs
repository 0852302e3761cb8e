//! The arci client against the in-memory emulator on virtual time.
#![allow(clippy::expect_used)] // test code: a failed expectation is a failed test

use std::sync::{Arc, Mutex};
use std::time::Duration;

use arci::{JointTrajectoryClient, TrajectoryPoint};
use fs020n_arci::Fs020nClient;
use fs020n_client::{BoxedStream, ClientConfig, ConnectFuture, Connector, Robot};
use fs020n_sim::{ControllerConfig, Emulator};

struct EmuConnector(Arc<Mutex<Emulator>>);

impl Connector for EmuConnector {
    fn connect(&self) -> ConnectFuture<'_> {
        let emu = self.0.lock().unwrap().clone();
        Box::pin(async move { Ok(Box::new(emu.connect()?) as BoxedStream) })
    }

    fn describe(&self) -> String {
        "in-memory emulator".into()
    }
}

async fn ready() -> (Emulator, Fs020nClient) {
    let emu = Emulator::new(ControllerConfig::default());
    let robot = Robot::connect_with(
        EmuConnector(Arc::new(Mutex::new(emu.clone()))),
        ClientConfig::default(),
    )
    .await
    .expect("connect");
    robot.set_speed(100.0).await.unwrap();
    robot.start().await.unwrap();
    let arm = Fs020nClient::new(Arc::new(robot)).unwrap();
    (emu, arm)
}

#[tokio::test(start_paused = true)]
async fn positions_and_trajectories_move_the_arm() {
    let (emu, arm) = ready().await;
    assert_eq!(arm.joint_names()[5], "joint_6");
    let home = arm.current_joint_positions().unwrap();
    assert!(
        (home[2] + std::f64::consts::FRAC_PI_2).abs() < 1e-9,
        "{home:?}"
    );
    let mut target = home.clone();
    target[0] = 0.3;
    arm.send_joint_positions(target.clone(), Duration::from_secs(2))
        .unwrap()
        .await
        .unwrap();
    assert!((emu.with(|c| c.joints())[0] - 0.3f64.to_degrees()).abs() < 0.5);
    let mut mid = target.clone();
    mid[1] = 0.2;
    arm.send_joint_trajectory(vec![
        TrajectoryPoint::new(mid, Duration::from_secs(2)),
        TrajectoryPoint::new(home.clone(), Duration::from_secs(4)),
    ])
    .unwrap()
    .await
    .unwrap();
    let at = arm.current_joint_positions().unwrap();
    for (a, h) in at.iter().zip(&home) {
        assert!((a - h).abs() < 0.01, "{at:?}");
    }
}

#[tokio::test(start_paused = true)]
async fn out_of_range_and_too_fast_are_refused_before_sending() {
    let (emu, arm) = ready().await;
    let before = emu.with(|c| c.counters().effective_requests);
    let mut far = arm.current_joint_positions().unwrap();
    far[0] = 3.0;
    match arm.send_joint_positions(far, Duration::from_secs(10)) {
        Err(arci::Error::OutOfLimit { name, .. }) => assert_eq!(name, "joint_1"),
        Err(e) => panic!("expected OutOfLimit, got {e}"),
        Ok(_) => panic!("an out-of-range target was accepted"),
    }
    let mut quick = arm.current_joint_positions().unwrap();
    quick[0] = 1.5;
    let e = arm
        .send_joint_positions(quick, Duration::from_millis(100))
        .err()
        .expect("too fast");
    assert!(e.to_string().contains("JT1"), "{e}");
    assert!(matches!(
        arm.send_joint_positions(vec![0.0; 5], Duration::from_secs(1)),
        Err(arci::Error::LengthMismatch { model: 6, input: 5 })
    ));
    assert_eq!(emu.with(|c| c.counters().effective_requests), before);
}

#[tokio::test(start_paused = true)]
async fn a_cancel_ends_the_wait_with_canceled() {
    let (_emu, arm) = ready().await;
    let mut target = arm.current_joint_positions().unwrap();
    target[0] = 1.0;
    let wait = arm
        .send_joint_positions(target, Duration::from_secs(6))
        .unwrap();
    let robot = arm.robot().clone();
    let cancel = async move {
        tokio::time::sleep(Duration::from_secs(1)).await;
        robot.cancel().await.unwrap();
    };
    let (r, ()) = tokio::join!(wait, cancel);
    assert!(matches!(r, Err(arci::Error::Canceled { .. })), "{r:?}");
}

/// openrr's teleop sends a target every cycle and never waits for the `WaitFuture`: every
/// command counts — the newest target is where the arm ends.
#[tokio::test(start_paused = true)]
async fn teleop_targets_every_cycle_without_waiting_end_at_the_newest() {
    let (emu, arm) = ready().await;
    let home = arm.current_joint_positions().unwrap();
    let mut target = home.clone();
    for k in 1..=20 {
        target[0] = home[0] + 0.01 * f64::from(k);
        let wait = arm
            .send_joint_positions(target.clone(), Duration::from_millis(500))
            .expect("every target is accepted at once");
        drop(wait); // as the teleop does
        tokio::time::sleep(Duration::from_millis(50)).await;
    }
    tokio::time::sleep(Duration::from_secs(3)).await;
    let at = emu.with(|c| c.joints())[0];
    assert!(
        (at - target[0].to_degrees()).abs() < 0.05,
        "the arm is at {at} deg, the newest target {} deg",
        target[0].to_degrees()
    );
}

/// While a trajectory runs, a newer command replaces the queued one: the replaced one ends
/// with Canceled ("superseded"), the running and the newest ones run to their end.
#[tokio::test(start_paused = true)]
async fn a_queued_command_replaced_by_a_newer_one_ends_canceled() {
    let (emu, arm) = ready().await;
    let home = arm.current_joint_positions().unwrap();
    let at = |deg: f64| {
        let mut t = home.clone();
        t[0] = deg.to_radians();
        t
    };
    let first = arm
        .send_joint_positions(at(10.0), Duration::from_secs(1))
        .unwrap();
    let second = arm
        .send_joint_positions(at(20.0), Duration::from_secs(1))
        .unwrap();
    let third = arm
        .send_joint_positions(at(5.0), Duration::from_secs(1))
        .unwrap();
    match second.await {
        Err(arci::Error::Canceled { message }) => {
            assert!(message.contains("superseded"), "{message}")
        }
        other => panic!("expected Canceled, got {other:?}"),
    }
    first.await.expect("the running command ends normally");
    third.await.expect("the newest command runs after it");
    assert!((emu.with(|c| c.joints())[0] - 5.0).abs() < 0.05);
    // Refusals found at the call still come back at once.
    let mut far = home.clone();
    far[0] = 3.0;
    assert!(matches!(
        arm.send_joint_positions(far, Duration::from_secs(10)),
        Err(arci::Error::OutOfLimit { .. })
    ));
}
