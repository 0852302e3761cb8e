//! From a `FollowJointTrajectory` goal to a checked [`Plan`]: joint names matched to the robot's
//! joints, radians to degrees, the current position prepended when the goal starts later than
//! time 0, tolerances resolved against the node's defaults, and every check of the client
//! library run (ranges, speeds, per-cycle steps and, for command 7, accelerations and every
//! target the controller can extrapolate to) — all before anything moves.

use std::time::Duration;

use fs020n_client::{Trajectory, TrajectoryPoint};
use fs020n_kin::RobotModel;
use fs020n_proto::{JointsDeg, JOINT_COUNT};

use crate::config::ExecutionConfig;
use crate::msg::{error_code, FollowJointTrajectoryGoal, JointTolerance, Time};

/// Why a goal is refused before anything moves: a `FollowJointTrajectory` error code and a
/// message that says what to change.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("{message}")]
pub struct GoalRefusal {
    /// `INVALID_GOAL`, `INVALID_JOINTS` or `OLD_HEADER_TIMESTAMP`.
    pub code: i32,
    /// What is wrong and how to fix it.
    pub message: String,
}

impl GoalRefusal {
    pub(crate) fn new(code: i32, message: impl Into<String>) -> GoalRefusal {
        GoalRefusal {
            code,
            message: message.into(),
        }
    }

    fn invalid(message: impl Into<String>) -> GoalRefusal {
        GoalRefusal::new(error_code::INVALID_GOAL, message)
    }
}

/// A goal ready to execute.
#[derive(Debug, Clone, PartialEq)]
pub struct Plan {
    /// The trajectory in the robot's joint order, degrees, from time 0.
    pub trajectory: Trajectory,
    /// For each joint of the goal (in the goal's order), the robot joint index (0-based).
    pub goal_order: [usize; JOINT_COUNT],
    /// The goal's joint names, in its order (for feedback).
    pub goal_joint_names: Vec<String>,
    /// Per robot joint: the goal tolerance in degrees, `None` when unchecked.
    pub goal_tolerance_deg: [Option<f64>; JOINT_COUNT],
    /// Per robot joint: the path tolerance in degrees, `None` when unchecked.
    pub path_tolerance_deg: [Option<f64>; JOINT_COUNT],
    /// Time after the trajectory's end to come within the goal tolerances.
    pub goal_time_tolerance: Duration,
    /// Wait this long before starting (a header stamp in the future).
    pub start_delay: Duration,
    /// The current position was prepended as the point at time 0.
    pub prepended_start: bool,
}

impl Plan {
    /// The trajectory's duration, seconds.
    pub fn duration_s(&self) -> f64 {
        self.trajectory.duration_s()
    }
}

/// A header stamp up to this far in the past still means "now" (clocks of two computers and
/// the time the goal travelled). Older stamps are refused with `OLD_HEADER_TIMESTAMP`.
pub const STAMP_SLACK_S: f64 = 0.5;

/// Checks `goal` against the robot's `joint_names`, the `model` and the execution settings,
/// with the robot at `current` (degrees) at time `now`, and builds the plan.
pub fn plan(
    goal: &FollowJointTrajectoryGoal,
    joint_names: &[String; JOINT_COUNT],
    model: &RobotModel,
    exec: &ExecutionConfig,
    current: &JointsDeg,
    now: Time,
) -> Result<Plan, GoalRefusal> {
    plan_with(goal, joint_names, model, exec, current, now, false)
}

/// [`plan`] for a goal that preempts a running one: it starts from where the arm is. The arm
/// braked somewhere past the state the new goal was planned from, so a first point at time 0
/// further than `start_tolerance_rad` from the current joints is replaced by them (the
/// checks of speeds and accelerations then decide whether the rest can follow on time).
pub fn plan_preempting(
    goal: &FollowJointTrajectoryGoal,
    joint_names: &[String; JOINT_COUNT],
    model: &RobotModel,
    exec: &ExecutionConfig,
    current: &JointsDeg,
    now: Time,
) -> Result<Plan, GoalRefusal> {
    plan_with(goal, joint_names, model, exec, current, now, true)
}

fn plan_with(
    goal: &FollowJointTrajectoryGoal,
    joint_names: &[String; JOINT_COUNT],
    model: &RobotModel,
    exec: &ExecutionConfig,
    current: &JointsDeg,
    now: Time,
    from_current: bool,
) -> Result<Plan, GoalRefusal> {
    let tr = &goal.trajectory;
    if !goal.multi_dof_trajectory.joint_names.is_empty()
        || !goal.multi_dof_trajectory.points.is_empty()
        || !goal.component_path_tolerance.is_empty()
        || !goal.component_goal_tolerance.is_empty()
    {
        return Err(GoalRefusal::new(
            error_code::INVALID_JOINTS,
            "the goal has multi-DOF joints or component tolerances; the FS020N has six revolute \
             joints: leave multi_dof_trajectory and component_*_tolerance empty",
        ));
    }
    let expected = joint_names.join(", ");
    let index_of = |name: &str| joint_names.iter().position(|n| n == name);
    if tr.joint_names.len() != JOINT_COUNT {
        return Err(GoalRefusal::new(
            error_code::INVALID_JOINTS,
            format!(
                "the goal names {} joints ({}); give all six: {expected}",
                tr.joint_names.len(),
                tr.joint_names.join(", ")
            ),
        ));
    }
    let mut goal_order = [0usize; JOINT_COUNT];
    for (k, name) in tr.joint_names.iter().enumerate() {
        let Some(j) = index_of(name) else {
            return Err(GoalRefusal::new(
                error_code::INVALID_JOINTS,
                format!("unknown joint {name:?}; this robot's joints are {expected}"),
            ));
        };
        if goal_order[..k].contains(&j) {
            return Err(GoalRefusal::new(
                error_code::INVALID_JOINTS,
                format!("joint {name:?} is named twice; give each of {expected} once"),
            ));
        }
        goal_order[k] = j;
    }
    if tr.points.is_empty() {
        return Err(GoalRefusal::invalid(
            "the trajectory has no points; give at least one",
        ));
    }
    // Header stamp: zero or (nearly) now starts at once; the future waits; a stamp further in
    // the past skips the points already due, as joint_trajectory_controller does; a trajectory
    // that ended before it arrived is refused.
    let last_time_s = tr
        .points
        .last()
        .map_or(0.0, |p| p.time_from_start.as_secs_f64());
    let mut start_delay = Duration::ZERO;
    // The time already past on the trajectory's own clock when it arrived: its points up to
    // then are skipped.
    let mut elapsed_s = 0.0;
    if !tr.header.stamp.is_zero() {
        let delay_s = tr.header.stamp.as_secs_f64() - now.as_secs_f64();
        if delay_s + last_time_s < 0.0 {
            return Err(GoalRefusal::new(
                error_code::OLD_HEADER_TIMESTAMP,
                format!(
                    "the trajectory ended {:.3} s before it arrived (header stamp in the past); \
                     send it with a zero stamp to start now",
                    -(delay_s + last_time_s)
                ),
            ));
        }
        if delay_s < -STAMP_SLACK_S {
            elapsed_s = -delay_s;
        }
        if delay_s > exec.max_start_delay.as_secs_f64() {
            return Err(GoalRefusal::invalid(format!(
                "the header stamp is {delay_s:.3} s in the future, more than the {:?} this node \
                 waits; send it later or with a zero stamp",
                exec.max_start_delay
            )));
        }
        start_delay = Duration::from_secs_f64(delay_s.max(0.0));
    }
    // Points, in the robot's order and units.
    let mut points = Vec::with_capacity(tr.points.len() + 1);
    let mut previous_t = -1.0;
    for (i, p) in tr.points.iter().enumerate() {
        let invalid = |what: String| GoalRefusal::invalid(format!("point {i}: {what}"));
        if p.time_from_start.nanosec >= 1_000_000_000 || p.time_from_start.sec < 0 {
            return Err(invalid(format!(
                "time_from_start {}.{:09} s is not a valid non-negative duration",
                p.time_from_start.sec, p.time_from_start.nanosec
            )));
        }
        let t = p.time_from_start.as_secs_f64();
        if t <= previous_t {
            return Err(invalid(format!(
                "time_from_start {t} s is not after the previous point's {previous_t} s; times \
                 must increase strictly"
            )));
        }
        previous_t = t;
        let skipped = elapsed_s > 0.0 && t <= elapsed_s;
        if !p.effort.is_empty() {
            // As joint_trajectory_controller, which refuses trajectories with effort fields.
            return Err(invalid(format!(
                "{} efforts given; this arm is position-controlled (the protocol takes positions \
                 only): leave effort empty",
                p.effort.len()
            )));
        }
        let reorder = |values: &[f64], what: &str| -> Result<Option<JointsDeg>, GoalRefusal> {
            match values.len() {
                0 if what != "positions" => Ok(None),
                JOINT_COUNT => {
                    let mut out = [0.0; JOINT_COUNT];
                    for (k, v) in values.iter().enumerate() {
                        if !v.is_finite() {
                            return Err(invalid(format!(
                                "{what}[{k}] ({}) is not a finite number",
                                tr.joint_names[k]
                            )));
                        }
                        out[goal_order[k]] = v.to_degrees();
                    }
                    Ok(Some(JointsDeg::new(out)))
                }
                n => Err(invalid(format!(
                    "{n} {what}; give {JOINT_COUNT} (one per joint name){}",
                    if what == "positions" { "" } else { " or none" }
                ))),
            }
        };
        let Some(position) = reorder(&p.positions, "positions")? else {
            return Err(invalid("no positions".into()));
        };
        let velocity = reorder(&p.velocities, "velocities")?;
        let acceleration = reorder(&p.accelerations, "accelerations")?;
        if skipped {
            // Due before the trajectory arrived (still checked above).
            continue;
        }
        points.push(TrajectoryPoint {
            time_s: t - elapsed_s,
            position,
            velocity,
            acceleration,
        });
    }
    // The arm ends at rest, as joint_trajectory_controller demands by default
    // (allow_nonzero_velocity_at_trajectory_end: false): a last point still moving would leave
    // the controller extrapolating past it.
    if let Some(last) = tr.points.last() {
        if let Some((k, v)) = last
            .velocities
            .iter()
            .enumerate()
            .find(|(_, v)| v.abs() > f64::from(f32::EPSILON))
        {
            return Err(GoalRefusal::invalid(format!(
                "the last point's velocity of {} is {v} rad/s, not zero; end the trajectory at \
                 rest (a last point still moving would leave the arm moving past it)",
                tr.joint_names[k]
            )));
        }
    }
    if points.is_empty() {
        return Err(GoalRefusal::new(
            error_code::OLD_HEADER_TIMESTAMP,
            "every point was due before the trajectory arrived (header stamp in the past); send \
             it with a zero stamp to start now",
        ));
    }
    // Start: at the current joints, or from them.
    let mut prepended_start = false;
    if points[0].time_s > 0.0 {
        points.insert(0, TrajectoryPoint::new(0.0, *current));
        prepended_start = true;
    } else {
        let first = points[0].position;
        let tol_deg = exec.start_tolerance_rad.to_degrees();
        let off = (0..JOINT_COUNT).find(|&j| (first[j] - current[j]).abs() > tol_deg);
        if off.is_some() && from_current {
            points[0] = TrajectoryPoint::new(0.0, *current);
        } else if let Some(j) = off {
            return Err(GoalRefusal::invalid(format!(
                "the first point (time 0) has {} at {:.4} rad but the robot is at {:.4} rad \
                 (more than {} rad apart); start the trajectory at the current joints, or give \
                 its first point a later time_from_start",
                joint_names[j],
                first[j].to_radians(),
                current[j].to_radians(),
                exec.start_tolerance_rad
            )));
        }
    }
    let trajectory = Trajectory::new(points)
        .map_err(|e| GoalRefusal::invalid(format!("refused before moving: {e}")))?;
    // The client library's own checks, exactly as the stream will run them.
    exec.stream
        .validate(model, &trajectory)
        .map_err(|e| GoalRefusal::invalid(format!("refused before moving: {e}")))?;
    // Tolerances.
    let tolerances = |given: &[JointTolerance], default_rad: f64, what: &str| {
        let default = (default_rad > 0.0).then(|| default_rad.to_degrees());
        let mut out = [default; JOINT_COUNT];
        for t in given {
            let Some(j) = index_of(&t.name) else {
                return Err(GoalRefusal::new(
                    error_code::INVALID_JOINTS,
                    format!(
                        "{what} names unknown joint {:?}; this robot's joints are {expected}",
                        t.name
                    ),
                ));
            };
            if !t.position.is_finite() {
                return Err(GoalRefusal::invalid(format!(
                    "{what} of {} is not a finite number",
                    t.name
                )));
            }
            out[j] = if t.position > 0.0 {
                Some(t.position.to_degrees())
            } else if t.position == 0.0 {
                default
            } else {
                None
            };
        }
        Ok(out)
    };
    let goal_tolerance_deg = tolerances(
        &goal.goal_tolerance,
        exec.goal_tolerance_rad,
        "goal_tolerance",
    )?;
    let path_tolerance_deg = tolerances(
        &goal.path_tolerance,
        exec.path_tolerance_rad,
        "path_tolerance",
    )?;
    let gtt = goal.goal_time_tolerance;
    let goal_time_tolerance = if gtt.sec == 0 && gtt.nanosec == 0 {
        exec.goal_time_tolerance
    } else if gtt.sec < 0 || gtt.nanosec >= 1_000_000_000 || gtt.as_secs_f64() > 3600.0 {
        return Err(GoalRefusal::invalid(format!(
            "goal_time_tolerance {}.{:09} s must be from 0 to 3600 s",
            gtt.sec, gtt.nanosec
        )));
    } else {
        Duration::from_secs_f64(gtt.as_secs_f64())
    };
    Ok(Plan {
        trajectory,
        goal_order,
        goal_joint_names: tr.joint_names.clone(),
        goal_tolerance_deg,
        path_tolerance_deg,
        goal_time_tolerance,
        start_delay,
        prepended_start,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::msg::{Duration as RosDuration, JointTrajectoryPoint};

    fn names() -> [String; JOINT_COUNT] {
        std::array::from_fn(|i| format!("joint_{}", i + 1))
    }

    fn home() -> JointsDeg {
        JointsDeg::new([0.0, 0.0, -90.0, 0.0, -90.0, 0.0])
    }

    fn point(t: f64, deg: [f64; 6]) -> JointTrajectoryPoint {
        JointTrajectoryPoint {
            positions: deg.iter().map(|d| d.to_radians()).collect(),
            time_from_start: RosDuration::from_secs_f64(t),
            ..Default::default()
        }
    }

    fn goal(points: Vec<JointTrajectoryPoint>) -> FollowJointTrajectoryGoal {
        let mut g = FollowJointTrajectoryGoal::default();
        g.trajectory.joint_names = names().to_vec();
        g.trajectory.points = points;
        g
    }

    fn run(g: &FollowJointTrajectoryGoal) -> Result<Plan, GoalRefusal> {
        plan(
            g,
            &names(),
            &RobotModel::fs020n(),
            &ExecutionConfig::default(),
            &home(),
            Time::now(),
        )
    }

    #[test]
    fn a_later_first_point_gets_the_current_position_prepended() {
        let p = run(&goal(vec![point(2.0, [10.0, 0.0, -90.0, 0.0, -90.0, 0.0])])).unwrap();
        assert!(p.prepended_start);
        assert_eq!(p.trajectory.first(), home());
        assert!((p.trajectory.last()[0] - 10.0).abs() < 1e-9);
        assert_eq!(p.duration_s(), 2.0);
        assert_eq!(p.goal_tolerance_deg[0], Some(0.01f64.to_degrees()));
        assert_eq!(p.path_tolerance_deg[0], None);
    }

    #[test]
    fn a_preempting_goal_starts_from_where_the_arm_braked() {
        // Planned from home, but the arm braked 1 degree further on JT1.
        let g = goal(vec![
            point(0.0, [0.0, 0.0, -90.0, 0.0, -90.0, 0.0]),
            point(2.0, [-10.0, 0.0, -90.0, 0.0, -90.0, 0.0]),
        ]);
        let braked = JointsDeg::new([1.5, 0.0, -90.0, 0.0, -90.0, 0.0]);
        let exec = ExecutionConfig::default();
        let m = RobotModel::fs020n();
        assert!(plan(&g, &names(), &m, &exec, &braked, Time::now()).is_err());
        let p = plan_preempting(&g, &names(), &m, &exec, &braked, Time::now()).unwrap();
        assert_eq!(p.trajectory.first(), braked);
        assert!((p.trajectory.last()[0] + 10.0).abs() < 1e-9);
        // Within the tolerance the goal's own first point stays.
        let p = plan_preempting(&g, &names(), &m, &exec, &home(), Time::now()).unwrap();
        assert_eq!(p.trajectory.first(), home());
    }

    #[test]
    fn joints_in_another_order_are_mapped_by_name() {
        let mut g = goal(vec![
            point(0.0, [0.0, -90.0, 0.0, -90.0, 0.0, 0.0]),
            point(2.0, [0.0, -90.0, 0.0, -90.0, 0.0, 20.0]),
        ]);
        // Goal order: 2,3,4,5,6,1
        g.trajectory.joint_names = [
            "joint_2", "joint_3", "joint_4", "joint_5", "joint_6", "joint_1",
        ]
        .map(String::from)
        .to_vec();
        let p = run(&g).unwrap();
        assert!(!p.prepended_start);
        assert!((p.trajectory.last()[0] - 20.0).abs() < 1e-9);
        assert_eq!(p.goal_order, [1, 2, 3, 4, 5, 0]);
    }

    #[test]
    fn wrong_joint_names_are_invalid_joints() {
        let mut g = goal(vec![point(1.0, [0.0; 6])]);
        g.trajectory.joint_names[2] = "elbow".into();
        let e = run(&g).unwrap_err();
        assert_eq!(e.code, error_code::INVALID_JOINTS);
        assert!(
            e.message.contains("elbow") && e.message.contains("joint_3"),
            "{e}"
        );
        g.trajectory.joint_names[2] = "joint_1".into();
        assert!(run(&g).unwrap_err().message.contains("twice"));
        g.trajectory.joint_names.pop();
        assert_eq!(run(&g).unwrap_err().code, error_code::INVALID_JOINTS);
    }

    #[test]
    fn out_of_range_and_too_fast_goals_are_refused_before_moving() {
        let e = run(&goal(vec![point(
            5.0,
            [170.0, 0.0, -90.0, 0.0, -90.0, 0.0],
        )]))
        .unwrap_err();
        assert_eq!(e.code, error_code::INVALID_GOAL);
        assert!(
            e.message.contains("refused before moving") && e.message.contains("JT1"),
            "{e}"
        );
        let e = run(&goal(vec![point(0.1, [90.0, 0.0, -90.0, 0.0, -90.0, 0.0])])).unwrap_err();
        assert_eq!(e.code, error_code::INVALID_GOAL);
    }

    #[test]
    fn a_first_point_at_time_zero_must_be_the_current_position() {
        let e = run(&goal(vec![
            point(0.0, [5.0, 0.0, -90.0, 0.0, -90.0, 0.0]),
            point(2.0, [10.0, 0.0, -90.0, 0.0, -90.0, 0.0]),
        ]))
        .unwrap_err();
        assert!(e.message.contains("current joints"), "{e}");
    }

    #[test]
    fn malformed_points_are_refused() {
        let mut g = goal(vec![point(1.0, [0.0; 6]), point(1.0, [0.0; 6])]);
        assert!(run(&g).unwrap_err().message.contains("increase strictly"));
        g.trajectory.points = vec![point(1.0, [0.0; 6])];
        g.trajectory.points[0].positions[1] = f64::NAN;
        assert!(run(&g).unwrap_err().message.contains("not a finite"));
        g.trajectory.points[0].positions.pop();
        assert!(run(&g).unwrap_err().message.contains("5 positions"));
        g.trajectory.points.clear();
        assert!(run(&g).unwrap_err().message.contains("no points"));
        let mut g = goal(vec![point(1.0, [0.0, 0.0, -90.0, 0.0, -90.0, 0.0])]);
        g.multi_dof_trajectory.joint_names.push("base".into());
        assert_eq!(run(&g).unwrap_err().code, error_code::INVALID_JOINTS);
    }

    #[test]
    fn points_carrying_effort_are_refused_as_joint_trajectory_controller_does() {
        let here = [0.0, 0.0, -90.0, 0.0, -90.0, 0.0];
        let mut g = goal(vec![point(1.0, here), point(2.0, here)]);
        assert!(run(&g).is_ok());
        g.trajectory.points[1].effort = vec![0.0; 6];
        let refusal = run(&g).unwrap_err();
        assert_eq!(refusal.code, error_code::INVALID_GOAL);
        assert!(
            refusal.message.contains("point 1") && refusal.message.contains("effort"),
            "{refusal}"
        );
    }

    #[test]
    fn header_stamps_start_now_later_or_are_too_old() {
        let mut g = goal(vec![point(1.0, [1.0, 0.0, -90.0, 0.0, -90.0, 0.0])]);
        let now = Time::now();
        g.trajectory.header.stamp = Time {
            sec: now.sec - 10,
            nanosec: now.nanosec,
        };
        let e = plan(
            &g,
            &names(),
            &RobotModel::fs020n(),
            &ExecutionConfig::default(),
            &home(),
            now,
        )
        .unwrap_err();
        assert_eq!(e.code, error_code::OLD_HEADER_TIMESTAMP);
        g.trajectory.header.stamp = Time {
            sec: now.sec + 3,
            nanosec: now.nanosec,
        };
        let p = plan(
            &g,
            &names(),
            &RobotModel::fs020n(),
            &ExecutionConfig::default(),
            &home(),
            now,
        )
        .unwrap();
        assert_eq!(p.start_delay, Duration::from_secs(3));
        // Ended as it arrived: refused too.
        g.trajectory.header.stamp = Time {
            sec: now.sec - 1,
            nanosec: now.nanosec,
        };
        let e = plan(
            &g,
            &names(),
            &RobotModel::fs020n(),
            &ExecutionConfig::default(),
            &home(),
            now,
        )
        .unwrap_err();
        assert_eq!(e.code, error_code::OLD_HEADER_TIMESTAMP);
        g.trajectory.header.stamp.sec = now.sec + 60;
        assert!(plan(
            &g,
            &names(),
            &RobotModel::fs020n(),
            &ExecutionConfig::default(),
            &home(),
            now
        )
        .is_err());
    }

    #[test]
    fn a_last_point_still_moving_is_refused_as_jtc_does() {
        let here = [0.0, 0.0, -90.0, 0.0, -90.0, 0.0];
        let mut g = goal(vec![point(1.0, here), point(2.0, here)]);
        // Zero (or float noise) at the end, anything on the way.
        g.trajectory.points[0].velocities = vec![0.0, 0.0, 0.0, 0.0, 0.0, 0.0];
        g.trajectory.points[1].velocities = vec![0.0, 1e-9, 0.0, 0.0, 0.0, 0.0];
        assert!(run(&g).is_ok());
        g.trajectory.points[1].velocities[3] = 0.05;
        let refusal = run(&g).unwrap_err();
        assert_eq!(refusal.code, error_code::INVALID_GOAL);
        assert!(
            refusal.message.contains("joint_4") && refusal.message.contains("not zero"),
            "{refusal}"
        );
    }

    #[test]
    fn a_trajectory_partly_in_the_past_skips_the_points_already_due_as_jtc_does() {
        // joint_trajectory_controller's "ignore partial old trajectory": stamped 1.6 s ago,
        // points at 0.5 s, 1 s and 3 s: the first two are skipped, the third is reached at
        // 1.4 s from now, from where the arm is.
        let target = [6.0, 0.0, -90.0, 0.0, -90.0, 0.0];
        let mut g = goal(vec![
            point(0.5, [40.0, 0.0, -90.0, 0.0, -90.0, 0.0]),
            point(1.0, [-40.0, 0.0, -90.0, 0.0, -90.0, 0.0]),
            point(3.0, target),
        ]);
        g.trajectory.header.stamp = Time {
            sec: 1_700_000_000,
            nanosec: 0,
        };
        let now = Time {
            sec: 1_700_000_001,
            nanosec: 600_000_000,
        };
        let p = plan(
            &g,
            &names(),
            &RobotModel::fs020n(),
            &ExecutionConfig::default(),
            &home(),
            now,
        )
        .unwrap();
        assert_eq!(p.start_delay, Duration::ZERO);
        assert!(p.prepended_start);
        let points = p.trajectory.points();
        assert_eq!(points.len(), 2, "{points:?}");
        assert_eq!(points[0].position, home());
        assert!((points[1].time_s - 1.4).abs() < 1e-6, "{points:?}");
        assert!((points[1].position[0] - 6.0).abs() < 1e-9);
        // A skipped point is still checked: a NaN in it refuses the goal.
        g.trajectory.points[0].positions[2] = f64::NAN;
        assert!(plan(
            &g,
            &names(),
            &RobotModel::fs020n(),
            &ExecutionConfig::default(),
            &home(),
            now
        )
        .is_err());
    }

    #[test]
    fn tolerances_follow_the_zero_default_and_minus_one_erased_rules() {
        let mut g = goal(vec![point(1.0, [1.0, 0.0, -90.0, 0.0, -90.0, 0.0])]);
        g.goal_tolerance = vec![
            JointTolerance {
                name: "joint_2".into(),
                position: 0.1,
                ..Default::default()
            },
            JointTolerance {
                name: "joint_3".into(),
                position: -1.0,
                ..Default::default()
            },
        ];
        g.path_tolerance = vec![JointTolerance {
            name: "joint_1".into(),
            position: 0.05,
            ..Default::default()
        }];
        g.goal_time_tolerance = RosDuration { sec: 5, nanosec: 0 };
        let p = run(&g).unwrap();
        assert_eq!(p.goal_tolerance_deg[1], Some(0.1f64.to_degrees()));
        assert_eq!(p.goal_tolerance_deg[2], None);
        assert_eq!(p.goal_tolerance_deg[0], Some(0.01f64.to_degrees()));
        assert_eq!(p.path_tolerance_deg[0], Some(0.05f64.to_degrees()));
        assert_eq!(p.path_tolerance_deg[1], None);
        assert_eq!(p.goal_time_tolerance, Duration::from_secs(5));
        g.goal_tolerance[0].name = "wrist".into();
        assert_eq!(run(&g).unwrap_err().code, error_code::INVALID_JOINTS);
    }
}
