//! Curvature feed-forward for command 7: what a time shift cannot correct.
//!
//! The controller follows each command-7 sample with a 0.1 s straight-line move blended with
//! the one before (protocol-1040 §2.4). Besides a delay (which the lead of
//! [`LagCompensation`](crate::LagCompensation) removes), that pipeline smooths the path like a
//! low-pass filter: a curved path is rounded inward, by about `g · p̈` for a trajectory `p` with
//! acceleration `p̈` and a constant `g` of the pipeline (seconds²). A pure time shift changes
//! the phase, never the magnitude; commanding `p − g · p̈` instead of `p` (with the velocity
//! of the sample changed consistently) cancels that rounding to first order.
//!
//! The gain `g` is fixed by the caller. The correction is bounded — the gain by
//! [`CurvatureCompensation::LIMIT_S2`], each joint's correction in degrees, its change by
//! [`CORRECTION_RATE_DEG_S`] — and a corrected sample is checked like every other (the step
//! between samples, the joint ranges and [`check_stream_sample`](crate::check_stream_sample)
//! over the whole window the controller can extrapolate it to), with the ranges shrunk by the
//! correction's bound; one that fails is replaced by the correction returning toward zero at
//! that rate, and if that fails too, by the plain sample.
//!
//! Measured on the emulated controller (docs/PERFORMANCE.md), it does not help: the error left
//! after the online lead is not a steady rounding but lies where the fast arm makes the motion
//! program wait for ACCURACY, and any change to the samples — this correction included — moves
//! it between ≈ 0.09° and ≈ 0.16° on the circle with the phase of the passes. Off by default; kept as an
//! option for a controller whose pipeline does round the path steadily.

use fs020n_proto::{JointsDeg, JOINT_COUNT};
use serde::Serialize;

use crate::trajectory::{Trajectory, TrajectorySample};

/// Half-width of the central second differences of the trajectory's positions and velocities
/// for the correction, seconds (one sample period at 50 Hz: smooths the spline's
/// piecewise-linear acceleration without blurring the path's own curvature).
const DIFF_STEP_S: f64 = 0.02;

/// Whether a command-7 stream boosts curved paths against the rounding by the controller's
/// pipeline: samples sent at `p − g · p̈` (position) and `v − g · v̈` (velocity), each joint's
/// correction bounded. Default `Off`: on the emulated controller it made tracking worse
/// (docs/PERFORMANCE.md, "Where command 7's error comes from").
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize)]
pub enum CurvatureCompensation {
    /// No correction (default): the samples are the trajectory's (only the lead, if any, applies).
    #[default]
    Off,
    /// A fixed gain `g`, seconds², with each joint's correction bounded by `max_deg`.
    Fixed {
        /// Gain `g`, seconds² (0 to [`LIMIT_S2`](CurvatureCompensation::LIMIT_S2)).
        gain_s2: f64,
        /// Largest correction of any joint, degrees (0 to
        /// [`MAX_CORRECTION_DEG`](CurvatureCompensation::MAX_CORRECTION_DEG)).
        max_deg: f64,
    },
}

impl CurvatureCompensation {
    /// Largest gain accepted, seconds²: a second-order low-pass of 0.1 s has `g` = 0.01 s²;
    /// a gain this size corrects 2° at 100°/s².
    pub const LIMIT_S2: f64 = 0.02;
    /// Largest per-joint correction accepted, degrees.
    pub const MAX_CORRECTION_DEG: f64 = 2.0;

    /// `Err` with the reason when the gain or the correction bound is out of range.
    pub fn validate(&self) -> Result<(), String> {
        let (gain, max_deg) = match *self {
            CurvatureCompensation::Off => return Ok(()),
            CurvatureCompensation::Fixed { gain_s2, max_deg } => (gain_s2, max_deg),
        };
        if !(0.0..=Self::LIMIT_S2).contains(&gain) {
            return Err(format!(
                "a curvature gain of {gain} s² is outside 0–{} s²; use a gain in that range",
                Self::LIMIT_S2
            ));
        }
        if !(0.0..=Self::MAX_CORRECTION_DEG).contains(&max_deg) {
            return Err(format!(
                "a curvature correction of {max_deg}° is outside 0–{}°; use a bound in that range",
                Self::MAX_CORRECTION_DEG
            ));
        }
        Ok(())
    }

    /// The bound on each joint's correction, degrees (0 when off).
    pub(crate) fn max_deg(&self) -> f64 {
        match *self {
            CurvatureCompensation::Off => 0.0,
            CurvatureCompensation::Fixed { max_deg, .. } => {
                max_deg.clamp(0.0, Self::MAX_CORRECTION_DEG)
            }
        }
    }

    /// The gain, seconds² (0 when off or not a number).
    pub(crate) fn gain_s2(&self) -> f64 {
        match *self {
            CurvatureCompensation::Off => 0.0,
            CurvatureCompensation::Fixed { gain_s2, .. } if gain_s2.is_finite() => {
                gain_s2.clamp(0.0, Self::LIMIT_S2)
            }
            CurvatureCompensation::Fixed { .. } => 0.0,
        }
    }
}

/// Fastest change of a joint's correction, degrees per second: a path whose acceleration
/// jumps (a bang-bang profile) asks for a correction that jumps by `2 · g · Δp̈`; limited to
/// this rate, the correction adds at most `rate × period` to the step between two samples.
pub(crate) const CORRECTION_RATE_DEG_S: f64 = 5.0;

/// `sample` (the trajectory's at `t`) corrected by the gain `gain_s2`: position
/// `p − g · D²p`, velocity `v − g · D²v`, acceleration unchanged (its own second difference
/// is the spline's noise), with `D²` the central second difference over [`DIFF_STEP_S`]. Each
/// joint's position correction is bounded by `max_deg`, and moves from `previous` (the
/// correction of the sample sent before, `sent − plain`) by at most `max_change_deg`; the
/// velocity correction is scaled down with it. A gain of 0 brings the correction back to 0
/// at that rate.
pub(crate) fn corrected(
    trajectory: &Trajectory,
    t: f64,
    sample: &TrajectorySample,
    gain_s2: f64,
    max_deg: f64,
    previous: &JointsDeg,
    max_change_deg: f64,
) -> TrajectorySample {
    let gain = if gain_s2.is_finite() {
        gain_s2.clamp(0.0, CurvatureCompensation::LIMIT_S2)
    } else {
        0.0
    };
    let max_deg = if max_deg.is_finite() {
        max_deg.clamp(0.0, CurvatureCompensation::MAX_CORRECTION_DEG)
    } else {
        0.0
    };
    let max_change = if max_change_deg.is_finite() {
        max_change_deg.max(0.0)
    } else {
        0.0
    };
    let h = DIFF_STEP_S;
    let (before, after) = (trajectory.sample(t - h), trajectory.sample(t + h));
    let here = trajectory.sample(t);
    let mut out = *sample;
    for j in 0..JOINT_COUNT {
        let dp = gain * (before.position[j] - 2.0 * here.position[j] + after.position[j]) / (h * h);
        let dv = gain * (before.velocity[j] - 2.0 * here.velocity[j] + after.velocity[j]) / (h * h);
        let (dp, dv) = if dp.is_finite() && dv.is_finite() {
            (dp, dv)
        } else {
            (0.0, 0.0)
        };
        // the correction asked for (subtracted from the position), bounded
        let want = (-dp).clamp(-max_deg, max_deg);
        let prev = if previous[j].is_finite() {
            previous[j].clamp(-max_deg, max_deg)
        } else {
            0.0
        };
        let c = want.clamp(prev - max_change, prev + max_change);
        let scale = if dp != 0.0 {
            (c / -dp).clamp(0.0, 1.0)
        } else {
            0.0
        };
        out.position[j] += c;
        out.velocity[j] -= dv * scale;
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::trajectory::TrajectoryPoint;

    /// JT1 on a sine of `amp_deg` and `omega` rad/s for 6 s, 10 ms apart.
    fn sine(amp_deg: f64, omega: f64) -> Trajectory {
        let points = (0..=600)
            .map(|k| {
                let t = f64::from(k) * 0.01;
                let mut p = TrajectoryPoint::new(
                    t,
                    JointsDeg::new([amp_deg * (omega * t).sin(), 0.0, -90.0, 0.0, -90.0, 0.0]),
                );
                p.velocity = Some(JointsDeg::new([
                    amp_deg * omega * (omega * t).cos(),
                    0.0,
                    0.0,
                    0.0,
                    0.0,
                    0.0,
                ]));
                p
            })
            .collect();
        Trajectory::new(points).unwrap()
    }

    #[test]
    fn a_sine_is_boosted_by_the_gain_times_omega_squared() {
        let (amp, omega, gain) = (10.0, 2.0, 0.005);
        let traj = sine(amp, omega);
        // at the crest: p = amp, p̈ = −amp·ω²; corrected p = amp·(1 + g·ω²)
        let t = std::f64::consts::FRAC_PI_2 / omega + 2.0 * std::f64::consts::PI / omega;
        let s = traj.sample(t);
        let c = corrected(&traj, t, &s, gain, 1.0, &JointsDeg::ZERO, 10.0);
        let want = amp * (1.0 + gain * omega * omega);
        assert!(
            (c.position[0] - want).abs() < 2e-3,
            "{} vs {want}",
            c.position[0]
        );
        // the velocity is boosted consistently where the sine crosses zero
        let t0 = 2.0 * std::f64::consts::PI / omega;
        let c0 = corrected(
            &traj,
            t0,
            &traj.sample(t0),
            gain,
            1.0,
            &JointsDeg::ZERO,
            10.0,
        );
        let want_v = amp * omega * (1.0 + gain * omega * omega);
        assert!(
            (c0.velocity[0] - want_v).abs() < 0.02,
            "{} vs {want_v}",
            c0.velocity[0]
        );
        assert!(c0.position[0].abs() < 1e-3);
        // joints that do not move are not touched
        assert_eq!(c.position[2], -90.0);
    }

    #[test]
    fn the_correction_is_bounded_per_joint_and_by_the_gain_limit() {
        let traj = sine(10.0, 6.0); // p̈ up to 360°/s²
        let t = std::f64::consts::FRAC_PI_2 / 6.0 + 1.0;
        let t = t + (std::f64::consts::TAU / 6.0) * 0.0;
        let s = traj.sample(t);
        // an absurd gain is clamped to LIMIT_S2, then the correction to max_deg
        for gain in [1.0, f64::INFINITY, 0.02] {
            let c = corrected(&traj, t, &s, gain, 0.25, &JointsDeg::ZERO, 10.0);
            let d = c.position.max_abs_diff(&s.position);
            assert!(d <= 0.25 + 1e-12, "gain {gain}: corrected by {d}°");
        }
        assert_eq!(
            corrected(&traj, t, &s, f64::NAN, 1.0, &JointsDeg::ZERO, 10.0),
            s
        );
        assert_eq!(
            corrected(&traj, t, &s, -0.01, 1.0, &JointsDeg::ZERO, 10.0),
            s,
            "a negative gain is zero"
        );
        assert_eq!(
            corrected(&traj, t, &s, 0.01, f64::NAN, &JointsDeg::ZERO, 10.0),
            s
        );
        // an absurd bound is clamped to MAX_CORRECTION_DEG
        let c = corrected(&traj, t, &s, 0.02, 100.0, &JointsDeg::ZERO, 10.0);
        assert!(
            c.position.max_abs_diff(&s.position)
                <= CurvatureCompensation::MAX_CORRECTION_DEG + 1e-12
        );
    }

    #[test]
    fn the_correction_moves_from_the_previous_one_at_most_by_the_change_allowed() {
        let traj = sine(10.0, 6.0);
        let t = std::f64::consts::FRAC_PI_2 / 6.0 + 1.0 + std::f64::consts::TAU / 6.0;
        let s = traj.sample(t);
        // at the crest the full correction is +0.02 · 360 → bounded to 1°; from 0 it moves
        // 0.1° only
        let c = corrected(&traj, t, &s, 0.02, 1.0, &JointsDeg::ZERO, 0.1);
        assert!(
            (c.position[0] - s.position[0] - 0.1).abs() < 1e-9,
            "{}",
            c.position[0]
        );
        // with no gain it returns toward 0 from where it was, at the same rate
        let mut prev = JointsDeg::ZERO;
        prev[0] = 0.8;
        let back = corrected(&traj, t, &s, 0.0, 1.0, &prev, 0.1);
        assert!((back.position[0] - s.position[0] - 0.7).abs() < 1e-9);
        assert_eq!(
            back.velocity, s.velocity,
            "no velocity correction without a gain"
        );
        // a previous correction beyond the bound is taken at the bound
        prev[0] = 50.0;
        let c = corrected(&traj, t, &s, 0.0, 1.0, &prev, 0.1);
        assert!((c.position[0] - s.position[0] - 0.9).abs() < 1e-9);
    }

    #[test]
    fn options_out_of_range_are_refused() {
        assert!(CurvatureCompensation::default().validate().is_ok());
        assert!(CurvatureCompensation::Off.validate().is_ok());
        assert!(CurvatureCompensation::Fixed {
            gain_s2: 0.05,
            max_deg: 1.0
        }
        .validate()
        .is_err());
        assert!(CurvatureCompensation::Fixed {
            gain_s2: 0.01,
            max_deg: 5.0
        }
        .validate()
        .is_err());
        assert_eq!(CurvatureCompensation::default(), CurvatureCompensation::Off);
        assert!(CurvatureCompensation::Fixed {
            gain_s2: f64::NAN,
            max_deg: 1.0
        }
        .validate()
        .is_err());
    }
}
