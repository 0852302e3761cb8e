//! Synchronized joint moves with a trapezoidal velocity profile, in closed form.
//!
//! All joints start and stop together and move on a straight line in joint space: every joint
//! follows the same normalized profile `s(t)` (0 → 1), scaled by its own distance:
//! `q_i(t) = from_i + (to_i − from_i) · s(t)`.
//!
//! **Limits.** With a speed fraction `f` in (0, 1], joint `i` may move at most at
//! `f · max_speed_deg_s` and accelerate at most at `max_accel_deg_s2` (acceleration is **not**
//! scaled by the speed fraction: 100 % acceleration, like `ACCEL 100` in the AS program). The
//! normalized profile therefore has peak speed `V = min_i f·v_i/|Δ_i|` and acceleration
//! `A = min_i a_i/|Δ_i|` — the tightest joint sets the time, the others are slowed down in
//! proportion. If `V²/A ≥ 1` the cruise speed is never reached and the profile is triangular.
//!
//! Duration: trapezoid `T = 1/V + V/A`, triangle `T = 2/√A`. A zero-length move lasts 0 s.

use fs020n_proto::{JointsDeg, JOINT_COUNT};

use crate::model::RobotModel;

/// The smallest speed fraction [`JointMove::plan`] accepts (0.01 %); smaller values are raised
/// to it.
pub const MIN_SPEED_FRACTION: f64 = 1e-4;

/// Why [`JointMove::try_plan`] refused to plan.
#[derive(Debug, Clone, Copy, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum MotionError {
    /// The speed fraction is not in (0, 1].
    #[error("speed fraction {0} is not in (0, 1]")]
    SpeedFraction(f64),
    /// A joint value is NaN or infinite.
    #[error("JT{0} start or target value is not finite")]
    NonFinite(usize),
}

/// A planned synchronized joint move (degrees, seconds).
///
/// ```
/// use fs020n_kin::{JointMove, JointsDeg, RobotModel};
/// let model = RobotModel::fs020n();
/// let to = JointsDeg::new([90.0, 0.0, -90.0, 0.0, -90.0, 0.0]);
/// let mv = JointMove::plan(&model, model.home, to, 1.0);
/// // Only JT1 moves: 90 deg with 235 deg/s^2 never reaches 190 deg/s (triangle: 2 sqrt(90/235) s)
/// assert!(mv.is_triangular());
/// assert!((mv.duration_s() - 2.0 * (90.0_f64 / 235.0).sqrt()).abs() < 1e-12);
/// // At 10 % speed (19 deg/s) it cruises: 90/19 + 19/235 s
/// let slow = JointMove::plan(&model, model.home, to, 0.1);
/// assert!((slow.duration_s() - (90.0 / 19.0 + 19.0 / 235.0)).abs() < 1e-9);
/// assert_eq!(mv.position_at(mv.duration_s()), to);
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct JointMove {
    from: JointsDeg,
    to: JointsDeg,
    speed_fraction: f64,
    duration_s: f64,
    /// Duration of the acceleration (and of the deceleration) phase, seconds.
    accel_time_s: f64,
    /// Peak speed of the normalized profile, 1/s.
    peak_rate: f64,
    /// Acceleration of the normalized profile, 1/s².
    accel_rate: f64,
}

impl JointMove {
    /// Plans a move, never failing: a speed fraction outside (0, 1] is clamped into
    /// [[`MIN_SPEED_FRACTION`], 1] (NaN becomes the minimum), and a joint whose start, target or
    /// distance is not finite does not move (non-finite start values are replaced by the target,
    /// or 0).
    pub fn plan(model: &RobotModel, from: JointsDeg, to: JointsDeg, speed_fraction: f64) -> Self {
        let f = if speed_fraction.is_nan() {
            MIN_SPEED_FRACTION
        } else {
            speed_fraction.clamp(MIN_SPEED_FRACTION, 1.0)
        };
        let mut from = from;
        let mut to = to;
        for i in 0..JOINT_COUNT {
            if !from[i].is_finite() {
                from[i] = if to[i].is_finite() { to[i] } else { 0.0 };
            }
            if !(to[i] - from[i]).is_finite() {
                to[i] = from[i];
            }
        }
        Self::build(model, from, to, f)
    }

    /// Plans a move, refusing a speed fraction outside (0, 1] or non-finite joint values.
    pub fn try_plan(
        model: &RobotModel,
        from: JointsDeg,
        to: JointsDeg,
        speed_fraction: f64,
    ) -> Result<Self, MotionError> {
        if speed_fraction.is_nan() || speed_fraction <= 0.0 || speed_fraction > 1.0 {
            return Err(MotionError::SpeedFraction(speed_fraction));
        }
        for i in 0..JOINT_COUNT {
            // A distance that overflows (e.g. -1e308 to 1e308) is as unusable as NaN.
            if !(to[i] - from[i]).is_finite() {
                return Err(MotionError::NonFinite(i + 1));
            }
        }
        Ok(Self::build(model, from, to, speed_fraction))
    }

    fn build(model: &RobotModel, from: JointsDeg, to: JointsDeg, f: f64) -> Self {
        let mut v = f64::INFINITY;
        let mut a = f64::INFINITY;
        for (i, spec) in model.joints.iter().enumerate() {
            let d = (to[i] - from[i]).abs();
            if d > 0.0 {
                v = v.min(f * spec.max_speed_deg_s / d);
                a = a.min(spec.max_accel_deg_s2 / d);
            }
        }
        if from == to || !a.is_finite() {
            // Zero-length move (or a model without an acceleration limit: instantaneous).
            return Self {
                from,
                to,
                speed_fraction: f,
                duration_s: 0.0,
                accel_time_s: 0.0,
                peak_rate: 0.0,
                accel_rate: 0.0,
            };
        }
        let (duration_s, accel_time_s, peak_rate) = if v * v >= a {
            // triangular: accelerate to the middle, decelerate to the end
            let ta = (1.0 / a).sqrt();
            (2.0 * ta, ta, a * ta)
        } else {
            let ta = v / a;
            (1.0 / v + ta, ta, v)
        };
        Self {
            from,
            to,
            speed_fraction: f,
            duration_s,
            accel_time_s,
            peak_rate,
            accel_rate: a,
        }
    }

    /// Start configuration, degrees.
    pub fn from(&self) -> JointsDeg {
        self.from
    }

    /// Target configuration, degrees.
    pub fn to(&self) -> JointsDeg {
        self.to
    }

    /// The speed fraction used (after clamping by [`JointMove::plan`]).
    pub fn speed_fraction(&self) -> f64 {
        self.speed_fraction
    }

    /// Total duration, seconds (0 for a zero-length move).
    pub fn duration_s(&self) -> f64 {
        self.duration_s
    }

    /// Duration of the acceleration phase (equal to the deceleration phase), seconds.
    pub fn accel_time_s(&self) -> f64 {
        self.accel_time_s
    }

    /// `true` when the profile is triangular (never cruises at the peak speed).
    pub fn is_triangular(&self) -> bool {
        self.duration_s > 0.0 && 2.0 * self.accel_time_s >= self.duration_s
    }

    /// Normalized progress `s(t)` in [0, 1] and its first two time derivatives.
    fn profile(&self, t: f64) -> (f64, f64, f64) {
        let total = self.duration_s;
        if total <= 0.0 {
            return (1.0, 0.0, 0.0);
        }
        if t.is_nan() || t <= 0.0 {
            // before the start, or NaN
            return (0.0, 0.0, 0.0);
        }
        if t >= total {
            return (1.0, 0.0, 0.0);
        }
        let (ta, a, v) = (self.accel_time_s, self.accel_rate, self.peak_rate);
        if t < ta {
            (0.5 * a * t * t, a * t, a)
        } else if t <= total - ta {
            (0.5 * a * ta * ta + v * (t - ta), v, 0.0)
        } else {
            let r = total - t;
            (1.0 - 0.5 * a * r * r, a * r, -a)
        }
    }

    /// Joint positions at time `t` seconds after the start (clamped to [0, duration]; NaN is
    /// the start). Exactly `from` at `t ≤ 0` and exactly `to` at `t ≥ duration`.
    pub fn position_at(&self, t: f64) -> JointsDeg {
        if self.duration_s <= 0.0 || t >= self.duration_s {
            return self.to;
        }
        if t.is_nan() || t <= 0.0 {
            return self.from;
        }
        let (s, _, _) = self.profile(t);
        self.from.zip_with(&self.to, |a, b| a + (b - a) * s)
    }

    /// Joint velocities at time `t`, deg/s (0 before the start and after the end).
    pub fn velocity_at(&self, t: f64) -> JointsDeg {
        let (_, ds, _) = self.profile(t);
        self.from.zip_with(&self.to, |a, b| (b - a) * ds)
    }

    /// Joint accelerations at time `t`, deg/s² (piecewise constant; 0 outside the move).
    pub fn acceleration_at(&self, t: f64) -> JointsDeg {
        let (_, _, dds) = self.profile(t);
        self.from.zip_with(&self.to, |a, b| (b - a) * dds)
    }

    /// Peak joint velocities (reached during the cruise phase), deg/s, signed.
    pub fn peak_velocity(&self) -> JointsDeg {
        self.from
            .zip_with(&self.to, |a, b| (b - a) * self.peak_rate)
    }
}
