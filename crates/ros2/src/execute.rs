//! Executing a [`Plan`] on the robot: the client library's stream (command 7, or command 6
//! waypoints), feedback, path and goal tolerances, cancel (commands 5 and 2: the robot brakes), and a
//! `FollowJointTrajectory` result for every way it can end. Independent of DDS: the node feeds
//! it goals and forwards what it reports.

use std::time::Duration;

use fs020n_client::{ClientError, ErrorKind, Robot, StreamOptions, StreamOutcome};
use fs020n_proto::{JointsDeg, JOINT_COUNT};
use tokio::sync::{mpsc, watch};
use tokio::time::Instant;

use crate::arming::GoalStop;
use crate::config::ExecutionConfig;
use crate::goal::Plan;
use crate::msg::{
    error_code, Duration as RosDuration, FollowJointTrajectoryFeedback,
    FollowJointTrajectoryResult, Header, JointTrajectoryPoint, Time,
};

/// How a goal ended (its action status).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum GoalEnd {
    /// Within the goal tolerances in time.
    Succeeded,
    /// Stopped: a fault, a tolerance, the link, a refusal (see the result's error code).
    Aborted,
    /// Cancelled by the action client (or preempted by a newer goal); the robot braked
    /// (commands 5 and 2).
    Canceled,
}

/// The end of a goal with its result.
#[derive(Debug, Clone, PartialEq)]
pub struct Outcome {
    /// The action status.
    pub end: GoalEnd,
    /// Error code and text.
    pub result: FollowJointTrajectoryResult,
    /// What became of the motion program (for the re-arm policy, [`crate::arming`]).
    pub program: GoalStop,
}

impl Outcome {
    fn new(end: GoalEnd, code: i32, text: impl Into<String>) -> Outcome {
        Outcome {
            end,
            result: FollowJointTrajectoryResult {
                error_code: code,
                error_string: text.into(),
            },
            program: GoalStop::ProgramRunning,
        }
    }

    fn aborted(code: i32, text: impl Into<String>) -> Outcome {
        Outcome::new(GoalEnd::Aborted, code, text)
    }

    /// The robot, the link or someone else stopped the motion: a fault.
    fn fault(code: i32, text: impl Into<String>) -> Outcome {
        let o = Outcome::aborted(code, text);
        Outcome {
            program: GoalStop::Fault(format!("the goal was stopped: {}", o.result.error_string)),
            ..o
        }
    }

    fn by_the_node(self) -> Outcome {
        Outcome {
            program: GoalStop::ByTheNode,
            ..self
        }
    }

    /// The outcome of a goal cancelled because a newer goal preempted it: ABORTED (as
    /// `INVALID_GOAL`, the code `joint_trajectory_controller` gives a preempted goal) with
    /// "preempted by a new goal". A goal that had ended otherwise keeps its outcome.
    pub fn preempted(self) -> Outcome {
        if self.end != GoalEnd::Canceled {
            return self;
        }
        Outcome {
            program: self.program,
            ..Outcome::aborted(
                error_code::INVALID_GOAL,
                "preempted by a new goal: the robot braked (commands 5 and 2) and follows the \
                 new goal from where it stopped",
            )
        }
    }
}

/// The stream options for a plan: the node's, with the start tolerance and the settling wait
/// of the goal.
pub fn stream_options(plan: &Plan, exec: &ExecutionConfig) -> StreamOptions {
    let end_tolerance_deg = plan
        .goal_tolerance_deg
        .iter()
        .flatten()
        .copied()
        .fold(f64::INFINITY, f64::min);
    StreamOptions {
        // The prepended point is where the robot was a moment ago: allow a little drift.
        start_tolerance_deg: exec.start_tolerance_rad.to_degrees(),
        end_tolerance_deg: if end_tolerance_deg.is_finite() {
            end_tolerance_deg
        } else {
            exec.goal_tolerance_rad.to_degrees()
        },
        end_timeout: plan.goal_time_tolerance.max(Duration::from_millis(1)),
        ..exec.stream
    }
}

fn to_goal_order(plan: &Plan, v: &JointsDeg) -> Vec<f64> {
    (0..JOINT_COUNT)
        .map(|k| v[plan.goal_order[k]].to_radians())
        .collect()
}

/// The feedback at trajectory time `tau` with the robot at `actual`.
pub fn feedback(plan: &Plan, tau: f64, actual: &JointsDeg) -> FollowJointTrajectoryFeedback {
    let s = plan.trajectory.sample(tau);
    let t = RosDuration::from_secs_f64(tau);
    let desired = to_goal_order(plan, &s.position);
    let actual_rad = to_goal_order(plan, actual);
    let error = desired
        .iter()
        .zip(&actual_rad)
        .map(|(d, a)| d - a)
        .collect();
    FollowJointTrajectoryFeedback {
        header: Header {
            stamp: Time::now(),
            frame_id: String::new(),
        },
        joint_names: plan.goal_joint_names.clone(),
        desired: JointTrajectoryPoint {
            positions: desired,
            velocities: to_goal_order(plan, &s.velocity),
            time_from_start: t,
            ..Default::default()
        },
        actual: JointTrajectoryPoint {
            positions: actual_rad,
            time_from_start: t,
            ..Default::default()
        },
        error: JointTrajectoryPoint {
            positions: error,
            time_from_start: t,
            ..Default::default()
        },
        ..Default::default()
    }
}

/// The first joint (robot order) whose distance to `target` exceeds its tolerance:
/// `(joint, distance, tolerance)` in degrees.
fn violation(
    tolerances: &[Option<f64>; JOINT_COUNT],
    target: &JointsDeg,
    actual: &JointsDeg,
) -> Option<(usize, f64, f64)> {
    (0..JOINT_COUNT).find_map(|j| {
        let tol = tolerances[j]?;
        let d = (target[j] - actual[j]).abs();
        (d > tol).then_some((j, d, tol))
    })
}

/// Maps a client error during execution to the goal's end: one mapping, from the client's
/// classification ([`ClientError::kind`]).
///
/// | kind | result | program (re-arm) |
/// |---|---|---|
/// | `Refused`, `Busy` (nothing was sent: a value, a sample, the encoder, the speed, IK, a raw text, the configuration; another motion) | ABORTED, `INVALID_GOAL`, "refused before moving" | still running |
/// | `NotReady` (the controller's state blocks motion: nothing moved) | ABORTED, `INVALID_GOAL`, "refused before moving" | a fault: `~/start` first |
/// | `Motion` (stopped by the controller's state, an underrun, no clock) | ABORTED, `PATH_TOLERANCE_VIOLATED`, "the robot stopped while moving" | a fault |
/// | `MoveTimeout` (held on HOLD too long: cancelled) | ABORTED, `PATH_TOLERANCE_VIOLATED` | a fault |
/// | `LinkLost`, `Connect` | ABORTED, `PATH_TOLERANCE_VIOLATED`, "the link to the robot was lost" | a fault |
/// | `Cancelled` (by someone else), `Other` | ABORTED, `PATH_TOLERANCE_VIOLATED` | a fault |
fn failed(e: &ClientError) -> Outcome {
    match e.kind() {
        ErrorKind::Refused | ErrorKind::Busy => Outcome::aborted(
            error_code::INVALID_GOAL,
            format!("refused before moving: {e}"),
        ),
        ErrorKind::NotReady => Outcome::fault(
            error_code::INVALID_GOAL,
            format!("refused before moving: {e}"),
        ),
        ErrorKind::Motion => Outcome::fault(
            error_code::PATH_TOLERANCE_VIOLATED,
            format!("the robot stopped while moving: {e}"),
        ),
        ErrorKind::LinkLost | ErrorKind::Connect => Outcome::fault(
            error_code::PATH_TOLERANCE_VIOLATED,
            format!("the link to the robot was lost while moving: {e}"),
        ),
        _ => Outcome::fault(
            error_code::PATH_TOLERANCE_VIOLATED,
            format!("the motion stopped: {e}"),
        ),
    }
}

/// Executes `plan` on `robot` (program running, robot at the plan's start): waits the plan's
/// start delay, streams the trajectory, sends feedback every `feedback_period` (dropped when
/// the channel is full), checks path tolerances on every status, and on `cancel` becoming
/// `true` cancels the stream (commands 5 and 2: the robot brakes, the program ends). At the
/// end, checks the goal tolerances on the robot's joints. The outcome says what became of the
/// motion program ([`Outcome::program`]).
pub async fn execute(
    robot: &Robot,
    plan: &Plan,
    exec: &ExecutionConfig,
    joint_names: &[String; JOINT_COUNT],
    feedback_period: Duration,
    mut cancel: watch::Receiver<bool>,
    feedback_tx: &mpsc::Sender<FollowJointTrajectoryFeedback>,
) -> Outcome {
    let canceled = || {
        Outcome::new(
            GoalEnd::Canceled,
            error_code::SUCCESSFUL,
            "cancelled: the robot braked to a stop and holds there (commands 5 and 2); the next \
             goal starts the motion program again",
        )
        .by_the_node()
    };
    if *cancel.borrow() {
        return Outcome::new(
            GoalEnd::Canceled,
            error_code::SUCCESSFUL,
            "cancelled before it started",
        );
    }
    if !plan.start_delay.is_zero() {
        tokio::select! {
            _ = tokio::time::sleep(plan.start_delay) => {}
            _ = cancel.wait_for(|c| *c) => {
                return Outcome::new(GoalEnd::Canceled, error_code::SUCCESSFUL, "cancelled before it started");
            }
        }
    }
    let options = stream_options(plan, exec);
    let handle = match robot.stream(plan.trajectory.clone(), options).await {
        Ok(h) => h,
        Err(ClientError::Cancelled(_)) => return canceled(),
        Err(e) => return failed(&e),
    };
    let started = Instant::now();
    let mut progress = handle.subscribe();
    let mut status_rx = robot.subscribe();
    let mut ticker = tokio::time::interval(feedback_period.max(Duration::from_millis(1)));
    ticker.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Delay);
    let mut we_cancelled = false;
    let mut path_violation: Option<String> = None;
    let duration = plan.duration_s();
    loop {
        tokio::select! {
            r = progress.changed() => if r.is_err() { break },
            requested = async { cancel.wait_for(|c| *c).await.is_ok() }, if !we_cancelled => {
                if requested {
                    we_cancelled = true;
                    let _ = handle.cancel().await;
                }
            }
            r = status_rx.changed() => {
                if r.is_err() {
                    // The session ended; the stream reports why.
                    continue;
                }
                let s = status_rx.borrow_and_update().clone();
                if path_violation.is_none() && s.received_at >= started {
                    {
                        // The reply reflects the robot about half a round trip before it
                        // arrived.
                        let tau = (s.received_at.duration_since(started).saturating_sub(s.rtt / 2))
                            .as_secs_f64()
                            .min(duration);
                        let desired = plan.trajectory.sample(tau).position;
                        if let Some((j, d, tol)) = violation(&plan.path_tolerance_deg, &desired, &s.status.joints) {
                            path_violation = Some(format!(
                                "path tolerance violated at t = {tau:.3} s: {} was {:.4} rad from the \
                                 trajectory (tolerance {:.4} rad); the robot braked (commands 5 and 2) — \
                                 slow the trajectory down or widen path_tolerance",
                                joint_names[j],
                                d.to_radians(),
                                tol.to_radians()
                            ));
                            we_cancelled = true;
                            let _ = handle.cancel().await;
                        }
                    }
                }
            }
            _ = ticker.tick() => {
                let s = robot.status();
                let tau = started.elapsed().as_secs_f64().min(duration);
                let _ = feedback_tx.try_send(feedback(plan, tau, &s.status.joints));
            }
        }
    }
    let report = match handle.wait().await {
        Ok(r) => r,
        Err(e) => return failed(&e),
    };
    if let Some(text) = path_violation {
        return Outcome::aborted(error_code::PATH_TOLERANCE_VIOLATED, text).by_the_node();
    }
    match report.outcome {
        StreamOutcome::Cancelled if we_cancelled => canceled(),
        StreamOutcome::Cancelled => Outcome::fault(
            error_code::PATH_TOLERANCE_VIOLATED,
            "the motion was cancelled by a cancel or stop of the robot (~/cancel, ~/stop or \
             another client of the session); the robot braked",
        ),
        StreamOutcome::Completed => {
            let now = robot.status();
            let target = plan.trajectory.last();
            match violation(&plan.goal_tolerance_deg, &target, &now.status.joints) {
                None => Outcome::new(
                    GoalEnd::Succeeded,
                    error_code::SUCCESSFUL,
                    format!(
                        "reached within the goal tolerances ({} samples, tracking error max {:.4} rad)",
                        report.samples_sent,
                        report.tracking_error_max_deg.to_radians()
                    ),
                ),
                Some((j, d, tol)) => Outcome::aborted(
                    error_code::GOAL_TOLERANCE_VIOLATED,
                    format!(
                        "{} ended {:.4} rad from the goal (tolerance {:.4} rad) {:.3} s after the \
                         trajectory's end; check the speed (100 % for command 7) or widen \
                         goal_tolerance / goal_time_tolerance",
                        joint_names[j],
                        d.to_radians(),
                        tol.to_radians(),
                        plan.goal_time_tolerance.as_secs_f64()
                    ),
                ),
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use fs020n_client::{Activity, Blocker};

    fn is_fault(o: &Outcome) -> bool {
        matches!(o.program, GoalStop::Fault(_))
    }

    #[test]
    fn every_error_refused_before_sending_is_refused_before_moving_and_keeps_the_program() {
        let refused = [
            ClientError::Speed { percent: 140.0 },
            ClientError::Config("period 0 s".into()),
            ClientError::NonFinite { what: "JT2".into() },
            ClientError::Ik(fs020n_kin::IkError::NonFinite),
            ClientError::Encode(fs020n_proto::EncodeError::NonFinite {
                field: "JT1",
                value: f64::NAN,
            }),
            ClientError::RawRefused(fs020n_client::RawRefusal::Empty),
            ClientError::Busy(Activity::Servo),
        ];
        for e in refused {
            let o = failed(&e);
            assert_eq!(o.end, GoalEnd::Aborted, "{e}");
            assert_eq!(o.result.error_code, error_code::INVALID_GOAL, "{e}");
            assert!(
                o.result.error_string.starts_with("refused before moving"),
                "{e}: {}",
                o.result.error_string
            );
            assert_eq!(o.program, GoalStop::ProgramRunning, "{e}");
        }
    }

    #[test]
    fn a_blocked_robot_is_refused_before_moving_as_a_fault() {
        let o = failed(&ClientError::Blocked(vec![Blocker::ProgramNotRunning]));
        assert_eq!(o.result.error_code, error_code::INVALID_GOAL);
        assert!(o.result.error_string.starts_with("refused before moving"));
        assert!(is_fault(&o), "{o:?}");
    }

    #[test]
    fn errors_while_moving_are_faults_with_a_path_error_code() {
        let while_moving = [
            (
                ClientError::Aborted {
                    during: "stream",
                    blockers: vec![Blocker::ProgramNotRunning],
                },
                "stopped while moving",
            ),
            (
                ClientError::StreamUnderrun {
                    gap: Duration::from_millis(300),
                    allowed: Duration::from_millis(120),
                },
                "stopped while moving",
            ),
            (ClientError::Closed, "link to the robot was lost"),
            (
                ClientError::HoldTimeout {
                    during: "stream",
                    waited: Duration::from_secs(30),
                },
                "motion stopped",
            ),
        ];
        for (e, text) in while_moving {
            let o = failed(&e);
            assert_eq!(o.end, GoalEnd::Aborted, "{e}");
            assert_eq!(
                o.result.error_code,
                error_code::PATH_TOLERANCE_VIOLATED,
                "{e}"
            );
            assert!(
                o.result.error_string.contains(text),
                "{e}: {}",
                o.result.error_string
            );
            assert!(is_fault(&o), "{e}");
        }
    }

    #[test]
    fn violations_name_the_first_joint_out_of_tolerance() {
        let tol = [Some(1.0), None, Some(0.5), None, None, None];
        let target = JointsDeg::new([0.0; 6]);
        let actual = JointsDeg::new([0.9, 50.0, 0.6, 0.0, 0.0, 0.0]);
        let (j, d, t) = violation(&tol, &target, &actual).unwrap();
        assert_eq!(j, 2);
        assert!((d - 0.6).abs() < 1e-12 && t == 0.5);
        assert!(violation(&[None; 6], &target, &actual).is_none());
    }
}
