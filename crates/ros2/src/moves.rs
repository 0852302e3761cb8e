//! The node's moves on the robot, as the motion owner ([`crate::motion_owner`]) decides them:
//! a trajectory checked and planned against the robot now (the program started when the
//! re-arm policy allows it), the source's permit, and the servo of `~/commands`.

use std::sync::Arc;

use fs020n_client::{Robot, ServoHandle, ServoOptions};
use ros2_client::log::LogLevel;

use crate::forward::ForwardCommands;
use crate::goal::{plan, plan_preempting, GoalRefusal, Plan};
use crate::motion_owner::{Readiness, ServoStep, PROGRAM_END_POLL};
use crate::msg::{error_code, FollowJointTrajectoryGoal, Time};
use crate::shared::{lock, Shared};
use crate::source::{Action, Permit};

/// Checks a new goal that would preempt the running one, without acting: the robot's session
/// and the goal itself from where the arm is now. A goal that fails here is rejected and the
/// running goal goes on, as `joint_trajectory_controller` does.
pub(crate) async fn precheck(
    shared: &Shared,
    goal: &FollowJointTrajectoryGoal,
) -> Result<(), GoalRefusal> {
    let refuse = |m: String| GoalRefusal::new(error_code::INVALID_GOAL, m);
    let robot = shared.robot().map_err(refuse)?;
    let current = robot.status().status.joints;
    plan_preempting(
        goal,
        &shared.config.joint_names,
        &shared.model,
        &shared.config.execution,
        &current,
        Time::now(),
    )
    .map(|_| ())
}

/// Checks a new goal against the robot now (session, switches, program: [`ready_to_move`]) and
/// plans it; the source's permit for its path. A goal is an explicit request for motion. `preempting`: the goal replaces one the node just stopped.
pub(crate) async fn admit(
    shared: &Shared,
    goal: &FollowJointTrajectoryGoal,
    preempting: bool,
) -> Result<(Arc<Robot>, Plan, Permit), GoalRefusal> {
    let refuse = |m: String| GoalRefusal::new(error_code::INVALID_GOAL, m);
    let (robot, status) = ready_to_move(shared).await.map_err(refuse)?;
    let planner = if preempting { plan_preempting } else { plan };
    let p = planner(
        goal,
        &shared.config.joint_names,
        &shared.model,
        &shared.config.execution,
        &status.joints,
        Time::now(),
    )?;
    // The path as the robot will follow it: the points and the spline between them every
    // 10 ms (a source with a fence checks each of them, and the straight pieces between).
    let path = planned_path(&p.trajectory);
    let permit = shared
        .source
        .permit(Action::Trajectory(&path))
        .map_err(refuse)?;
    Ok((robot, p, permit))
}

/// Checks the robot now (session, switches, program) for an explicit request of motion (a
/// goal, a streamed trajectory, the first command of a servo), as the motion owner decides
/// ([`crate::motion_owner::MotionOwner::handle_readiness`]): when the program is not running
/// and the re-arm policy allows it, starts it (command 1). Returns the session and a fresh
/// status.
pub(crate) async fn ready_to_move(
    shared: &Shared,
) -> Result<(Arc<Robot>, fs020n_client::Status), String> {
    let robot = shared.robot()?;
    let since = tokio::time::Instant::now();
    let mut status = robot.poll().await.map_err(|e| e.to_string())?;
    loop {
        let now = tokio::time::Instant::now();
        let readiness = lock(&shared.motion).handle_readiness(&status, now, since);
        match readiness {
            Readiness::Ready => return Ok((robot, status)),
            Readiness::Refused(reason) => return Err(reason),
            Readiness::PollAgain => {
                tokio::time::sleep(PROGRAM_END_POLL).await;
                status = robot.poll().await.map_err(|e| e.to_string())?;
            }
            Readiness::StartProgram => {
                let _permit = shared
                    .source
                    .permit(Action::Start)
                    .map_err(|r| format!("the motion program was not started: {r}"))?;
                robot
                    .start()
                    .await
                    .map_err(|e| format!("could not start the motion program: {e}"))?;
                lock(&shared.motion).handle_started();
                status = robot.poll().await.map_err(|e| e.to_string())?;
                return Ok((robot, status));
            }
        }
    }
}

/// The positions of `trajectory` at its points and every 10 ms between them, in time order.
fn planned_path(trajectory: &fs020n_client::Trajectory) -> Vec<fs020n_kin::JointsDeg> {
    const STEP_S: f64 = 0.01;
    let (start, end) = (trajectory.start_s(), trajectory.end_s());
    let n = ((end - start) / STEP_S).ceil().clamp(0.0, 1e6) as usize;
    let mut path: Vec<_> = (0..=n)
        .map(|k| (start + k as f64 * STEP_S).min(end))
        .chain(trajectory.points().iter().map(|p| p.time_s))
        .map(|t| (t, trajectory.sample(t).position))
        .collect();
    path.sort_by(|a, b| a.0.total_cmp(&b.0));
    path.into_iter().map(|(_, q)| q).collect()
}

/// A servo fed by `~/commands`, with the source's permit it holds until it ends.
pub(crate) struct ServoRun {
    handle: ServoHandle,
    permit: Permit,
}

impl ServoRun {
    /// The servo ended by itself (its watchdog, a fault, the link).
    pub(crate) fn is_finished(&self) -> bool {
        self.handle.is_finished()
    }
}

/// Handles one `~/commands` message as the motion owner decides
/// ([`crate::motion_owner::MotionOwner::handle_servo_command`]): checks it, opens the servo for
/// the first one (the same readiness and re-arm policy as a goal), checks the sample with the
/// source (a fence) and pushes it. `Err`: why it was refused (nothing was sent).
pub(crate) async fn command(
    shared: &Shared,
    forward: &ForwardCommands,
    servo: &mut Option<ServoRun>,
    data: &[f64],
) -> Result<(), String> {
    lock(&shared.motion).handle_servo_command()?;
    if servo.as_ref().is_some_and(|s| s.handle.is_finished()) {
        end_servo(shared, servo).await;
    }
    let step = lock(&shared.motion).handle_servo_command()?;
    let sample = forward.handle_command(data).map_err(|e| e.to_string())?;
    let options = ServoOptions::default();
    let checked = ForwardCommands::stream_sample(&sample, options.lookahead_passes);
    let run = match (step, servo) {
        (ServoStep::Push, Some(run)) => run,
        (_, servo) => {
            let (robot, _) = ready_to_move(shared).await?;
            shared.source.check(Action::StreamSample(&checked))?;
            let permit = shared.source.permit(Action::Servo)?;
            let handle = robot
                .servo(options)
                .await
                .map_err(|e| format!("the servo did not open: {e}"))?;
            lock(&shared.motion).handle_servo_opened();
            let text = format!(
                "servoing from ~/commands (command 7): the watchdog brakes the arm and ends the \
                 motion program after {:?} without a command",
                options.watchdog
            );
            shared.log(LogLevel::Info, &text);
            lock(&shared.state).last_command = Some(text);
            servo.insert(ServoRun { handle, permit })
        }
    };
    shared.source.check(Action::StreamSample(&checked))?;
    run.handle.push(sample).map_err(|e| e.to_string())
}

/// Ends the servo (if it still runs: commands 5 then 2), tells the re-arm policy how it ended
/// and gives the permit back. The watchdog and the node's own stop are the node's stops (the
/// next command starts the program again); a fault, a lost link or a stop of the robot by
/// anyone else requires `~/start`.
pub(crate) async fn end_servo(shared: &Shared, servo: &mut Option<ServoRun>) {
    let Some(ServoRun { handle, permit }) = servo.take() else {
        return;
    };
    let watchdog = handle.options().watchdog;
    let ended = handle.finish().await;
    drop(permit);
    let (how, text) =
        crate::forward::servo_end(ended.as_ref().map(|report| report.outcome), watchdog);
    lock(&shared.motion).handle_servo_ended(how, tokio::time::Instant::now());
    shared.log(LogLevel::Warn, &text);
    lock(&shared.state).last_command = Some(text);
}
