//! Pacing of command-7 targets: how often the controller is given a new target, and which.
//!
//! The motion program starts a 0.1 s straight-line move (`SPEED 0.1 S`) whenever the target it
//! extrapolates differs from the one before, and the next one blends in only once the tool is
//! within ACCURACY (10 mm) of the current target (protocol-1040 §2.4 and §4). A sample with a
//! velocity changes the target on every pass of the program's loop, so a new move starts every
//! pass while the tool is slow — and once it is fast enough to be more than ACCURACY behind its
//! newest target, every pass waits, its target already stale, and the delay jumps
//! (docs/PERFORMANCE.md, "Where command 7's error comes from").
//!
//! [`TargetPacing::Held`] gives the controller a new target only every few samples instead: a
//! point of the trajectory with zero velocity and acceleration (the controller's extrapolation
//! then gives the same point on every pass, so it starts exactly one move per target), held for
//! a span chosen from the tool's speed ahead so that the tool is within ACCURACY of one target
//! when the next arrives. The moves then overlap like a moving average of the targets — a
//! fixed delay of half a move plus half a span — and the target is placed that much ahead:
//! at the middle of its span plus the lead of [`LagCompensation`](crate::LagCompensation),
//! which starts from half a move and is refined online from the replies.
//!
//! Every held target is a point of the trajectory (or its last point), checked like any sample
//! before it is sent; the step between two targets is bounded by `max_step_deg` per period of
//! trajectory time between them.

use fs020n_kin::RobotModel;
use fs020n_proto::{JointsDeg, ACCURACY_MM, STREAM_LMOVE_TIME_S};
use serde::Serialize;

use crate::trajectory::Trajectory;

/// How a command-7 stream paces its targets.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize)]
pub enum TargetPacing {
    /// Held targets (default): each target is a point of the trajectory ahead with zero
    /// velocity and acceleration, kept for [`MIN_HOLD_FRACTION`]–[`MAX_HOLD_FRACTION`] of the
    /// move's time (20–80 ms at monitor speed 100 %; a whole number of sample periods, longer
    /// where the tool is fast) so that the controller's passes do not wait for ACCURACY.
    /// Curvature compensation does not apply.
    #[default]
    Held,
    /// Every sample carries the trajectory's velocity and acceleration and the controller
    /// extrapolates it on every pass: a new move per pass, which waits for ACCURACY once the tool
    /// is fast (the behaviour before held targets; needed for
    /// [`CurvatureCompensation`](crate::CurvatureCompensation)).
    Extrapolated,
}

/// Shortest span a target is held, as a fraction of the move's time (20 ms at monitor speed
/// 100 %): five overlapping moves add up to a constant speed on a straight path.
pub const MIN_HOLD_FRACTION: f64 = 0.2;
/// Longest span a target is held, as a fraction of the move's time (80 ms at monitor speed
/// 100 %): longer spans make the sum of the overlapping moves ripple (at 0.8 by a third of
/// the speed).
pub const MAX_HOLD_FRACTION: f64 = 0.8;
/// Fraction of ACCURACY the tool may be from the current target, as predicted, when the next
/// target arrives (the prediction is of a straight path at the fastest speed ahead).
const ACCURACY_MARGIN: f64 = 0.8;
/// Step between the points where the tool's speed ahead is probed, seconds.
const PROBE_STEP_S: f64 = 0.01;
/// Time difference of the tool-speed estimate, seconds.
const SPEED_DIFF_S: f64 = 0.001;

/// The motion program's move time at `speed_percent` monitor speed, seconds; 100 % when not
/// known (the shortest move, so the shortest holds and the least lead to start from).
pub(crate) fn move_time_s(speed_percent: Option<f64>) -> f64 {
    match speed_percent {
        Some(p) if p.is_finite() && (1.0..=100.0).contains(&p) => STREAM_LMOVE_TIME_S * 100.0 / p,
        _ => STREAM_LMOVE_TIME_S,
    }
}

/// The target the controller holds, and when it changes.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct HeldTarget {
    /// Trajectory time of the sample that first carried it, seconds.
    pub(crate) since_s: f64,
    /// How long it is held, seconds.
    pub(crate) hold_s: f64,
    /// The trajectory time it is the position of, seconds.
    pub(crate) time_s: f64,
    /// The position.
    pub(crate) position: JointsDeg,
}

/// Where a held-pacing stream is: the sample period and the controller's move time, seconds.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Pace {
    /// Time between samples, seconds.
    pub(crate) period_s: f64,
    /// The controller's move time ([`move_time_s`]), seconds.
    pub(crate) move_s: f64,
}

/// The next target of a held-pacing stream at trajectory time `tau`: the current one while its
/// span lasts (`None`), else a new one (`Some`). `lead_s` is the lag compensation's lead;
/// `last` the stream's last sample (the trajectory's end).
pub(crate) fn next_target(
    model: &RobotModel,
    trajectory: &Trajectory,
    current: Option<&HeldTarget>,
    tau: f64,
    lead_s: f64,
    pace: Pace,
    last: bool,
) -> Option<HeldTarget> {
    let end = trajectory.end_s();
    // Half a period of slack: a sample that leaves a little early still counts as due.
    if let Some(held) = current {
        if !last && tau - held.since_s < held.hold_s - 0.5 * pace.period_s {
            return None;
        }
    }
    let hold_s = hold_for(model, trajectory, tau + lead_s, pace);
    let time_s = if last {
        end
    } else {
        (tau + 0.5 * hold_s + lead_s).min(end)
    };
    Some(HeldTarget {
        since_s: tau,
        hold_s,
        time_s,
        position: if time_s >= end {
            trajectory.last()
        } else {
            trajectory.sample(time_s).position
        },
    })
}

/// How long to hold a target placed from trajectory time `from_s` on: the shortest whole
/// number of periods from [`MIN_HOLD_FRACTION`] of the move time on after which the tool,
/// following at the fastest speed of the trajectory over the next move and span, is predicted
/// within ACCURACY of the target; at most [`MAX_HOLD_FRACTION`] of the move time (or one
/// period, if longer).
///
/// The overlapping moves follow the targets half a move plus half a span late, and the target
/// is placed that far ahead, so at the next target the tool is still `v · (T − h) / 2` from it
/// (`T` the move's time, `h` the span).
pub(crate) fn hold_for(
    model: &RobotModel,
    trajectory: &Trajectory,
    from_s: f64,
    pace: Pace,
) -> f64 {
    let move_s = pace.move_s;
    let (min_hold_s, max_hold_s) = (MIN_HOLD_FRACTION * move_s, MAX_HOLD_FRACTION * move_s);
    let end = trajectory.end_s();
    let tool = |t: f64| model.flange_position_m(&trajectory.sample(t.min(end)).position.to_rad());
    let mut speed_mm_s: f64 = 0.0;
    let mut t = from_s;
    while t <= from_s + move_s + max_hold_s && t < end {
        let d = (tool(t + SPEED_DIFF_S) - tool(t)).norm();
        speed_mm_s = speed_mm_s.max(d * 1000.0 / SPEED_DIFF_S);
        t += PROBE_STEP_S;
    }
    let period_s = pace.period_s.max(1e-3);
    let mut n = (min_hold_s / period_s - 1e-9).ceil().max(1.0);
    while n * period_s < max_hold_s - 1e-9
        && speed_mm_s * 0.5 * (move_s - n * period_s) > ACCURACY_MARGIN * ACCURACY_MM
    {
        n += 1.0;
    }
    n * period_s
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::trajectory::TrajectoryPoint;

    /// JT1 from 0 at `speed` deg/s for 2 s.
    fn ramp(speed: f64) -> Trajectory {
        let model = RobotModel::fs020n();
        let mut end = model.home;
        end[0] += 2.0 * speed;
        Trajectory::new(vec![
            TrajectoryPoint::new(0.0, model.home),
            TrajectoryPoint::new(2.0, end),
        ])
        .unwrap()
    }

    fn pace(period_s: f64) -> Pace {
        Pace {
            period_s,
            move_s: STREAM_LMOVE_TIME_S,
        }
    }

    #[test]
    fn a_slow_tool_gets_the_shortest_hold_and_a_fast_one_a_longer_one() {
        let model = RobotModel::fs020n();
        let slow = hold_for(&model, &ramp(1.0), 0.5, pace(0.02));
        let fast = hold_for(&model, &ramp(30.0), 0.5, pace(0.02));
        assert!((slow - 0.02).abs() < 1e-9, "{slow}");
        assert!(fast > slow && fast <= 0.08 + 1e-9, "{fast}");
        // whole periods, at 250 Hz too
        let fast_250 = hold_for(&model, &ramp(30.0), 0.5, pace(0.004));
        assert!(((fast_250 / 0.004) - (fast_250 / 0.004).round()).abs() < 1e-9);
        assert!((0.02 - 1e-9..=0.08 + 1e-9).contains(&fast_250));
        // a period longer than the longest hold: every sample is a new target
        assert!((hold_for(&model, &ramp(30.0), 0.5, pace(0.1)) - 0.1).abs() < 1e-9);
        // a slower monitor speed makes longer moves, held longer
        let half_speed = Pace {
            period_s: 0.02,
            move_s: move_time_s(Some(50.0)),
        };
        assert!((move_time_s(Some(50.0)) - 0.2).abs() < 1e-12);
        assert_eq!(move_time_s(None), STREAM_LMOVE_TIME_S);
        assert_eq!(move_time_s(Some(f64::NAN)), STREAM_LMOVE_TIME_S);
        let slow_at_half = hold_for(&model, &ramp(1.0), 0.5, half_speed);
        assert!((slow_at_half - 0.04).abs() < 1e-9, "{slow_at_half}");
    }

    #[test]
    fn a_target_is_held_for_its_span_then_placed_ahead_by_half_a_span_and_the_lead() {
        let model = RobotModel::fs020n();
        let t = ramp(5.0);
        let p = pace(0.02);
        let first = next_target(&model, &t, None, 0.5, 0.05, p, false).unwrap();
        assert!((first.time_s - (0.5 + 0.5 * first.hold_s + 0.05)).abs() < 1e-12);
        assert_eq!(first.position, t.sample(first.time_s).position);
        // within the span: nothing new
        let early = 0.5 + first.hold_s - 0.011;
        assert!(next_target(&model, &t, Some(&first), early, 0.05, p, false).is_none());
        // due (within half a period)
        let due = 0.5 + first.hold_s - 0.009;
        let next = next_target(&model, &t, Some(&first), due, 0.05, p, false).unwrap();
        assert!(next.time_s > first.time_s);
        // the last sample is the trajectory's last point, whatever the span
        let end = next_target(&model, &t, Some(&next), 2.0, 0.05, p, true).unwrap();
        assert_eq!(end.position, t.last());
        // near the end a target is the last point, never beyond it
        let late = next_target(&model, &t, None, 1.99, 0.3, p, false).unwrap();
        assert_eq!(late.position, t.last());
    }
}
