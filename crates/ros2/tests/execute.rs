//! Goals executed on the in-memory emulator on virtual time: success within the goal
//! tolerances, feedback, cancel (the robot brakes), an E-stop (aborted with an error code), a
//! path tolerance, and the refusals made before anything moves.
#![allow(clippy::expect_used)] // test code: a failed expectation is a failed test

use std::sync::{Arc, Mutex};
use std::time::Duration;

use fs020n_client::{BoxedStream, ClientConfig, ConnectFuture, Connector, Robot};
use fs020n_kin::RobotModel;
use fs020n_proto::JointsDeg;
use fs020n_ros2::execute::{execute, GoalEnd, Outcome};
use fs020n_ros2::goal::plan;
use fs020n_ros2::msg::{
    error_code, Duration as RosDuration, FollowJointTrajectoryGoal, JointTolerance,
    JointTrajectoryPoint, Time,
};
use fs020n_ros2::ExecutionConfig;
use fs020n_sim::{ControllerConfig, Emulator};
use tokio::sync::{mpsc, watch};

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

async fn ready() -> (Emulator, Robot) {
    let emu = Emulator::new(ControllerConfig::default());
    let robot = Robot::connect_with(
        EmuConnector(Arc::new(Mutex::new(emu.clone()))),
        ClientConfig::default(),
    )
    .await
    .expect("connect");
    robot.set_speed(100.0).await.expect("speed");
    robot.start().await.expect("start");
    (emu, robot)
}

fn names() -> [String; 6] {
    std::array::from_fn(|i| format!("joint_{}", i + 1))
}

fn home() -> JointsDeg {
    JointsDeg::new([0.0, 0.0, -90.0, 0.0, -90.0, 0.0])
}

/// JT1 from home to `deg` in `secs`, `steps` points, the first at `secs / steps`.
fn jt1_goal(deg: f64, secs: f64, steps: usize) -> FollowJointTrajectoryGoal {
    let mut g = FollowJointTrajectoryGoal::default();
    g.trajectory.joint_names = names().to_vec();
    for k in 1..=steps {
        let f = k as f64 / steps as f64;
        let mut q = home();
        // Smooth (cosine) profile so that the spline stays within the model's accelerations.
        q[0] = deg * (1.0 - (std::f64::consts::PI * f).cos()) / 2.0;
        g.trajectory.points.push(JointTrajectoryPoint {
            positions: q.iter().map(|d| d.to_radians()).collect(),
            time_from_start: RosDuration::from_secs_f64(secs * f),
            ..Default::default()
        });
    }
    g
}

async fn run(
    robot: &Robot,
    goal: &FollowJointTrajectoryGoal,
    cancel: watch::Receiver<bool>,
) -> (
    Outcome,
    Vec<fs020n_ros2::msg::FollowJointTrajectoryFeedback>,
) {
    let exec = ExecutionConfig::default();
    let current = robot.poll().await.expect("poll").joints;
    let p = plan(
        goal,
        &names(),
        &RobotModel::fs020n(),
        &exec,
        &current,
        Time::now(),
    )
    .expect("a valid goal");
    let (tx, mut rx) = mpsc::channel(10_000);
    let outcome = execute(
        robot,
        &p,
        &exec,
        &names(),
        Duration::from_millis(50),
        cancel,
        &tx,
    )
    .await;
    drop(tx);
    let mut fb = Vec::new();
    while let Some(f) = rx.recv().await {
        fb.push(f);
    }
    (outcome, fb)
}

#[tokio::test(start_paused = true)]
async fn a_goal_is_followed_and_succeeds_with_feedback() {
    let (emu, robot) = ready().await;
    let (_tx, cancel) = watch::channel(false);
    let (outcome, feedback) = run(&robot, &jt1_goal(20.0, 2.0, 20), cancel).await;
    assert_eq!(outcome.end, GoalEnd::Succeeded, "{outcome:?}");
    assert_eq!(outcome.result.error_code, error_code::SUCCESSFUL);
    let at = emu.with(|c| c.joints());
    assert!((at[0] - 20.0).abs() < 0.01f64.to_degrees(), "{at:?}");
    // Feedback every 50 ms for about 2 s, in the goal's joint order, desired moving forward.
    assert!(feedback.len() >= 20, "{}", feedback.len());
    assert_eq!(feedback[0].joint_names, names().to_vec());
    let desired: Vec<f64> = feedback.iter().map(|f| f.desired.positions[0]).collect();
    assert!(
        desired.windows(2).all(|w| w[1] >= w[0] - 1e-12),
        "{desired:?}"
    );
    let last = feedback.last().unwrap();
    for j in 0..6 {
        let e = last.desired.positions[j] - last.actual.positions[j];
        assert!((last.error.positions[j] - e).abs() < 1e-12);
    }
}

#[tokio::test(start_paused = true)]
async fn cancel_brakes_short_of_the_goal() {
    let (emu, robot) = ready().await;
    let (tx, cancel) = watch::channel(false);
    let goal = jt1_goal(60.0, 6.0, 30);
    let canceller = async {
        tokio::time::sleep(Duration::from_secs(2)).await;
        tx.send_replace(true);
    };
    let ((outcome, _), ()) = tokio::join!(run(&robot, &goal, cancel), canceller);
    assert_eq!(outcome.end, GoalEnd::Canceled, "{outcome:?}");
    tokio::time::sleep(Duration::from_secs(2)).await;
    let rest = emu.with(|c| c.joints())[0];
    tokio::time::sleep(Duration::from_secs(1)).await;
    assert!(rest > 1.0 && rest < 40.0, "{rest}");
    assert!(
        (emu.with(|c| c.joints())[0] - rest).abs() < 1e-9,
        "still moving"
    );
    assert!(robot.is_connected());
}

#[tokio::test(start_paused = true)]
async fn an_emergency_stop_aborts_with_path_tolerance_violated_and_the_remedy() {
    let (emu, robot) = ready().await;
    let (_tx, cancel) = watch::channel(false);
    let goal = jt1_goal(60.0, 6.0, 30);
    let estop = async {
        tokio::time::sleep(Duration::from_secs(2)).await;
        emu.with(|c| c.set_estop(true));
    };
    let ((outcome, _), ()) = tokio::join!(run(&robot, &goal, cancel), estop);
    assert_eq!(outcome.end, GoalEnd::Aborted, "{outcome:?}");
    assert_eq!(
        outcome.result.error_code,
        error_code::PATH_TOLERANCE_VIOLATED
    );
    assert!(
        outcome.result.error_string.contains("E3808"),
        "{}",
        outcome.result.error_string
    );
    assert!(
        outcome
            .result
            .error_string
            .contains(fs020n_client::ESTOP_REMEDY),
        "{}",
        outcome.result.error_string
    );
}

#[tokio::test(start_paused = true)]
async fn a_tight_path_tolerance_aborts_and_brakes() {
    let (emu, robot) = ready().await;
    let (_tx, cancel) = watch::channel(false);
    let mut goal = jt1_goal(60.0, 4.0, 20);
    goal.path_tolerance = vec![JointTolerance {
        name: "joint_1".into(),
        position: 1e-6,
        ..Default::default()
    }];
    let (outcome, _) = run(&robot, &goal, cancel).await;
    assert_eq!(outcome.end, GoalEnd::Aborted, "{outcome:?}");
    assert_eq!(
        outcome.result.error_code,
        error_code::PATH_TOLERANCE_VIOLATED
    );
    assert!(
        outcome.result.error_string.contains("joint_1"),
        "{outcome:?}"
    );
    tokio::time::sleep(Duration::from_secs(2)).await;
    assert!(emu.with(|c| c.joints())[0] < 55.0);
}

#[tokio::test(start_paused = true)]
async fn a_goal_the_robot_cannot_reach_in_time_violates_the_goal_tolerance() {
    let (emu, robot) = ready().await;
    // 10 % monitor speed: command 7 tracks slowly, far behind the trajectory.
    robot.set_speed(10.0).await.unwrap();
    let (_tx, cancel) = watch::channel(false);
    let mut goal = jt1_goal(40.0, 2.0, 20);
    goal.goal_time_tolerance = RosDuration {
        sec: 0,
        nanosec: 100_000_000,
    };
    let (outcome, _) = run(&robot, &goal, cancel).await;
    assert_eq!(outcome.end, GoalEnd::Aborted, "{outcome:?}");
    assert_eq!(
        outcome.result.error_code,
        error_code::GOAL_TOLERANCE_VIOLATED
    );
    assert!(outcome.result.error_string.contains("joint_1"));
    let _ = emu;
}

#[tokio::test(start_paused = true)]
async fn a_goal_with_the_program_stopped_is_refused_without_moving() {
    let (emu, robot) = ready().await;
    robot.stop_program().await.unwrap();
    // The program ends once the stop signal has been stable for 50 ms.
    tokio::time::sleep(Duration::from_millis(500)).await;
    let before = emu.with(|c| c.counters().effective_requests);
    let (_tx, cancel) = watch::channel(false);
    let (outcome, _) = run(&robot, &jt1_goal(10.0, 2.0, 10), cancel).await;
    assert_eq!(outcome.end, GoalEnd::Aborted);
    assert_eq!(outcome.result.error_code, error_code::INVALID_GOAL);
    assert!(
        outcome.result.error_string.contains("not running"),
        "{outcome:?}"
    );
    assert_eq!(emu.with(|c| c.counters().effective_requests), before);
    assert_eq!(emu.with(|c| c.joints()), home());
}

/// JT1 from `from` to `to` degrees (the rest at home) in `secs`, first point at `secs / steps`.
fn jt1_goal_between(from: f64, to: f64, secs: f64, steps: usize) -> FollowJointTrajectoryGoal {
    let mut g = jt1_goal(to - from, secs, steps);
    for p in &mut g.trajectory.points {
        p.positions[0] += from.to_radians();
    }
    g
}

#[tokio::test(start_paused = true)]
async fn a_cancel_is_an_own_stop_and_the_program_starts_again_for_the_next_goal() {
    let (emu, robot) = ready().await;
    let (tx, cancel) = watch::channel(false);
    let goal = jt1_goal(60.0, 6.0, 30);
    let canceller = async {
        tokio::time::sleep(Duration::from_secs(2)).await;
        tx.send_replace(true);
    };
    let ((outcome, _), ()) = tokio::join!(run(&robot, &goal, cancel), canceller);
    assert_eq!(outcome.end, GoalEnd::Canceled, "{outcome:?}");
    assert_eq!(outcome.program, fs020n_ros2::arming::GoalStop::ByTheNode);
    // At once, as the node does for the next goal: start, then follow from where it stopped.
    robot
        .start()
        .await
        .expect("start after the node's own stop");
    let here = robot.poll().await.expect("poll").joints;
    let (_tx2, cancel) = watch::channel(false);
    let back = jt1_goal_between(here[0], 0.0, 3.0, 15);
    let (outcome, _) = run(&robot, &back, cancel).await;
    assert_eq!(outcome.end, GoalEnd::Succeeded, "{outcome:?}");
    assert!(emu.with(|c| c.joints())[0].abs() < 0.01f64.to_degrees());
}

#[tokio::test(start_paused = true)]
async fn a_preempted_goal_ends_aborted_and_a_fault_is_not_an_own_stop() {
    let (emu, robot) = ready().await;
    let (tx, cancel) = watch::channel(false);
    let canceller = async {
        tokio::time::sleep(Duration::from_secs(1)).await;
        tx.send_replace(true);
    };
    let goal = jt1_goal(60.0, 6.0, 30);
    let ((outcome, _), ()) = tokio::join!(run(&robot, &goal, cancel), canceller);
    let preempted = outcome.preempted();
    assert_eq!(preempted.end, GoalEnd::Aborted);
    assert_eq!(preempted.result.error_code, error_code::INVALID_GOAL);
    assert!(preempted
        .result
        .error_string
        .contains("preempted by a new goal"));
    assert_eq!(preempted.program, fs020n_ros2::arming::GoalStop::ByTheNode);
    // An E-stop during a goal: a fault for the re-arm policy.
    robot.start().await.expect("start");
    let here = robot.poll().await.expect("poll").joints;
    let (_tx, cancel) = watch::channel(false);
    let estop = async {
        tokio::time::sleep(Duration::from_secs(1)).await;
        emu.with(|c| c.set_estop(true));
    };
    let goal = jt1_goal_between(here[0], here[0] + 40.0, 6.0, 30);
    let ((outcome, _), ()) = tokio::join!(run(&robot, &goal, cancel), estop);
    assert!(
        matches!(outcome.program, fs020n_ros2::arming::GoalStop::Fault(_)),
        "{outcome:?}"
    );
    // A fault is not turned into a preemption.
    assert_eq!(outcome.clone().preempted(), outcome);
}
