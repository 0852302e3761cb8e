//! Time-stamped joint trajectories for [`Robot::stream`](crate::Robot::stream), validated
//! before anything is sent.
//!
//! Between points the trajectory is a cubic Hermite spline through the positions, with the
//! given velocities, or — where a point has none — finite-difference velocities (central
//! differences inside, zero at the first and last point: streams start and end at rest).
//! Accelerations given at both ends of a segment are interpolated linearly; otherwise the
//! spline's own second derivative is used. For command 7 that estimate is limited to the
//! model's maximum acceleration (it only shapes the controller's extrapolation, and a
//! coarse trajectory's spline can demand several times what the arm can do at its knots);
//! given accelerations are never changed, and are refused when above the maximum.

use std::time::Duration;

use fs020n_kin::{LimitError, RobotModel};
use fs020n_proto::{JointsDeg, StreamSample, JOINT_COUNT};

use crate::display::Rounded;
use crate::safety::{check_stream_sample, SampleError};

/// Most stream cycles a trajectory may take at its period.
pub(crate) const MAX_CYCLES: f64 = 10_000_000.0;

/// A stream option ([`StreamOptions`](crate::StreamOptions)) outside its range.
#[derive(Debug, Clone, Copy, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum OptionError {
    /// `period` outside 1 ms – 1 s.
    #[error("period {} must be from 1 ms to 1 s", Rounded(*.period))]
    Period {
        /// The period given.
        period: Duration,
    },
    /// `max_step_deg` not a finite number above 0.
    #[error("max_step_deg {deg} must be a finite number above 0")]
    MaxStep {
        /// The value given, degrees.
        deg: f64,
    },
    /// `lookahead_passes` outside 0–[`MAX_LOOKAHEAD_PASSES`](crate::MAX_LOOKAHEAD_PASSES).
    #[error("lookahead_passes {passes} must be from 0 to {max}")]
    Lookahead {
        /// The value given.
        passes: f64,
        /// The largest accepted.
        max: f64,
    },
    /// A lag-compensation lead (`lag_compensation`) above the controller's ±0.5 s time clamp.
    #[error("a lag_compensation lead of {:.3} s is more than the controller's {:.1} s time clamp; use at most {:.1} s", .lead.as_secs_f64(), .max.as_secs_f64(), .max.as_secs_f64())]
    Lead {
        /// The lead given.
        lead: Duration,
        /// The largest lead.
        max: Duration,
    },
    /// A curvature compensation (`curvature_compensation`) with a gain or a correction bound
    /// out of range.
    #[error("curvature_compensation: gain {gain_s2} s² must be from 0 to {} s² and the correction bound {max_deg}° from 0 to {}°", crate::CurvatureCompensation::LIMIT_S2, crate::CurvatureCompensation::MAX_CORRECTION_DEG)]
    Curvature {
        /// The gain (or the largest gain) given, seconds².
        gain_s2: f64,
        /// The correction bound given, degrees.
        max_deg: f64,
    },
    /// A curvature compensation with held targets (`target_pacing`): the correction is
    /// defined on extrapolated samples only.
    #[error("curvature_compensation needs target_pacing Extrapolated (held targets carry no velocity to correct)")]
    CurvatureNeedsExtrapolatedPacing,
    /// A timeout (`end_timeout`, `hold_timeout`) longer than one day.
    #[error("{option} {} must be at most one day", Rounded(*.timeout))]
    Timeout {
        /// Which option.
        option: &'static str,
        /// The value given.
        timeout: Duration,
    },
    /// `max_gap` shorter than two periods or longer than 500 ms.
    #[error("max_gap {} must be at least two periods ({}) and at most 500 ms", Rounded(*.gap), Rounded(*.period * 2))]
    MaxGap {
        /// The value given.
        gap: Duration,
        /// The period.
        period: Duration,
    },
    /// A tolerance (`start_tolerance_deg`, `end_tolerance_deg`) not a finite number above 0.
    #[error("{option} {deg} must be a finite number above 0")]
    Tolerance {
        /// Which option.
        option: &'static str,
        /// The value given, degrees.
        deg: f64,
    },
    /// A servo's `watchdog` outside its range.
    #[error("servo watchdog {} must be from {} to {}", Rounded(*.watchdog), Rounded(*.min), Rounded(*.max))]
    Watchdog {
        /// The value given.
        watchdog: Duration,
        /// The shortest accepted.
        min: Duration,
        /// The longest accepted.
        max: Duration,
    },
    /// The trajectory takes more than ten million cycles at this period.
    #[error("the trajectory takes {cycles} cycles of {}; at most ten million are streamed — use a longer period or split it", Rounded(*.period))]
    TooManyCycles {
        /// Cycles it would take.
        cycles: f64,
        /// The period.
        period: Duration,
    },
}

/// One point of a trajectory. Units are in the names and types: seconds and degrees.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct TrajectoryPoint {
    /// Time from the start of the stream, seconds (the first point is usually at 0).
    pub time_s: f64,
    /// Joint positions, degrees.
    pub position: JointsDeg,
    /// Joint velocities, degrees per second (estimated when absent).
    pub velocity: Option<JointsDeg>,
    /// Joint accelerations, degrees per second squared (from the spline when absent).
    pub acceleration: Option<JointsDeg>,
}

impl TrajectoryPoint {
    /// A point with a position only.
    pub fn new(time_s: f64, position: JointsDeg) -> TrajectoryPoint {
        TrajectoryPoint {
            time_s,
            position,
            velocity: None,
            acceleration: None,
        }
    }
}

/// Why a trajectory is refused. Each message says how to fix it.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum TrajectoryError {
    /// No points.
    #[error("the trajectory has no points; give at least one")]
    Empty,
    /// A NaN or infinite value.
    #[error("point {index}: {field} is not finite; every value must be a number")]
    NonFinite {
        /// 0-based point index.
        index: usize,
        /// Which value.
        field: &'static str,
    },
    /// The first time stamp is negative.
    #[error("point 0 has time {time_s} s; times must start at 0 or later")]
    NegativeStart {
        /// The first time stamp.
        time_s: f64,
    },
    /// Time stamps are not strictly increasing.
    #[error("point {index} has time {time_s} s, not after the previous point's {previous_s} s; times must increase strictly")]
    TimeNotIncreasing {
        /// 0-based point index.
        index: usize,
        /// Its time.
        time_s: f64,
        /// The previous point's time.
        previous_s: f64,
    },
    /// A position outside the joint ranges (at a point, or between points on the spline).
    #[error("at t = {time_s:.3} s: {limit}; keep the trajectory inside the joint ranges")]
    OutOfRange {
        /// Trajectory time, seconds.
        time_s: f64,
        /// The violation.
        limit: LimitError,
    },
    /// A joint faster than the model's maximum speed.
    #[error("at t = {time_s:.3} s: JT{joint} moves at {speed_deg_s:.1} deg/s, above its maximum {max_deg_s:.1} deg/s; slow the trajectory down")]
    TooFast {
        /// Trajectory time, seconds.
        time_s: f64,
        /// 1-based joint.
        joint: usize,
        /// The speed, deg/s.
        speed_deg_s: f64,
        /// The maximum, deg/s.
        max_deg_s: f64,
    },
    /// Two consecutive samples (one stream period apart) differ by more than the step limit.
    #[error("at t = {time_s:.3} s: JT{joint} steps {step_deg:.3} deg in one cycle, above the limit {max_deg} deg; slow the trajectory down or stream at a higher rate")]
    StepTooLarge {
        /// Trajectory time, seconds.
        time_s: f64,
        /// 1-based joint.
        joint: usize,
        /// The step, degrees.
        step_deg: f64,
        /// The limit, degrees.
        max_deg: f64,
    },
    /// The trajectory does not start where the robot is.
    #[error("the trajectory starts {distance_deg:.3} deg (JT{joint}) from the robot's current position, more than {tolerance_deg} deg; move to its first point first")]
    StartTooFar {
        /// 1-based joint with the largest difference.
        joint: usize,
        /// The difference, degrees.
        distance_deg: f64,
        /// The tolerance, degrees.
        tolerance_deg: f64,
    },
    /// A command-7 sample of the trajectory (position, velocity, acceleration as they would be
    /// sent) is refused: a velocity or acceleration above the model's, or a target the
    /// controller could extrapolate to outside the joint ranges.
    #[error("at t = {time_s:.3} s: {error}")]
    Sample {
        /// Trajectory time, seconds.
        time_s: f64,
        /// The violation.
        error: SampleError,
    },
    /// A stream option out of its range.
    #[error("invalid stream option: {0}")]
    Options(#[from] OptionError),
}

/// A validated sequence of [`TrajectoryPoint`]s: at least one point, finite values, strictly
/// increasing times from 0 or later.
#[derive(Debug, Clone, PartialEq)]
pub struct Trajectory {
    points: Vec<TrajectoryPoint>,
    /// Velocities used by the spline (given or estimated).
    velocities: Vec<JointsDeg>,
}

/// A sample of a trajectory: position, velocity, acceleration at one time.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TrajectorySample {
    /// Degrees.
    pub position: JointsDeg,
    /// Degrees per second.
    pub velocity: JointsDeg,
    /// Degrees per second squared.
    pub acceleration: JointsDeg,
}

impl Trajectory {
    /// Checks the structure (see the type's description) and prepares the spline.
    ///
    /// ```
    /// use fs020n_client::{Trajectory, TrajectoryPoint};
    /// use fs020n_proto::JointsDeg;
    /// let home = JointsDeg::new([0.0, 0.0, -90.0, 0.0, -90.0, 0.0]);
    /// let mut end = home;
    /// end[0] = 10.0;
    /// let t = Trajectory::new(vec![TrajectoryPoint::new(0.0, home), TrajectoryPoint::new(2.0, end)])?;
    /// assert_eq!((t.start_s(), t.end_s(), t.duration_s()), (0.0, 2.0, 2.0));
    /// assert!((t.sample(1.0).position[0] - 5.0).abs() < 1e-9);
    /// # Ok::<(), fs020n_client::TrajectoryError>(())
    /// ```
    pub fn new(points: Vec<TrajectoryPoint>) -> Result<Trajectory, TrajectoryError> {
        if points.is_empty() {
            return Err(TrajectoryError::Empty);
        }
        for (index, p) in points.iter().enumerate() {
            let nf = |field| Err(TrajectoryError::NonFinite { index, field });
            if !p.time_s.is_finite() {
                return nf("time");
            }
            if !p.position.is_finite() {
                return nf("position");
            }
            if p.velocity.is_some_and(|v| !v.is_finite()) {
                return nf("velocity");
            }
            if p.acceleration.is_some_and(|a| !a.is_finite()) {
                return nf("acceleration");
            }
            if index == 0 && p.time_s < 0.0 {
                return Err(TrajectoryError::NegativeStart { time_s: p.time_s });
            }
            if index > 0 && p.time_s <= points[index - 1].time_s {
                return Err(TrajectoryError::TimeNotIncreasing {
                    index,
                    time_s: p.time_s,
                    previous_s: points[index - 1].time_s,
                });
            }
        }
        let n = points.len();
        let velocities = (0..n)
            .map(|i| match points[i].velocity {
                Some(v) => v,
                None if i == 0 || i == n - 1 => JointsDeg::ZERO,
                None => {
                    let (a, b) = (&points[i - 1], &points[i + 1]);
                    let dt = b.time_s - a.time_s;
                    b.position.zip_with(&a.position, |x, y| (x - y) / dt)
                }
            })
            .collect();
        Ok(Trajectory { points, velocities })
    }

    /// The points.
    pub fn points(&self) -> &[TrajectoryPoint] {
        &self.points
    }

    /// Time of the first point, seconds.
    pub fn start_s(&self) -> f64 {
        self.points[0].time_s
    }

    /// Time of the last point, seconds (the stream ends there).
    pub fn end_s(&self) -> f64 {
        self.points[self.points.len() - 1].time_s
    }

    /// How long the trajectory lasts: [`end_s`](Self::end_s) − [`start_s`](Self::start_s),
    /// seconds.
    pub fn duration_s(&self) -> f64 {
        self.end_s() - self.start_s()
    }

    /// The first position.
    pub fn first(&self) -> JointsDeg {
        self.points[0].position
    }

    /// The last position.
    pub fn last(&self) -> JointsDeg {
        self.points[self.points.len() - 1].position
    }

    /// Samples at time `t` (seconds; clamped to the trajectory's span, where the velocity and
    /// acceleration outside are zero).
    pub fn sample(&self, t: f64) -> TrajectorySample {
        self.sample_with_origin(t).0
    }

    /// The sample command 7 sends at time `t`: [`sample`](Self::sample), with the spline's
    /// own acceleration (where no acceleration is given) limited to the model's maximum
    /// acceleration of each joint. Given accelerations are returned unchanged.
    pub fn sample_for_streaming(&self, t: f64, model: &RobotModel) -> TrajectorySample {
        let (mut s, given) = self.sample_with_origin(t);
        if !given {
            let max = model.max_accels_deg_s2();
            for j in 0..JOINT_COUNT {
                s.acceleration[j] = s.acceleration[j].clamp(-max[j], max[j]);
            }
        }
        s
    }

    /// The position of [`sample`](Self::sample) at `t` alone, looking for the segment from
    /// `hint` (the segment of the previous call): a caller sampling at nearby or increasing
    /// times walks a step or two instead of searching the whole trajectory.
    pub(crate) fn position_near(&self, t: f64, hint: &mut usize) -> JointsDeg {
        let n = self.points.len();
        if n == 1 || t.is_nan() || t <= self.start_s() {
            return self.first();
        }
        if t >= self.end_s() {
            return self.last();
        }
        // Segment i: points[i].time_s <= t < points[i + 1].time_s.
        // A few steps from the hint, else a binary search. (start < t < end here, so both
        // walks stop inside the trajectory.)
        let mut i = (*hint).min(n - 2);
        let mut steps = 0;
        while self.points[i].time_s > t && steps < 8 {
            i -= 1;
            steps += 1;
        }
        while self.points[i + 1].time_s <= t && steps < 8 {
            i += 1;
            steps += 1;
        }
        if !(self.points[i].time_s <= t && t < self.points[i + 1].time_s) {
            i = self.points.partition_point(|p| p.time_s <= t) - 1;
        }
        *hint = i;
        let (a, b) = (&self.points[i], &self.points[i + 1]);
        let (va, vb) = (self.velocities[i], self.velocities[i + 1]);
        let h = b.time_s - a.time_s;
        let s = (t - a.time_s) / h;
        let (s2, s3) = (s * s, s * s * s);
        let (h00, h10, h01, h11) = (
            2.0 * s3 - 3.0 * s2 + 1.0,
            s3 - 2.0 * s2 + s,
            -2.0 * s3 + 3.0 * s2,
            s3 - s2,
        );
        let mut p = [0.0; JOINT_COUNT];
        for (j, p) in p.iter_mut().enumerate() {
            let (p0, p1, m0, m1) = (a.position[j], b.position[j], va[j] * h, vb[j] * h);
            *p = h00 * p0 + h10 * m0 + h01 * p1 + h11 * m1;
        }
        JointsDeg(p)
    }

    /// The sample and whether its acceleration was given (interpolated from the points) rather
    /// than the spline's.
    fn sample_with_origin(&self, t: f64) -> (TrajectorySample, bool) {
        let n = self.points.len();
        let rest = |p: JointsDeg| {
            (
                TrajectorySample {
                    position: p,
                    velocity: JointsDeg::ZERO,
                    acceleration: JointsDeg::ZERO,
                },
                true,
            )
        };
        if n == 1 || t.is_nan() || t <= self.start_s() {
            return rest(self.first());
        }
        if t >= self.end_s() {
            return rest(self.last());
        }
        // Segment i: points[i] .. points[i + 1] with points[i].time_s <= t < points[i+1].time_s.
        let i = self.points.partition_point(|p| p.time_s <= t) - 1;
        let (a, b) = (&self.points[i], &self.points[i + 1]);
        let (va, vb) = (self.velocities[i], self.velocities[i + 1]);
        let h = b.time_s - a.time_s;
        let s = (t - a.time_s) / h;
        let (s2, s3) = (s * s, s * s * s);
        let (h00, h10, h01, h11) = (
            2.0 * s3 - 3.0 * s2 + 1.0,
            s3 - 2.0 * s2 + s,
            -2.0 * s3 + 3.0 * s2,
            s3 - s2,
        );
        let (d00, d10, d01, d11) = (
            6.0 * s2 - 6.0 * s,
            3.0 * s2 - 4.0 * s + 1.0,
            -6.0 * s2 + 6.0 * s,
            3.0 * s2 - 2.0 * s,
        );
        let (e00, e10, e01, e11) = (
            12.0 * s - 6.0,
            6.0 * s - 4.0,
            -12.0 * s + 6.0,
            6.0 * s - 2.0,
        );
        let mut p = [0.0; JOINT_COUNT];
        let mut v = [0.0; JOINT_COUNT];
        let mut acc = [0.0; JOINT_COUNT];
        for j in 0..JOINT_COUNT {
            let (p0, p1, m0, m1) = (a.position[j], b.position[j], va[j] * h, vb[j] * h);
            p[j] = h00 * p0 + h10 * m0 + h01 * p1 + h11 * m1;
            v[j] = (d00 * p0 + d10 * m0 + d01 * p1 + d11 * m1) / h;
            acc[j] = (e00 * p0 + e10 * m0 + e01 * p1 + e11 * m1) / (h * h);
        }
        let (acceleration, given) = match (a.acceleration, b.acceleration) {
            (Some(x), Some(y)) => (x.zip_with(&y, |x, y| x + s * (y - x)), true),
            _ => (JointsDeg(acc), false),
        };
        (
            TrajectorySample {
                position: JointsDeg(p),
                velocity: JointsDeg(v),
                acceleration,
            },
            given,
        )
    }

    /// Checks the trajectory against the model and a cycle `period`: every point and every
    /// sample one period apart inside the joint ranges and below the maximum joint speeds,
    /// and no joint stepping more than `max_step_deg` between consecutive samples. (The public
    /// check is [`StreamOptions::validate`](crate::StreamOptions::validate).)
    pub(crate) fn validate_waypoints(
        &self,
        model: &RobotModel,
        period: Duration,
        max_step_deg: f64,
    ) -> Result<(), TrajectoryError> {
        let period_s = period.as_secs_f64();
        if period_s <= 0.0 {
            return Err(OptionError::Period { period }.into());
        }
        if !(max_step_deg.is_finite() && max_step_deg > 0.0) {
            return Err(OptionError::MaxStep { deg: max_step_deg }.into());
        }
        let max_speed = model.max_speeds_deg_s();
        let check = |t: f64, s: &TrajectorySample| -> Result<(), TrajectoryError> {
            model
                .check_limits(&s.position)
                .map_err(|limit| TrajectoryError::OutOfRange { time_s: t, limit })?;
            for j in 0..JOINT_COUNT {
                if s.velocity[j].abs() > max_speed[j] {
                    return Err(TrajectoryError::TooFast {
                        time_s: t,
                        joint: j + 1,
                        speed_deg_s: s.velocity[j].abs(),
                        max_deg_s: max_speed[j],
                    });
                }
            }
            Ok(())
        };
        for (i, p) in self.points.iter().enumerate() {
            let s = TrajectorySample {
                position: p.position,
                velocity: self.velocities[i],
                acceleration: JointsDeg::ZERO,
            };
            check(p.time_s, &s)?;
        }
        let (t0, t1) = (self.start_s(), self.end_s());
        let cycles = ((t1 - t0) / period_s).ceil();
        if cycles > MAX_CYCLES {
            return Err(OptionError::TooManyCycles { cycles, period }.into());
        }
        let cycles = cycles as u64;
        let mut prev = self.sample(t0);
        for k in 1..=cycles {
            let t = (t0 + k as f64 * period_s).min(t1);
            let s = self.sample(t);
            check(t, &s)?;
            for j in 0..JOINT_COUNT {
                let step = (s.position[j] - prev.position[j]).abs();
                if step > max_step_deg {
                    return Err(TrajectoryError::StepTooLarge {
                        time_s: t,
                        joint: j + 1,
                        step_deg: step,
                        max_deg: max_step_deg,
                    });
                }
            }
            prev = s;
        }
        Ok(())
    }

    /// [`validate_waypoints`](Self::validate_waypoints), then the checks of command 7 with `lookahead_passes`:
    /// at every point and every sample one period apart, the sample as it would be sent
    /// ([`sample_for_streaming`](Self::sample_for_streaming)) passes
    /// [`check_stream_sample`](crate::check_stream_sample) — velocities and accelerations at
    /// most the model's maxima, and every target the controller can extrapolate to over
    /// [`extrapolation_window`](crate::extrapolation_window) inside the joint ranges
    /// ([`TrajectoryError::Sample`]).
    pub(crate) fn validate_extrapolated(
        &self,
        model: &RobotModel,
        period: Duration,
        max_step_deg: f64,
        lookahead_passes: f64,
    ) -> Result<(), TrajectoryError> {
        self.validate_waypoints(model, period, max_step_deg)?;
        let period_s = period.as_secs_f64();
        let check = |t: f64| -> Result<(), TrajectoryError> {
            let s = self.sample_for_streaming(t, model);
            check_stream_sample(
                model,
                &StreamSample {
                    t0_s: 0.0,
                    lookahead_passes,
                    position: s.position,
                    velocity: s.velocity,
                    acceleration: s.acceleration,
                },
            )
            .map_err(|error| TrajectoryError::Sample { time_s: t, error })
        };
        for p in &self.points {
            check(p.time_s)?;
        }
        let (t0, t1) = (self.start_s(), self.end_s());
        // `validate_waypoints` bounded the number of cycles.
        let cycles = ((t1 - t0) / period_s).ceil() as u64;
        for k in 1..=cycles {
            check((t0 + k as f64 * period_s).min(t1))?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn home() -> JointsDeg {
        JointsDeg::new([0.0, 0.0, -90.0, 0.0, -90.0, 0.0])
    }

    fn line(to_jt1: f64, secs: f64) -> Trajectory {
        let mut end = home();
        end[0] = to_jt1;
        Trajectory::new(vec![
            TrajectoryPoint::new(0.0, home()),
            TrajectoryPoint::new(secs, end),
        ])
        .unwrap()
    }

    #[test]
    fn position_near_is_the_sample_position_whatever_the_hint() {
        let points: Vec<TrajectoryPoint> = (0..40)
            .map(|k| {
                let t = f64::from(k) * 0.004 + if k > 20 { 0.01 } else { 0.0 };
                TrajectoryPoint::new(
                    t,
                    JointsDeg::new([(t * 7.0).sin() * 20.0, t, -90.0, 0.0, -90.0, 0.0]),
                )
            })
            .collect();
        let tr = Trajectory::new(points).unwrap();
        let mut hint = 0;
        for (k, t) in (-10..200)
            .chain((-10..200).rev())
            .map(|k| (k, f64::from(k) * 0.0009))
        {
            let want = tr.sample(t).position;
            assert_eq!(tr.position_near(t, &mut hint), want, "t {t} (step {k})");
            let mut far = 37;
            assert_eq!(tr.position_near(t, &mut far), want, "t {t}, hint far away");
        }
    }
    #[test]
    fn structure_is_checked() {
        assert_eq!(Trajectory::new(vec![]), Err(TrajectoryError::Empty));
        let mut p = TrajectoryPoint::new(0.0, home());
        p.position[3] = f64::NAN;
        assert!(matches!(
            Trajectory::new(vec![p]),
            Err(TrajectoryError::NonFinite {
                index: 0,
                field: "position"
            })
        ));
        assert!(matches!(
            Trajectory::new(vec![TrajectoryPoint::new(-1.0, home())]),
            Err(TrajectoryError::NegativeStart { .. })
        ));
        assert!(matches!(
            Trajectory::new(vec![
                TrajectoryPoint::new(0.0, home()),
                TrajectoryPoint::new(1.0, home()),
                TrajectoryPoint::new(1.0, home()),
            ]),
            Err(TrajectoryError::TimeNotIncreasing { index: 2, .. })
        ));
    }

    #[test]
    fn spline_from_rest_to_rest() {
        let t = line(10.0, 2.0);
        let mid = t.sample(1.0);
        assert!((mid.position[0] - 5.0).abs() < 1e-12);
        // Hermite with zero end velocities: peak speed 1.5 * 10 / 2.
        assert!((mid.velocity[0] - 7.5).abs() < 1e-12);
        assert_eq!(t.sample(-1.0).position, home());
        assert_eq!(t.sample(5.0).velocity, JointsDeg::ZERO);
        assert!((t.sample(0.0).acceleration[0]).abs() < 1e-12);
        assert!((t.sample(1e-9).acceleration[0] - 15.0).abs() < 1e-6);
    }

    #[test]
    fn validation_against_model_and_period() {
        let m = RobotModel::fs020n();
        let ms20 = Duration::from_millis(20);
        assert!(line(10.0, 2.0).validate_waypoints(&m, ms20, 1.0).is_ok());
        // 7.5 deg/s peak * 0.02 s = 0.15 deg per cycle.
        assert!(matches!(
            line(10.0, 2.0).validate_waypoints(&m, ms20, 0.1),
            Err(TrajectoryError::StepTooLarge { joint: 1, .. })
        ));
        assert!(matches!(
            line(170.0, 20.0).validate_waypoints(&m, ms20, 5.0),
            Err(TrajectoryError::OutOfRange { .. })
        ));
        assert!(matches!(
            line(150.0, 0.5).validate_waypoints(&m, ms20, 100.0),
            Err(TrajectoryError::TooFast { joint: 1, .. })
        ));
        assert!(matches!(
            line(10.0, 2.0).validate_waypoints(&m, Duration::ZERO, 1.0),
            Err(TrajectoryError::Options(OptionError::Period { .. }))
        ));
    }
}
