//! The loop of motion requests: the `FollowJointTrajectory` action's goals, cancels and result
//! requests, `~/joint_trajectory` and `~/commands`, each handed to the motion owner
//! ([`crate::motion_owner`]) for its decision and carried out on the robot ([`crate::moves`],
//! [`crate::execute`]); replies through [`crate::replies`].

use std::future::Future;
use std::pin::Pin;
use std::sync::Arc;
use std::time::Duration;

use fs020n_client::Robot;
use ros2_client::action::SendGoalResponse;
use ros2_client::action_msgs::{CancelGoalResponse, CancelGoalResponseEnum, GoalId, GoalInfo};
use ros2_client::builtin_interfaces::Time as RosTime;
use ros2_client::dds::rustdds::DomainParticipant;
use ros2_client::log::LogLevel;
use tokio::sync::{mpsc, watch};

use crate::action::{status, CancelCode, GoalTable};
use crate::error::Ros2Error;
use crate::execute::{execute, GoalEnd, Outcome};
use crate::forward::ForwardCommands;
use crate::goal::{GoalRefusal, Plan};
use crate::motion_owner::Admission;
use crate::moves::{admit, command, end_servo, precheck, ServoRun};
use crate::msg::{
    error_code, Float64MultiArray, FollowJointTrajectoryFeedback, FollowJointTrajectoryGoal,
    FollowJointTrajectoryResult, JointTrajectory,
};
use crate::replies::{
    cancel_fields, publish_statuses, send_results, ActionReplies, ActionReply, ActionReplyTopics,
    ActionServer, Goals, ACTION_POLL,
};
use crate::shared::{lock, Shared};
use crate::source::Permit;

/// A trajectory executing on the robot.
type Executing<'a> = Pin<Box<dyn Future<Output = Outcome> + Send + 'a>>;

/// The I/O side of the running trajectory: its brake switch and its execution.
struct Running<'a> {
    brake: watch::Sender<bool>,
    execution: Executing<'a>,
}

/// Reads the action's services and the streaming topics until the node ends.
pub(crate) async fn action_loop(
    shared: &Shared,
    server: &ActionServer,
    reply_topics: ActionReplyTopics,
    participant: DomainParticipant,
    trajectories: &ros2_client::Subscription<JointTrajectory>,
    commands: &ros2_client::Subscription<Float64MultiArray>,
) -> Result<(), Ros2Error> {
    let (feedback_tx, mut feedback_rx) = mpsc::channel::<FollowJointTrajectoryFeedback>(4);
    let feedback_tx = &feedback_tx;
    let mut goals: Goals = GoalTable::new(
        Duration::from_secs_f64(shared.config.result_retention_s),
        FollowJointTrajectoryResult::default(),
    );
    let mut running: Option<Running<'_>> = None;
    // The servo of `~/commands`, while one runs.
    let mut servo: Option<ServoRun> = None;
    let forward = ForwardCommands::new(shared.model.clone(), shared.config.joint_names.clone());
    let feedback_period = Duration::from_secs_f64(1.0 / shared.config.feedback_rate_hz);
    let mut poll = tokio::time::interval(ACTION_POLL);
    poll.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Delay);
    let mut replies = ActionReplies::new(shared, server, participant, reply_topics);
    let start = |robot: Arc<Robot>, p: Plan, permit: Permit| -> Running<'_> {
        let (brake, cancel_rx) = watch::channel(false);
        let exec = &shared.config.execution;
        let names = &shared.config.joint_names;
        Running {
            brake,
            execution: Box::pin(async move {
                let outcome = execute(
                    &robot,
                    &p,
                    exec,
                    names,
                    feedback_period,
                    cancel_rx,
                    feedback_tx,
                )
                .await;
                // Control is given back when the trajectory is over.
                drop(permit);
                outcome
            }),
        }
    };
    publish_statuses(server, &goals);
    loop {
        tokio::select! {
            _ = poll.tick() => {
                // Goals.
                loop {
                    let (request_id, request) = match server.receive_goal() {
                        Ok(Some(r)) => r,
                        Ok(None) => break,
                        Err(e) => {
                            tracing::warn!("goal request not read: {e:?}");
                            break;
                        }
                    };
                    let id = request.goal_id;
                    let goal = request.goal;
                    let admitted = if goals.contains(&id) {
                        Err(GoalRefusal::new(error_code::INVALID_GOAL, "a goal with this id exists already; give every goal a new id"))
                    } else {
                        admit_replacing(shared, &goal, &mut servo, &mut replies, &mut goals, &mut running).await
                    };
                    match admitted {
                        Err(refusal) => {
                            let text = format!("goal rejected ({}): {}", refusal.code, refusal.message);
                            shared.log(LogLevel::Warn, &text);
                            lock(&shared.state).last_goal = Some(text);
                            let response = SendGoalResponse { accepted: false, stamp: RosTime::ZERO };
                            replies.send(ActionReply::Goal(request_id, response));
                        }
                        Ok((robot, p, permit)) => {
                            let stamp = RosTime::now();
                            goals.handle_goal_accepted(id, stamp.to_nanos());
                            let response = SendGoalResponse { accepted: true, stamp };
                            replies.send(ActionReply::Goal(request_id, response));
                            publish_statuses(server, &goals);
                            let text = format!(
                                "executing a trajectory of {} points over {:.3} s",
                                goal.trajectory.points.len(),
                                p.duration_s()
                            );
                            shared.log(LogLevel::Info, &text);
                            lock(&shared.state).last_goal = Some(text);
                            lock(&shared.motion).handle_trajectory_started(Some(id));
                            running = Some(start(robot, p, permit));
                        }
                    }
                }
                // Cancels.
                loop {
                    let (request_id, request) = match server.receive_cancel_request() {
                        Ok(Some(r)) => r,
                        Ok(None) => break,
                        Err(e) => {
                            tracing::warn!("cancel request not read: {e:?}");
                            break;
                        }
                    };
                    let (code, canceling) = match cancel_fields(&request) {
                        Some((id, stamp)) => goals.handle_cancel_request(
                            (id != GoalId::ZERO).then_some(id),
                            stamp.to_nanos(),
                        ),
                        None => (CancelCode::Rejected, Vec::new()),
                    };
                    let ids: Vec<GoalId> = canceling.iter().map(|(id, _)| *id).collect();
                    if lock(&shared.motion).handle_cancel_request(&ids) {
                        if let Some(r) = &running {
                            r.brake.send_replace(true);
                        }
                        shared.log(LogLevel::Info, "goal cancel requested: braking (commands 5 and 2); the arm holds where it stops");
                    }
                    let response = CancelGoalResponse {
                        return_code: match code {
                            CancelCode::ErrorNone => CancelGoalResponseEnum::None,
                            CancelCode::Rejected => CancelGoalResponseEnum::Rejected,
                            CancelCode::UnknownGoalId => CancelGoalResponseEnum::UnknownGoal,
                            CancelCode::GoalTerminated => CancelGoalResponseEnum::GoalTerminated,
                        },
                        goals_canceling: canceling
                            .iter()
                            .map(|(goal_id, ns)| GoalInfo { goal_id: *goal_id, stamp: RosTime::from_nanos(*ns) })
                            .collect(),
                    };
                    replies.send(ActionReply::Cancel(request_id, response));
                    if !canceling.is_empty() {
                        publish_statuses(server, &goals);
                    }
                }
                // Result requests.
                loop {
                    let (request_id, request) = match server.receive_result_request() {
                        Ok(Some(r)) => r,
                        Ok(None) => break,
                        Err(e) => {
                            tracing::warn!("result request not read: {e:?}");
                            break;
                        }
                    };
                    if let Some(reply) = goals.handle_result_request(request_id, request.goal_id) {
                        send_results(&mut replies, vec![reply]);
                    }
                }
                if goals.handle_timeout(tokio::time::Instant::now()) {
                    publish_statuses(server, &goals);
                }
                // Replies whose requester's reply reader is matched now.
                replies.poll();
                // A servo that ended by itself (the watchdog, a fault).
                if servo.as_ref().is_some_and(|s| s.is_finished()) {
                    end_servo(shared, &mut servo).await;
                }
            }
            message = commands.async_take() => {
                let data = match message {
                    Ok((m, _)) => m.data,
                    Err(e) => {
                        tracing::warn!("~/commands message not read: {e:?}");
                        continue;
                    }
                };
                if let Err(reason) = command(shared, &forward, &mut servo, &data).await {
                    let text = format!("~/commands refused (nothing sent): {reason}");
                    shared.log(LogLevel::Warn, &text);
                    lock(&shared.state).last_command_refused = Some(text);
                }
            }
            Some(fb) = feedback_rx.recv() => {
                // After a cancel request the goal is "canceling": no more feedback.
                let goal = lock(&shared.motion).feedback_goal();
                if let Some(id) = goal {
                    if goals.status_of(&id) == status::EXECUTING {
                        let _ = server.send_feedback(id, fb);
                    }
                }
            }
            outcome = maybe(&mut running), if running.is_some() => {
                running = None;
                end_trajectory(shared, &mut replies, &mut goals, outcome);
            }
            message = trajectories.async_take() => {
                let trajectory = match message {
                    Ok((t, _)) => t,
                    Err(e) => {
                        tracing::warn!("~/joint_trajectory message not read: {e:?}");
                        continue;
                    }
                };
                // Checked like a goal with the node's default tolerances; it replaces the
                // running trajectory (goal or topic) once it passes the checks.
                let goal = FollowJointTrajectoryGoal { trajectory, ..Default::default() };
                let admitted = admit_replacing(shared, &goal, &mut servo, &mut replies, &mut goals, &mut running).await;
                match admitted {
                    Err(refusal) => {
                        let text = format!("~/joint_trajectory refused ({}): {}", refusal.code, refusal.message);
                        shared.log(LogLevel::Warn, &text);
                        lock(&shared.state).last_goal = Some(text);
                    }
                    Ok((robot, p, permit)) => {
                        let text = format!(
                            "following a ~/joint_trajectory of {} points over {:.3} s",
                            goal.trajectory.points.len(),
                            p.duration_s()
                        );
                        shared.log(LogLevel::Info, &text);
                        lock(&shared.state).last_goal = Some(text);
                        lock(&shared.motion).handle_trajectory_started(None);
                        running = Some(start(robot, p, permit));
                    }
                }
            }
        }
    }
}

/// Awaits the running trajectory, or never when there is none.
async fn maybe(slot: &mut Option<Running<'_>>) -> Outcome {
    match slot {
        Some(r) => (&mut r.execution).await,
        None => std::future::pending().await,
    }
}

/// Ends the running trajectory: the motion owner learns what became of the program, the goal
/// (if it came from the action) keeps its result, the result requests waiting for it are
/// answered and the statuses published.
fn end_trajectory(
    shared: &Shared,
    replies: &mut ActionReplies<'_>,
    goals: &mut Goals,
    outcome: Outcome,
) {
    let id = lock(&shared.motion)
        .handle_trajectory_ended(outcome.program.clone(), tokio::time::Instant::now());
    let end = match outcome.end {
        GoalEnd::Succeeded => status::SUCCEEDED,
        GoalEnd::Aborted => status::ABORTED,
        GoalEnd::Canceled => status::CANCELED,
    };
    let text = format!(
        "goal {:?} ({}): {}",
        outcome.end, outcome.result.error_code, outcome.result.error_string
    );
    shared.log(
        if outcome.end == GoalEnd::Succeeded {
            LogLevel::Info
        } else {
            LogLevel::Warn
        },
        &text,
    );
    lock(&shared.state).last_goal = Some(text);
    // A trajectory from the topic has no goal: nobody asks for its result.
    if let Some(id) = id {
        let results = goals.handle_goal_end(id, end, outcome.result, tokio::time::Instant::now());
        send_results(replies, results);
        publish_statuses(replies.server(), goals);
    }
}

/// Admits `goal` (an action goal or a `~/joint_trajectory` message) as the next trajectory, as
/// the motion owner decides ([`Admission`]): when a trajectory or a servo runs, the new one
/// replaces it, as joint_trajectory_controller does, once it passes the checks that do not
/// need the arm to stop; then the servo ends, or the running trajectory is preempted and the
/// arm brakes, before the new one is planned from where it is.
async fn admit_replacing(
    shared: &Shared,
    goal: &FollowJointTrajectoryGoal,
    servo: &mut Option<ServoRun>,
    replies: &mut ActionReplies<'_>,
    goals: &mut Goals,
    running: &mut Option<Running<'_>>,
) -> Result<(Arc<Robot>, Plan, Permit), GoalRefusal> {
    let admission = lock(&shared.motion).handle_trajectory_request();
    match admission {
        Admission::Plan => admit(shared, goal, false).await,
        Admission::Replace {
            end_servo: ending,
            preempt: preempting,
        } => {
            precheck(shared, goal).await?;
            if ending {
                end_servo(shared, servo).await;
            }
            if preempting.is_some() {
                preempt(shared, replies, goals, running).await;
            }
            admit(shared, goal, true).await
        }
    }
}

/// Stops the running trajectory because a newer one replaces it: it ends ABORTED "preempted
/// by a new goal" once the robot has braked.
async fn preempt(
    shared: &Shared,
    replies: &mut ActionReplies<'_>,
    goals: &mut Goals,
    running: &mut Option<Running<'_>>,
) {
    if let Some(Running { brake, execution }) = running.take() {
        shared.log(
            LogLevel::Info,
            "a new trajectory preempts the running one: braking (commands 5 and 2)",
        );
        brake.send_replace(true);
        let outcome = execution.await.preempted();
        end_trajectory(shared, replies, goals, outcome);
    }
}
