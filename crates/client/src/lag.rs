//! Online estimation of the controller's tracking lag while streaming, and the lead that
//! compensates it.
//!
//! The arm follows command 7 through the controller's own pipeline — the look-ahead of one
//! motion, a 0.1 s straight-line move per pass, blending within ACCURACY — so it runs behind the
//! trajectory by a roughly constant time `P`. The protocol lets the client observe it: every
//! reply carries the joints and the server time (TIMER(1)). The estimator compares each reply's
//! joints with the path the client commanded and finds the time shift that explains them best
//! (least squares over a grid of shifts, with exponential forgetting so it follows changes).
//!
//! Compensation: with a lead `λ`, a sample that holds at trajectory time τ is stamped as if it
//! held at τ − λ, so the controller extrapolates it `λ` further along its velocity (within its
//! ±0.5 s clamp): the arm aims at the trajectory `λ` ahead, and arrives there `P` later. The lead
//! is the estimated `P`, bounded by [`LagCompensation::Online::max`]; it changes no safety
//! check — every sample is still checked over the whole window the controller can extrapolate it
//! to ([`check_stream_sample`](crate::check_stream_sample)), which the ±0.5 s clamp bounds.

use std::time::Duration;

use fs020n_proto::{JointsDeg, JOINT_COUNT};
use serde::Serialize;

use crate::trajectory::Trajectory;

/// How a command-7 stream compensates the controller's tracking lag.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub enum LagCompensation {
    /// No compensation: samples are stamped with the time at which they hold.
    Off,
    /// A fixed lead (at most 0.5 s, the controller's clamp).
    Fixed(Duration),
    /// The lead follows the lag estimated online from the replies (default), between 0 and
    /// `max`.
    Online {
        /// Largest lead, at most 0.5 s. Default 0.3 s.
        max: Duration,
    },
}

impl Default for LagCompensation {
    fn default() -> Self {
        LagCompensation::Online {
            max: Duration::from_millis(300),
        }
    }
}

impl LagCompensation {
    /// Largest lead the controller's time clamp can express.
    pub const LIMIT: Duration = Duration::from_millis(500);

    /// `Err` with the reason when the lead is outside 0–[`LIMIT`](Self::LIMIT).
    pub fn validate(&self) -> Result<(), String> {
        let d = match self {
            LagCompensation::Off => return Ok(()),
            LagCompensation::Fixed(d) => d,
            LagCompensation::Online { max } => max,
        };
        if *d > Self::LIMIT {
            return Err(format!(
                "a lead of {:.3} s is more than the controller's 0.5 s time clamp; use at most 0.5 s",
                d.as_secs_f64()
            ));
        }
        Ok(())
    }
}

/// Resolution of the lag grid, seconds.
const GRID_STEP_S: f64 = 0.005;
/// Shortest lag considered (the arm ahead of the trajectory), seconds.
const GRID_MIN_S: f64 = -0.2;
/// Longest lag considered, seconds.
const GRID_MAX_S: f64 = 0.6;
/// Memory of the online estimate, seconds of trajectory time: the lag depends on the speed, so
/// the estimate must follow it within a fraction of a second (measured on the emulator: 0.2 s
/// tracks a circle about twice as well as 1 s).
const MEMORY_S: f64 = 0.2;
/// Observations while the trajectory barely moves say nothing about time.
const MIN_SPEED_DEG_S: f64 = 1.0;
/// Observations before the online lead moves.
const WARMUP: u32 = 10;
/// Least trajectory time between two observations, seconds: faster streams (250 Hz) add
/// nothing the forgetting would keep, and each observation costs ~320 trajectory samples.
const MIN_OBSERVATION_INTERVAL_S: f64 = 0.0075;

/// Estimates the lag online and keeps the lead.
#[derive(Debug, Clone)]
pub(crate) struct LagEstimator {
    mode: LagCompensation,
    /// Pipeline lag `P`: cost of each candidate against the path as commanded (with the lead),
    /// with forgetting.
    pipeline: Vec<f64>,
    /// Apparent lag against the trajectory itself, over the whole stream (what is reported).
    apparent: Vec<f64>,
    observations: u32,
    last_tau: Option<f64>,
    lead_s: f64,
}

impl LagEstimator {
    pub(crate) fn new(mode: LagCompensation) -> LagEstimator {
        let n = ((GRID_MAX_S - GRID_MIN_S) / GRID_STEP_S).round() as usize + 1;
        let lead_s = match mode {
            LagCompensation::Fixed(d) => d.as_secs_f64().min(LagCompensation::LIMIT.as_secs_f64()),
            _ => 0.0,
        };
        LagEstimator {
            mode,
            pipeline: vec![0.0; n],
            apparent: vec![0.0; n],
            observations: 0,
            last_tau: None,
            lead_s,
        }
    }

    /// Like [`new`](Self::new), but an online lead starts at `prior_s` (bounded like the
    /// estimate) instead of none, until the estimate takes over after the warm-up.
    pub(crate) fn starting_at(mode: LagCompensation, prior_s: f64) -> LagEstimator {
        let mut est = LagEstimator::new(mode);
        if let LagCompensation::Online { max } = mode {
            let max_s = max.as_secs_f64().min(LagCompensation::LIMIT.as_secs_f64());
            est.lead_s = prior_s.clamp(0.0, max_s);
        }
        est
    }

    /// The lead to stamp samples with now, seconds.
    pub(crate) fn lead_s(&self) -> f64 {
        self.lead_s
    }

    /// One reply: the arm at `actual` when the trajectory was at time `tau` (the reply's server
    /// time mapped to trajectory time); `lead_then_s` is the lead of the samples the arm was
    /// following.
    pub(crate) fn observe(
        &mut self,
        trajectory: &Trajectory,
        tau: f64,
        actual: &JointsDeg,
        lead_then_s: f64,
    ) {
        let moving = trajectory
            .sample(tau)
            .velocity
            .iter()
            .any(|v| v.abs() >= MIN_SPEED_DEG_S);
        if !moving || !actual.is_finite() {
            return;
        }
        if self
            .last_tau
            .is_some_and(|last| (tau - last).abs() < MIN_OBSERVATION_INTERVAL_S)
        {
            return;
        }
        // The grid's times increase: each sample starts its segment search where the previous
        // one ended (two walks, one per cost).
        let (mut hint_p, mut hint_a) = (0usize, 0usize);
        let cost = |t: f64, hint: &mut usize| {
            let q = trajectory.position_near(t, hint);
            (0..JOINT_COUNT)
                .map(|j| (q[j] - actual[j]).powi(2))
                .sum::<f64>()
        };
        let forget = self
            .last_tau
            .map_or(1.0, |last| (-(tau - last).abs() / MEMORY_S).exp());
        self.last_tau = Some(tau);
        for (k, (p, a)) in self
            .pipeline
            .iter_mut()
            .zip(self.apparent.iter_mut())
            .enumerate()
        {
            let shift = GRID_MIN_S + k as f64 * GRID_STEP_S;
            *p = *p * forget + cost(tau + lead_then_s - shift, &mut hint_p);
            *a += cost(tau - shift, &mut hint_a);
        }
        self.observations += 1;
        if let LagCompensation::Online { max } = self.mode {
            if self.observations >= WARMUP {
                let max_s = max.as_secs_f64().min(LagCompensation::LIMIT.as_secs_f64());
                self.lead_s = argmin(&self.pipeline).clamp(0.0, max_s);
            }
        }
    }

    /// The time shift that best aligns the arm with the trajectory over the whole stream,
    /// seconds (`None` before any observation while moving).
    pub(crate) fn apparent_lag_s(&self) -> Option<f64> {
        (self.observations > 0).then(|| argmin(&self.apparent))
    }
}

/// The grid point of least cost, refined by a parabola through its neighbours.
fn argmin(costs: &[f64]) -> f64 {
    let k = costs
        .iter()
        .enumerate()
        .min_by(|a, b| a.1.total_cmp(b.1))
        .map_or(0, |(k, _)| k);
    let mut x = k as f64;
    if k > 0 && k + 1 < costs.len() {
        let (a, b, c) = (costs[k - 1], costs[k], costs[k + 1]);
        let d = a - 2.0 * b + c;
        if d > 0.0 {
            x += (0.5 * (a - c) / d).clamp(-0.5, 0.5);
        }
    }
    GRID_MIN_S + x * GRID_STEP_S
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::trajectory::TrajectoryPoint;

    fn ramp() -> Trajectory {
        // JT1 at 20 deg/s for 4 s.
        let points = (0..=40)
            .map(|k| {
                let t = k as f64 * 0.1;
                let mut p = TrajectoryPoint::new(
                    t,
                    JointsDeg::new([20.0 * t, 0.0, -90.0, 0.0, -90.0, 0.0]),
                );
                p.velocity = Some(JointsDeg::new([20.0, 0.0, 0.0, 0.0, 0.0, 0.0]));
                p
            })
            .collect();
        Trajectory::new(points).unwrap()
    }

    #[test]
    fn finds_a_constant_lag_and_leads_by_it() {
        let traj = ramp();
        let mut est = LagEstimator::new(LagCompensation::default());
        let pipeline = 0.12;
        for k in 0..150 {
            let tau = 0.5 + k as f64 * 0.02;
            let lead = est.lead_s();
            // the arm follows the commanded path (the trajectory `lead` ahead) `pipeline` late
            let actual = traj.sample(tau + lead - pipeline).position;
            est.observe(&traj, tau, &actual, lead);
        }
        assert!((est.lead_s() - pipeline).abs() < 0.004, "{}", est.lead_s());
    }

    #[test]
    fn an_online_lead_starts_at_its_prior_and_the_estimate_takes_over_after_the_warm_up() {
        let traj = ramp();
        let mut est = LagEstimator::starting_at(LagCompensation::default(), 0.05);
        assert_eq!(est.lead_s(), 0.05);
        let pipeline = 0.07;
        for k in 0..150 {
            if k == WARMUP - 1 {
                assert_eq!(est.lead_s(), 0.05, "unchanged during the warm-up");
            }
            let tau = 0.5 + f64::from(k) * 0.02;
            let lead = est.lead_s();
            est.observe(
                &traj,
                tau,
                &traj.sample(tau + lead - pipeline).position,
                lead,
            );
        }
        assert!((est.lead_s() - pipeline).abs() < 0.004, "{}", est.lead_s());
        // bounded by the online maximum; a fixed lead or none ignores the prior
        let capped = LagCompensation::Online {
            max: Duration::from_millis(30),
        };
        assert_eq!(LagEstimator::starting_at(capped, 0.05).lead_s(), 0.03);
        let fixed = LagCompensation::Fixed(Duration::from_millis(20));
        assert_eq!(LagEstimator::starting_at(fixed, 0.05).lead_s(), 0.02);
        assert_eq!(
            LagEstimator::starting_at(LagCompensation::Off, 0.05).lead_s(),
            0.0
        );
    }

    #[test]
    fn replies_closer_than_the_observation_interval_are_skipped() {
        let traj = ramp();
        let mut fast = LagEstimator::new(LagCompensation::default());
        let mut slow = LagEstimator::new(LagCompensation::default());
        for k in 0..600 {
            // 250 Hz replies; the slow estimator gets every other one (125 Hz).
            let tau = 0.5 + k as f64 * 0.004;
            let actual = traj.sample(tau - 0.1).position;
            fast.observe(&traj, tau, &actual, 0.0);
            if k % 2 == 0 {
                slow.observe(&traj, tau, &actual, 0.0);
            }
        }
        assert_eq!(fast.observations, slow.observations);
        assert!((fast.apparent_lag_s().unwrap() - 0.1).abs() < 0.003);
    }

    #[test]
    fn the_apparent_lag_is_measured_against_the_trajectory() {
        let traj = ramp();
        let mut est = LagEstimator::new(LagCompensation::Off);
        for k in 0..100 {
            let tau = 0.5 + k as f64 * 0.02;
            let actual = traj.sample(tau - 0.2).position;
            est.observe(&traj, tau, &actual, 0.0);
        }
        assert_eq!(est.lead_s(), 0.0, "Off never leads");
        assert!((est.apparent_lag_s().unwrap() - 0.2).abs() < 0.003);
    }

    #[test]
    fn the_lead_is_bounded_and_a_still_trajectory_is_not_observed() {
        let traj = ramp();
        let mut est = LagEstimator::new(LagCompensation::Online {
            max: Duration::from_millis(100),
        });
        for k in 0..100 {
            let tau = 0.5 + k as f64 * 0.02;
            let actual = traj.sample(tau + est.lead_s() - 0.4).position;
            let lead = est.lead_s();
            est.observe(&traj, tau, &actual, lead);
        }
        assert!((est.lead_s() - 0.1).abs() < 1e-12);
        // an arm ahead of the trajectory shows a negative lag
        let mut ahead = LagEstimator::new(LagCompensation::Off);
        for k in 0..50 {
            let tau = 0.5 + k as f64 * 0.02;
            ahead.observe(&traj, tau, &traj.sample(tau + 0.05).position, 0.0);
        }
        assert!((ahead.apparent_lag_s().unwrap() + 0.05).abs() < 0.003);
        let mut still = LagEstimator::new(LagCompensation::default());
        still.observe(&traj, 10.0, &traj.last(), 0.0);
        assert_eq!(still.apparent_lag_s(), None);
        assert!(LagCompensation::Fixed(Duration::from_millis(600))
            .validate()
            .is_err());
        assert!(LagCompensation::default().validate().is_ok());
    }
}
