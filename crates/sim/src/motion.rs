//! The robot's motion: segments in progress, one planned motion, braking, HOLD, limits.
//!
//! Motions blend by superposition: each segment contributes its displacement (from the target of
//! the motion before it to its own target) as a function of time, so a motion that starts while
//! the previous one is still decelerating (continuous-path blending within ACCURACY) adds its
//! acceleration to the other's deceleration, without a velocity jump. The commanded position is
//! then limited to each joint's maximum speed and clamped into the joint ranges, so the robot can
//! never leave its ranges or exceed its speeds, whatever the sum does.

use std::cell::Cell;
use std::collections::VecDeque;

use fs020n_kin::{ArcError, CircularArc, FlangeNear, JointMove, Pose, RobotModel};
use fs020n_proto::{JointsDeg, JOINT_COUNT};
use smallvec::SmallVec;

/// A straight-line (LMOVE) tool path, pre-sampled through inverse kinematics.
///
/// Sampling is adaptive: the line is first cut every [`LINEAR_SAMPLE_MM`] of tool travel and
/// every [`LINEAR_SAMPLE_DEG`] of tool rotation, then any piece across which a joint turns more
/// than [`LINEAR_MAX_JOINT_STEP_DEG`] is halved (through IK) until it does not. Between samples
/// the joints are interpolated linearly, which keeps the tool within a few micrometres of the
/// line for such short pieces; far from singularities a 0.1 s stream segment needs only a few
/// IK solutions (the emulator's hot path), near them the sampling densifies by itself.
#[derive(Debug, Clone)]
pub struct LinearPath {
    /// Path parameters (0 = start, 1 = target), increasing. Held inline for a one-piece
    /// line (a stream's lines mostly are): no allocation.
    params: SmallVec<[f64; 2]>,
    /// Joint configurations at `params`, first = start, last = target.
    samples: SmallVec<[JointsDeg; 2]>,
    duration_s: f64,
    /// The flange pose at the target (computed for planning; the robot reuses it as its
    /// target's pose when the motion starts).
    end_pose: Pose,
}

/// Longest tool travel between two IK samples of a straight line, millimetres.
pub const LINEAR_SAMPLE_MM: f64 = 5.0;
/// Largest tool rotation between two IK samples of a straight line, degrees.
pub const LINEAR_SAMPLE_DEG: f64 = 2.0;
/// Largest joint step between two IK samples of a straight line, degrees (finer pieces are
/// halved).
pub const LINEAR_MAX_JOINT_STEP_DEG: f64 = 2.0;
/// A joint step that does not shrink when a piece is halved many times is a configuration
/// flip (no continuous IK path): above this many degrees the line is refused.
const FLIP_DEG: f64 = 30.0;
/// Most halvings of one piece.
const MAX_HALVINGS: u32 = 12;
/// Most samples of one path.
const MAX_SAMPLES: usize = 20_000;

/// `cos(0.995 · LINEAR_SAMPLE_DEG / 2)`, the cosine of half of a little less than the sampling
/// angle: two unit quaternions whose dot product is at least this (in absolute value) differ
/// by a rotation of less than [`LINEAR_SAMPLE_DEG`], by a margin (≈ 1.5e-6) far beyond the
/// rounding of either computation (≈ 1e-16). Checked against the formula by a test.
const COS_HALF_SAMPLE_ANGLE: f64 = 0.999_849_214_359_025_2;

impl LinearPath {
    /// Plans a straight tool line from `from` to `to` (joint configurations), taking at least
    /// `duration_s`, stretched when a joint would exceed its maximum speed. Fails when a point of
    /// the line has no inverse-kinematics solution inside the joint ranges near the previous one
    /// (the line crosses a singularity, leaves the workspace or the ranges).
    ///
    /// `_resolution_s` (the controller tick) is kept for compatibility; the sampling no longer
    /// depends on time (the profile is evaluated exactly, only the geometry is sampled).
    pub fn plan(
        model: &RobotModel,
        from: JointsDeg,
        to: JointsDeg,
        duration_s: f64,
        _resolution_s: f64,
    ) -> Option<LinearPath> {
        LinearPath::plan_from_pose(model, from, model.forward(&from.to_rad()), to, duration_s)
    }

    /// [`LinearPath::plan`] with the flange pose at `from` already known (`from_pose` must be
    /// `model.forward(from)`).
    pub(crate) fn plan_from_pose(
        model: &RobotModel,
        from: JointsDeg,
        from_pose: Pose,
        to: JointsDeg,
        duration_s: f64,
    ) -> Option<LinearPath> {
        let p0 = from_pose;
        let p1 = model.forward(&to.to_rad());
        let distance_mm = p0.distance_m(&p1) * 1000.0;
        let (pos0, pos1) = (p0.position_m(), p1.position_m());
        let (rot0, rot1) = (p0.rotation(), p1.rotation());
        // The rotation's pieces: none to add when it turns by less than one sampling angle,
        // which the quaternions' dot product (the cosine of half the angle) shows without
        // the angle's `atan2`.
        let angle_pieces = if rot0.coords.dot(&rot1.coords).abs() >= COS_HALF_SAMPLE_ANGLE {
            1
        } else {
            let angle_deg = p0.angle_to_rad(&p1).to_degrees();
            (angle_deg / LINEAR_SAMPLE_DEG).ceil() as usize
        };
        let n = ((distance_mm / LINEAR_SAMPLE_MM).ceil() as usize)
            .max(angle_pieces)
            .clamp(1, MAX_SAMPLES);
        let (params, samples) = sample_tool_path(model, from, to, n, |s| {
            Pose::new(pos0.lerp(&pos1, s), rot0.slerp(&rot1, s))
        })?;
        let needed = stretched_duration(model, &params, &samples, duration_s);
        Some(LinearPath {
            params,
            samples,
            duration_s: needed,
            end_pose: p1,
        })
    }

    /// Duration, seconds.
    pub fn duration_s(&self) -> f64 {
        self.duration_s
    }

    /// Number of IK samples along the line (start and target included).
    pub fn sample_count(&self) -> usize {
        self.samples.len()
    }

    /// Adds the displacement from the start at `t` seconds after the start (the joints as
    /// `position_at` computes them, minus the start) to `q`, with the evaluation state of the
    /// previous tick: the piece is found from the previous one (the path parameter only grows
    /// while the segment runs), the cycloid's sine is advanced from the previous tick's (see
    /// [`Tracker`]) and each piece's rate is computed once, when it is entered. The result differs from
    /// `position_at`'s by rounding only (≪ 1e-9°). The robot's tick does the same in two
    /// parts (`Tracker::add_in_piece`, then `add_displacement_new_piece`), reading only the
    /// segment's own state in the common case.
    #[cfg(test)]
    fn add_displacement(&self, t: f64, tr: &mut Tracker, q: &mut JointsDeg) {
        if !tr.add_in_piece(t, self.duration_s, q) {
            self.add_displacement_new_piece(tr.last_s, tr, q);
        }
    }

    /// The tick's evaluation of a segment (`add_displacement`) at path parameter `s` outside the
    /// tracker's piece: finds the piece, keeps its rise and rate in the tracker, adds the
    /// displacement to `q`.
    #[inline(never)]
    fn add_displacement_new_piece(&self, s: f64, tr: &mut Tracker, q: &mut JointsDeg) {
        let last = self.samples.len() - 1;
        if s >= 1.0 || last == 0 {
            let d = self.rise(last);
            for j in 0..JOINT_COUNT {
                q[j] += d[j];
            }
            return;
        }
        // The piece [params[k], params[k+1]] holding s: the last k with params[k] <= s (or 0),
        // at most last − 1 — the same piece as the binary search of `position_at`.
        let params = &self.params;
        let mut k = tr.piece.min(last - 1);
        while k + 1 < last && params[k + 1] <= s {
            k += 1;
        }
        while k > 0 && params[k] > s {
            k -= 1;
        }
        tr.piece = k;
        (tr.piece_from, tr.piece_to) = (params[k], params[k + 1]);
        tr.rise = self.rise(k);
        // The joints' rate along the piece, degrees per unit of path parameter.
        let ds = params[k + 1] - params[k];
        tr.slope = if ds > 0.0 {
            self.samples[k + 1].zip_with(&self.samples[k], |b, a| (b - a) / ds)
        } else {
            JointsDeg::ZERO
        };
        let x = (s - tr.piece_from).max(0.0);
        for j in 0..JOINT_COUNT {
            q[j] += tr.rise[j] + tr.slope[j] * x;
        }
    }

    /// `samples[k] − samples[0]`: the displacement at the start of piece `k`.
    fn rise(&self, k: usize) -> JointsDeg {
        self.samples[k].zip_with(&self.samples[0], |a, b| a - b)
    }

    fn position_at(&self, t: f64) -> JointsDeg {
        sampled_position(&self.params, &self.samples, self.duration_s, t)
    }
}

/// The joints of a sampled path (`params`, `samples`) `t` seconds after its start, on the
/// cycloidal profile of `duration_s`: zero speed and acceleration at both ends; between
/// samples the joints are interpolated linearly.
fn sampled_position(params: &[f64], samples: &[JointsDeg], duration_s: f64, t: f64) -> JointsDeg {
    let u = (t / duration_s).clamp(0.0, 1.0);
    let s = u - (2.0 * std::f64::consts::PI * u).sin() / (2.0 * std::f64::consts::PI);
    let last = samples.len() - 1;
    if s >= 1.0 || last == 0 {
        return samples[last];
    }
    // The piece [params[k], params[k+1]] holding s.
    let k = params
        .partition_point(|&p| p <= s)
        .saturating_sub(1)
        .min(last - 1);
    let (a, b) = (params[k], params[k + 1]);
    let f = if b > a {
        ((s - a) / (b - a)).clamp(0.0, 1.0)
    } else {
        1.0
    };
    samples[k].zip_with(&samples[k + 1], |x, y| x + (y - x) * f)
}

/// Longest sweep of a circular path between two IK samples, degrees (with
/// [`LINEAR_SAMPLE_MM`] along it: the chord of a piece leaves the circle by at most 0.06 mm).
pub const CIRCULAR_SAMPLE_DEG: f64 = 5.0;

/// Why a circular path cannot be planned.
#[derive(Debug, Clone, Copy, PartialEq, thiserror::Error)]
pub enum CircularPlanError {
    /// The three points define no circle.
    #[error(transparent)]
    NoCircle(#[from] ArcError),
    /// A point of the circle has no inverse-kinematics solution inside the joint ranges near
    /// the previous one (it leaves the workspace, crosses a singularity or flips configuration).
    #[error("the circle leaves the reachable workspace or crosses a singularity")]
    Unreachable,
}

/// A circular (C1MOVE/C2MOVE) tool path: the flange on the circle through the start, the via
/// point and the target ([`CircularArc`]), pre-sampled through inverse kinematics as a
/// [`LinearPath`] is, on the same cycloidal profile.
#[derive(Debug, Clone)]
pub struct CircularPath {
    params: PathParams,
    samples: PathSamples,
    duration_s: f64,
    arc: CircularArc,
    end_pose: Pose,
}

impl CircularPath {
    /// The circle from the flange at `from` through `via` to the flange at `to`, the path
    /// parameter proportional to the length along it. `duration_of` gives the duration asked
    /// for the circle's length in millimetres (the length at the tool speed); it is stretched
    /// when a joint would exceed its maximum speed.
    pub fn plan(
        model: &RobotModel,
        from: JointsDeg,
        via: &Pose,
        to: JointsDeg,
        duration_of: impl FnOnce(f64) -> f64,
    ) -> Result<CircularPath, CircularPlanError> {
        let p0 = model.forward(&from.to_rad());
        let p2 = model.forward(&to.to_rad());
        let arc = CircularArc::through(&p0, via, &p2)?;
        let duration_s = duration_of(arc.length_m() * 1000.0);
        let pieces = |x: f64, per: f64| (x / per).ceil() as usize;
        let n = pieces(arc.length_m() * 1000.0, LINEAR_SAMPLE_MM)
            .max(pieces(arc.sweep_rad().to_degrees(), CIRCULAR_SAMPLE_DEG))
            .max(pieces(arc.rotation_rad().to_degrees(), LINEAR_SAMPLE_DEG))
            .clamp(2, MAX_SAMPLES);
        let (params, samples) = sample_tool_path(model, from, to, n, |s| arc.pose_at(s))
            .ok_or(CircularPlanError::Unreachable)?;
        let needed = stretched_duration(model, &params, &samples, duration_s);
        Ok(CircularPath {
            params,
            samples,
            duration_s: needed,
            arc,
            end_pose: p2,
        })
    }

    /// Duration, seconds.
    pub fn duration_s(&self) -> f64 {
        self.duration_s
    }

    /// The circle.
    pub fn arc(&self) -> &CircularArc {
        &self.arc
    }

    /// Number of IK samples along the circle (start and target included).
    pub fn sample_count(&self) -> usize {
        self.samples.len()
    }

    fn position_at(&self, t: f64) -> JointsDeg {
        sampled_position(&self.params, &self.samples, self.duration_s, t)
    }
}

/// A hybrid (HMOVE) path: the wrist centre on the straight line from where it is at the start
/// to where it is at the target, the wrist joints JT4–JT6 turning linearly (as in a joint
/// move); JT1–JT3 are solved for the wrist centre near the previous sample. Sampled and
/// timed as a [`LinearPath`] is.
#[derive(Debug, Clone)]
pub struct HybridPath {
    params: PathParams,
    samples: PathSamples,
    duration_s: f64,
    end_pose: Pose,
}

impl HybridPath {
    /// Plans the hybrid path from `from` to `to`. `duration_of` gives the duration asked for
    /// the wrist centre's travel in millimetres (the length at the tool speed); it is
    /// stretched when a joint would exceed its maximum speed. `None` when a point of the line
    /// has no solution near the previous one (out of reach, a singularity, a configuration
    /// flip).
    pub fn plan(
        model: &RobotModel,
        from: JointsDeg,
        to: JointsDeg,
        duration_of: impl FnOnce(f64) -> f64,
    ) -> Option<HybridPath> {
        let (w0, w1) = (
            model.wrist_centre_m(&from.to_rad()),
            model.wrist_centre_m(&to.to_rad()),
        );
        let length_mm = (w1 - w0).norm() * 1000.0;
        let wrist_turn_deg = (3..JOINT_COUNT)
            .map(|j| (to[j] - from[j]).abs())
            .fold(0.0, f64::max);
        let n = ((length_mm / LINEAR_SAMPLE_MM).ceil() as usize)
            .max((wrist_turn_deg / LINEAR_MAX_JOINT_STEP_DEG).ceil() as usize)
            .clamp(1, MAX_SAMPLES);
        let solve = |s: f64, seed: &JointsDeg| -> Option<JointsDeg> {
            if s >= 1.0 {
                return Some(to);
            }
            let mut guess = *seed;
            for j in 3..JOINT_COUNT {
                guess[j] = from[j] + (to[j] - from[j]) * s;
            }
            let g = guess.to_rad();
            // A flange pose whose wrist centre is on the line (its orientation the guess's:
            // the wrist centre depends on JT1–JT3 alone, which the solution gives).
            let flange = model.forward(&g);
            let offset = flange.position_m() - model.wrist_centre_m(&g);
            let pose = Pose::new(w0.lerp(&w1, s) + offset, flange.rotation());
            let mut q = model.inverse_nearest(&pose, &g).ok()?.to_deg();
            for j in 3..JOINT_COUNT {
                q[j] = guess[j];
            }
            Some(q)
        };
        let (params, samples) = sample_joint_path(from, n, solve)?;
        let needed = stretched_duration(model, &params, &samples, duration_of(length_mm));
        Some(HybridPath {
            params,
            samples,
            duration_s: needed,
            end_pose: model.forward(&to.to_rad()),
        })
    }

    /// Duration, seconds.
    pub fn duration_s(&self) -> f64 {
        self.duration_s
    }

    /// Number of samples along the path (start and target included).
    pub fn sample_count(&self) -> usize {
        self.samples.len()
    }

    fn position_at(&self, t: f64) -> JointsDeg {
        sampled_position(&self.params, &self.samples, self.duration_s, t)
    }
}

/// The path parameters of a sampled tool path (inline for a one-piece line: no allocation).
type PathParams = SmallVec<[f64; 2]>;
/// The joint configurations at a sampled tool path's parameters.
type PathSamples = SmallVec<[JointsDeg; 2]>;

/// Samples a tool path through inverse kinematics: `pose_at(s)` is the flange at path
/// parameter `s` (0 = at `from`, 1 = at `to`), solved near the previous sample (see
/// [`sample_joint_path`]).
fn sample_tool_path(
    model: &RobotModel,
    from: JointsDeg,
    to: JointsDeg,
    n: usize,
    pose_at: impl Fn(f64) -> Pose,
) -> Option<(PathParams, PathSamples)> {
    let solve = |s: f64, seed: &JointsDeg| -> Option<JointsDeg> {
        if s >= 1.0 {
            return Some(to);
        }
        model
            .inverse_nearest(&pose_at(s), &seed.to_rad())
            .ok()
            .map(|q| q.to_deg())
    };
    sample_joint_path(from, n, solve)
}

/// Samples a path given by `solve(s, seed)` (the joints at path parameter `s`, found near
/// `seed`; `s` = 1 gives the target): first cut into `n` equal pieces, then each piece
/// across which a joint turns more than [`LINEAR_MAX_JOINT_STEP_DEG`] halved until it does not
/// (see [`LinearPath`]). `None` when a point has no solution near the previous one, or the
/// path flips configuration.
fn sample_joint_path(
    from: JointsDeg,
    n: usize,
    solve: impl Fn(f64, &JointsDeg) -> Option<JointsDeg>,
) -> Option<(PathParams, PathSamples)> {
    let mut params = PathParams::with_capacity(n + 1);
    let mut samples = PathSamples::with_capacity(n + 1);
    params.push(0.0);
    samples.push(from);
    // The pieces waiting to be refined: one per halving level at most, and the top.
    let mut stack = [(0.0, JointsDeg::ZERO, 0u32); MAX_HALVINGS as usize + 2];
    for k in 1..=n {
        let s1 = k as f64 / n as f64;
        let q1 = solve(s1, samples.last()?)?;
        // Refine the piece (s0, s1] by halving until no joint steps more than the limit.
        stack[0] = (s1, q1, 0u32);
        let mut pending = 1;
        while pending > 0 {
            pending -= 1;
            let (sb, qb, depth) = stack[pending];
            let sa = *params.last()?;
            let qa = *samples.last()?;
            let step = qb.max_abs_diff(&qa);
            if step <= LINEAR_MAX_JOINT_STEP_DEG || depth >= MAX_HALVINGS {
                if step > FLIP_DEG {
                    return None;
                }
                params.push(sb);
                samples.push(qb);
                if samples.len() > MAX_SAMPLES {
                    return None;
                }
            } else {
                let sm = 0.5 * (sa + sb);
                let qm = solve(sm, &qa)?;
                stack[pending] = (sb, qb, depth + 1);
                stack[pending + 1] = (sm, qm, depth + 1);
                pending += 2;
            }
        }
    }
    Some((params, samples))
}

/// The duration of a sampled path: at least `duration_s`, stretched so that no joint exceeds
/// its maximum speed.
fn stretched_duration(
    model: &RobotModel,
    params: &[f64],
    samples: &[JointsDeg],
    duration_s: f64,
) -> f64 {
    // The cycloidal profile peaks at twice the mean rate: a piece of Δs along which joint j
    // turns d needs T ≥ 2 d / (Δs · v_max).
    let mut needed = duration_s;
    let speeds = model.max_speeds_deg_s();
    for (w, ds) in samples.windows(2).zip(params.windows(2)) {
        let ds = ds[1] - ds[0];
        if ds <= 0.0 {
            continue;
        }
        for (j, speed) in speeds.iter().enumerate() {
            let d = (w[1][j] - w[0][j]).abs();
            needed = needed.max(2.0 * d / (ds * speed));
        }
    }
    needed
}

/// The shape of one motion.
#[derive(Debug, Clone)]
pub enum Shape {
    /// Joint-interpolated (JMOVE).
    Joint(JointMove),
    /// Straight tool line (LMOVE).
    Linear(LinearPath),
    /// Circular tool path (C1MOVE/C2MOVE).
    Circular(CircularPath),
    /// Wrist centre on a line, wrist joints interpolated (HMOVE).
    Hybrid(HybridPath),
}

impl Shape {
    fn duration_s(&self) -> f64 {
        match self {
            Shape::Joint(m) => m.duration_s(),
            Shape::Linear(l) => l.duration_s(),
            Shape::Circular(c) => c.duration_s(),
            Shape::Hybrid(h) => h.duration_s(),
        }
    }
}

/// Evaluations between two exact `sin_cos` of a [`Tracker`]: the rotation's rounding errors
/// (a few units in the last place per step) stay below 1e-13 in the sine.
const TRACKER_RESEED: u32 = 64;
/// Largest difference (radians) between an angle and the tracked one that a [`Tracker`]
/// corrects to first order (the error, half its square, stays below 1e-18); beyond it (an
/// irregular step: the HOLD ramp) the sine is computed exactly.
const TRACKER_TOLERANCE: f64 = 1e-9;

/// The evaluation state of a segment in progress, carried from tick to tick: the piece of a
/// linear path the previous evaluation fell in, and the cycloid's sine and cosine advanced by
/// a fixed step.
///
/// Ticks are regular, so the cycloid's angle grows by the same step `h` from tick to tick (up
/// to rounding). The tracker keeps `sin` and `cos` of `seed + n·h` and rotates them by `h`
/// (`sin(a + h) = sin a cos h + cos a sin h`), then corrects for the angle's actual value
/// (`sin(a + e) ≈ sin a + e cos a`, `e` a few units in the last place). It computes `sin_cos`
/// exactly at the first two evaluations (the seed and the step), every
/// [`TRACKER_RESEED`] evaluations, and whenever a step is irregular.
#[derive(Debug, Clone, Copy, Default)]
struct Tracker {
    /// The piece of the previous evaluation, and its parameter range (empty: none yet).
    piece: usize,
    piece_from: f64,
    piece_to: f64,
    /// The piece's displacement at its start and its rate (computed when the piece is entered).
    rise: JointsDeg,
    slope: JointsDeg,
    /// The path parameter of the last evaluation that left the piece.
    last_s: f64,
    /// An exact `sin_cos` has been computed (`seed`, `sin`, `cos` are valid).
    seeded: bool,
    /// The step `h` is known (`sin_h`, `cos_h` valid).
    stepping: bool,
    seed: f64,
    h: f64,
    sin_h: f64,
    cos_h: f64,
    /// Steps since the seed; `sin` and `cos` are those of `seed + n·h`.
    n: u32,
    sin: f64,
    cos: f64,
}

impl Tracker {
    /// The common case of the tick's evaluation of a linear segment (`add_displacement`) of
    /// `duration_s`: when the path parameter at `t` is still in the previous evaluation's
    /// piece, adds the displacement to `q` and returns `true`; otherwise returns `false` with
    /// the parameter in `last_s` (the caller goes on with `add_displacement_new_piece`).
    #[inline(always)]
    fn add_in_piece(&mut self, t: f64, duration_s: f64, q: &mut JointsDeg) -> bool {
        let u = (t / duration_s).clamp(0.0, 1.0);
        let s = u - self.sin(2.0 * std::f64::consts::PI * u) / (2.0 * std::f64::consts::PI);
        if self.piece_from <= s && s < self.piece_to {
            let x = s - self.piece_from;
            for j in 0..JOINT_COUNT {
                q[j] += self.rise[j] + self.slope[j] * x;
            }
            true
        } else {
            self.last_s = s;
            false
        }
    }

    /// `sin(angle)`, within 1e-13 (see [`Tracker`]).
    fn sin(&mut self, angle: f64) -> f64 {
        self.sin_cos(angle).0
    }

    /// `sin(angle)` and `cos(angle)`, within 1e-13 (see [`Tracker`]).
    #[inline(always)]
    fn sin_cos(&mut self, angle: f64) -> (f64, f64) {
        if self.stepping && self.n < TRACKER_RESEED {
            let e = angle - (self.seed + f64::from(self.n + 1) * self.h);
            if e.abs() <= TRACKER_TOLERANCE {
                return self.step(e);
            }
        }
        self.sin_cos_slow(angle)
    }

    /// One step of the rotation: the next tick's sine and cosine, corrected to first order by
    /// `e`, the actual angle's difference from the stepped one.
    #[inline(always)]
    fn step(&mut self, e: f64) -> (f64, f64) {
        let (s, c) = (
            self.sin * self.cos_h + self.cos * self.sin_h,
            self.cos * self.cos_h - self.sin * self.sin_h,
        );
        self.sin = s;
        self.cos = c;
        self.n += 1;
        (s + c * e, c - s * e)
    }

    /// [`Tracker::sin_cos`] when the fast path does not apply: learn the step, or compute
    /// exactly.
    #[inline(never)]
    fn sin_cos_slow(&mut self, angle: f64) -> (f64, f64) {
        if self.seeded && self.n < TRACKER_RESEED {
            if !self.stepping {
                let h = angle - self.seed;
                if h.is_finite() {
                    (self.sin_h, self.cos_h) = h.sin_cos();
                    self.h = h;
                    self.stepping = true;
                }
            }
            if self.stepping {
                let e = angle - (self.seed + f64::from(self.n + 1) * self.h);
                if e.abs() <= TRACKER_TOLERANCE {
                    return self.step(e);
                }
                // An irregular step: learn the step again.
                self.stepping = false;
            }
        }
        (self.sin, self.cos) = angle.sin_cos();
        self.seed = angle;
        self.seeded = true;
        self.n = 0;
        (self.sin, self.cos)
    }
}

/// A motion: where it starts (the previous motion's target), where it ends, and its shape.
#[derive(Debug, Clone)]
pub struct Motion {
    /// Start configuration (the target of the motion before it).
    pub from: JointsDeg,
    /// Target configuration.
    pub to: JointsDeg,
    /// Joint or linear.
    pub shape: Shape,
}

#[derive(Debug, Clone)]
struct Active {
    motion: Motion,
    /// Motion-clock time at which it started.
    started: f64,
    /// The shape's duration, seconds.
    duration_s: f64,
    /// A linear shape starts at `motion.from` (as planned): its displacement is evaluated
    /// piece by piece (see [`Tracker`]).
    from_start: bool,
    tracker: Tracker,
    /// Evaluated in the robot's [`Cycloids`] sum (a one-piece line of its duration), with
    /// `cos φ`, `sin φ` of its phase against the sum's epoch.
    in_sum: Option<(f64, f64)>,
}

/// Joins and leaves after which a [`Cycloids`] sum's coefficients are recomputed from its
/// members.
const CYCLOIDS_RECOMPUTE: u32 = 64;

/// Epochs of a [`Cycloids`] sum older than this (seconds of motion clock) are moved to the
/// present, so that its times and angles stay small numbers.
const CYCLOIDS_REBASE_S: f64 = 100.0;

/// The displacement of one-piece straight lines of the same duration `T`, in closed form.
///
/// Such a line moves by `Δ·s(u)`, `s(u) = u − sin(2πu)/2π`, `u = (t − t_i)/T`. With
/// `τ = t − E` (an epoch) and `φ_i = ω (t_i − E)`, `ω = 2π/T`, the sum over the lines is
/// `c0 + a·τ − (sin ωτ · cs − cos ωτ · sn)/2π` with `a = ΣΔ_i/T`, `c0 = −ΣΔ_i (t_i − E)/T`,
/// `cs = ΣΔ_i cos φ_i`, `sn = ΣΔ_i sin φ_i`: one `sin_cos` of the tick (advanced from the
/// previous tick's by a [`Tracker`]) however many lines overlap. A line's terms are added when
/// it starts and subtracted when it ends; every [`CYCLOIDS_RECOMPUTE`] of these and at a new
/// epoch the coefficients are recomputed from the members (no drift). The sum equals the
/// lines' separate evaluation up to rounding.
#[derive(Debug, Clone)]
struct Cycloids {
    duration_s: f64,
    omega: f64,
    epoch: f64,
    members: usize,
    /// The coefficients need recomputing from the members (a new epoch, or many joins and
    /// leaves added and subtracted since the last time: their rounding is not left to add up).
    dirty: bool,
    /// Joins and leaves since the coefficients were last recomputed.
    changes: u32,
    c0: JointsDeg,
    a: JointsDeg,
    cs: JointsDeg,
    sn: JointsDeg,
    /// `sin ωτ`, `cos ωτ` from tick to tick.
    tracker: Tracker,
}

impl Cycloids {
    fn new(duration_s: f64, epoch: f64) -> Cycloids {
        Cycloids {
            duration_s,
            omega: 2.0 * std::f64::consts::PI / duration_s,
            epoch,
            members: 0,
            dirty: true,
            changes: 0,
            c0: JointsDeg::ZERO,
            a: JointsDeg::ZERO,
            cs: JointsDeg::ZERO,
            sn: JointsDeg::ZERO,
            tracker: Tracker::default(),
        }
    }

    /// `cos φ`, `sin φ` of a line started at `started`.
    fn phase(&self, started: f64) -> (f64, f64) {
        let (s, c) = (self.omega * (started - self.epoch)).sin_cos();
        (c, s)
    }

    /// Adds (`sign` 1) or removes (`sign` −1) a member's terms.
    fn account(&mut self, m: &Active, sign: f64) {
        let Some((cos_phi, sin_phi)) = m.in_sum else {
            return;
        };
        let lag = (m.started - self.epoch) / self.duration_s;
        for j in 0..JOINT_COUNT {
            let d = sign * (m.motion.to[j] - m.motion.from[j]);
            self.c0[j] -= d * lag;
            self.a[j] += d / self.duration_s;
            self.cs[j] += d * cos_phi;
            self.sn[j] += d * sin_phi;
        }
        self.changes += 1;
        if self.changes >= CYCLOIDS_RECOMPUTE {
            self.dirty = true;
        }
    }

    fn rebuild<'a>(&mut self, members: impl Iterator<Item = &'a Active>) {
        (self.c0, self.a, self.cs, self.sn) = (
            JointsDeg::ZERO,
            JointsDeg::ZERO,
            JointsDeg::ZERO,
            JointsDeg::ZERO,
        );
        for m in members {
            self.account(m, 1.0);
        }
        self.dirty = false;
        self.changes = 0;
    }

    /// Adds the members' displacement at motion-clock time `clock` to `q`.
    fn add(&mut self, clock: f64, q: &mut JointsDeg) {
        let tau = clock - self.epoch;
        let (s, c) = self.tracker.sin_cos(self.omega * tau);
        for j in 0..JOINT_COUNT {
            q[j] += self.c0[j] + self.a[j] * tau
                - (s * self.cs[j] - c * self.sn[j]) / (2.0 * std::f64::consts::PI);
        }
    }
}

/// A stop with each joint decelerating at its maximum acceleration.
#[derive(Debug, Clone)]
struct Brake {
    from: JointsDeg,
    velocity: JointsDeg,
    elapsed: f64,
}

impl Brake {
    /// Position of joint `j` after `t` seconds of braking (constant deceleration at the joint's
    /// maximum acceleration until it stands).
    fn position(&self, model: &RobotModel, t: f64) -> (JointsDeg, bool) {
        let mut q = self.from;
        let mut done = true;
        for (j, spec) in model.joints.iter().enumerate() {
            let v = self.velocity[j];
            let a = spec.max_accel_deg_s2;
            let t_stop = v.abs() / a;
            let t = t.min(t_stop);
            done &= t >= t_stop;
            q[j] = (self.from[j] + v * t - 0.5 * v.signum() * a * t * t)
                .clamp(spec.min_deg, spec.max_deg);
        }
        (q, done)
    }

    fn stop_position(&self, model: &RobotModel) -> JointsDeg {
        self.position(model, f64::INFINITY).0
    }
}

/// What the robot is doing, for observers.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum MotionPhase {
    /// Standing still.
    Idle,
    /// Executing one or more blended motions.
    Moving,
    /// Braking to a stop.
    Braking,
    /// Paused by HOLD in the middle of a motion (resumes on RUN).
    Held,
}

/// The robot arm's motion state, advanced tick by tick.
#[derive(Debug, Clone)]
pub struct Arm {
    joints: JointsDeg,
    velocity: JointsDeg,
    /// Position the finished segments have reached; the in-progress ones add to it.
    anchor: JointsDeg,
    /// Final target of everything in progress.
    target: JointsDeg,
    /// Oldest first (they usually finish in that order).
    active: VecDeque<Active>,
    /// Every segment in `active` lasts at least as long as the one before it: since they
    /// start in order, none ends before the first (the tick then tests only the first).
    ends_in_order: bool,
    planned: Option<Motion>,
    brake: Option<Brake>,
    /// Motion clock: advances with time scaled by the HOLD ramp.
    clock: f64,
    /// 1 = full speed, 0 = held.
    hold_scale: f64,
    held: bool,
    /// The flange pose at `target`, computed once per target (the blending test compares the
    /// tool with it every tick while a motion waits).
    target_pose: Cell<Option<(JointsDeg, Pose)>>,
    /// The flange and its derivatives where the blending test last computed the forward
    /// kinematics: the tests whose outcome a bound decides skip it.
    blend_ref: Option<FlangeNear>,
    /// The one-piece lines in progress of one duration, summed in closed form.
    cycloids: Option<Cycloids>,
}

/// Margin on the distance to the ACCURACY sphere for the rounding of the forward kinematics
/// and of the estimate (≈ 1e-15 m): a nanometre.
const BLEND_MARGIN_M: f64 = 1e-9;

/// Time for HOLD to bring the motion to a pause (and for RUN to resume it), seconds.
pub const HOLD_RAMP_S: f64 = 0.2;

impl Arm {
    /// A robot standing at `joints`.
    pub fn new(joints: JointsDeg) -> Arm {
        Arm {
            joints,
            velocity: JointsDeg::ZERO,
            anchor: joints,
            target: joints,
            active: VecDeque::new(),
            ends_in_order: true,
            planned: None,
            brake: None,
            clock: 0.0,
            hold_scale: 1.0,
            held: false,
            target_pose: Cell::new(None),
            blend_ref: None,
            cycloids: None,
        }
    }

    /// Current joint angles (what the encoders read).
    pub fn joints(&self) -> JointsDeg {
        self.joints
    }

    /// Current joint velocities, deg/s.
    pub fn velocity(&self) -> JointsDeg {
        self.velocity
    }

    /// The final target of the motions in progress (the current joints when idle).
    pub fn target(&self) -> JointsDeg {
        self.target
    }

    /// `true` when a motion waits to blend in.
    pub fn has_planned(&self) -> bool {
        self.planned.is_some()
    }

    /// Number of motions in progress (blending ones included).
    pub fn active_count(&self) -> usize {
        self.active.len()
    }

    /// What the robot is doing.
    pub fn phase(&self) -> MotionPhase {
        if self.brake.is_some() {
            MotionPhase::Braking
        } else if self.active.is_empty() && self.velocity.iter().all(|v| v == 0.0) {
            MotionPhase::Idle
        } else if self.held && self.hold_scale == 0.0 {
            MotionPhase::Held
        } else {
            MotionPhase::Moving
        }
    }

    /// `true` when nothing moves and nothing will without a new command.
    pub fn is_still(&self) -> bool {
        self.phase() == MotionPhase::Idle && self.planned.is_none() && self.hold_scale_settled()
    }

    fn hold_scale_settled(&self) -> bool {
        (self.held && self.hold_scale == 0.0) || (!self.held && self.hold_scale == 1.0)
    }

    /// Sets or releases HOLD: motion decelerates to a pause over [`HOLD_RAMP_S`] and resumes the
    /// same way.
    pub fn set_hold(&mut self, held: bool) {
        self.held = held;
    }

    /// `true` when a new motion may start now: nothing in progress, or the tool is within
    /// `accuracy_mm` of the current target (continuous-path blending).
    pub fn ready_for_next(&mut self, model: &RobotModel, accuracy_mm: f64) -> bool {
        if self.brake.is_some() {
            return false;
        }
        if self.active.is_empty() {
            return true;
        }
        // The flange estimated from the last exact test's derivatives, with a proven error
        // bound (`FlangeNear`): when the sphere is clearly outside or clearly inside that
        // ball, the exact test's outcome is known without the forward kinematics.
        let q = self.joints.to_rad();
        // The cached target pose read in place (`Cell::get` would copy it).
        let there = match self.target_pose.get_mut() {
            Some((joints, pose)) if same_bits(joints, &self.target) => pose.position_m(),
            _ => self.target_pose(model).position_m(),
        };
        let accuracy_m = accuracy_mm / 1000.0;
        if let Some(near) = &self.blend_ref {
            let (estimate, error_m) = near.estimate_m(&q);
            let distance_m = (estimate - there).norm();
            let slack_m = error_m + BLEND_MARGIN_M;
            if distance_m - slack_m > accuracy_m {
                return false;
            }
            if distance_m + slack_m < accuracy_m {
                return true;
            }
        }
        let near = model.flange_near(&q);
        self.blend_ref = Some(near);
        let distance_m = (near.position_m() - there).norm();
        distance_m * 1000.0 <= accuracy_mm
    }

    /// The flange pose at [`target`](Self::target) (`model.forward(target)`), cached.
    pub(crate) fn target_pose(&self, model: &RobotModel) -> Pose {
        if let Some((joints, pose)) = self.target_pose.get() {
            if same_bits(&joints, &self.target) {
                return pose;
            }
        }
        let pose = model.forward(&self.target.to_rad());
        self.target_pose.set(Some((self.target, pose)));
        pose
    }

    /// Starts `motion` at once (its `from` must be [`target`](Self::target)).
    pub fn start(&mut self, motion: Motion) {
        self.target = motion.to;
        match &motion.shape {
            Shape::Linear(path) => self.target_pose.set(Some((motion.to, path.end_pose))),
            Shape::Circular(path) => self.target_pose.set(Some((motion.to, path.end_pose))),
            Shape::Hybrid(path) => self.target_pose.set(Some((motion.to, path.end_pose))),
            Shape::Joint(_) => {}
        }
        self.brake = None;
        let duration_s = motion.shape.duration_s();
        let from_start = match &motion.shape {
            Shape::Linear(l) => same_bits(&l.samples[0], &motion.from),
            Shape::Joint(_) | Shape::Circular(_) | Shape::Hybrid(_) => false,
        };
        // A one-piece line (start and target only) of the sum's duration joins the sum.
        let one_piece = from_start
            && matches!(&motion.shape, Shape::Linear(l) if l.samples.len() == 2)
            && duration_s > 0.0
            && duration_s.is_finite();
        let mut in_sum = None;
        if one_piece {
            let clock = self.clock;
            let sum = self
                .cycloids
                .get_or_insert_with(|| Cycloids::new(duration_s, clock));
            if sum.members == 0 && sum.duration_s.to_bits() != duration_s.to_bits() {
                *sum = Cycloids::new(duration_s, clock);
            }
            if sum.duration_s.to_bits() == duration_s.to_bits() {
                in_sum = Some(sum.phase(clock));
                sum.members += 1;
            }
        }
        // `started` never decreases (the motion clock only advances), so segments of
        // non-decreasing durations end in order.
        self.ends_in_order = match self.active.back() {
            Some(last) => self.ends_in_order && duration_s >= last.duration_s,
            None => true,
        };
        self.active.push_back(Active {
            duration_s,
            from_start,
            motion,
            started: self.clock,
            tracker: Tracker::default(),
            in_sum,
        });
        if let (Some(_), Some(sum), Some(a)) = (in_sum, &mut self.cycloids, self.active.back()) {
            sum.account(a, 1.0);
        }
    }

    /// Queues `motion` to blend in when the tool reaches ACCURACY of the current target.
    pub fn plan(&mut self, motion: Motion) {
        self.planned = Some(motion);
    }

    /// Takes the planned motion if it may start now.
    pub fn take_planned_if_ready(
        &mut self,
        model: &RobotModel,
        accuracy_mm: f64,
    ) -> Option<Motion> {
        if self.planned.is_some() && self.ready_for_next(model, accuracy_mm) {
            self.planned.take()
        } else {
            None
        }
    }

    /// BRAKE: stops the motion in progress with each joint decelerating at its maximum
    /// acceleration, and drops the planned one. Braking again while braking changes nothing.
    pub fn brake(&mut self, model: &RobotModel) {
        self.planned = None;
        self.active.clear();
        self.cycloids = None;
        if self.brake.is_none() && self.velocity.iter().any(|v| v != 0.0) {
            self.brake = Some(Brake {
                from: self.joints,
                velocity: self.velocity,
                elapsed: 0.0,
            });
        }
        // Where the robot comes to rest: the end of the braking curve (inside the ranges). Any
        // motion planned from now on starts there, and the robot settles there.
        let rest = match &self.brake {
            Some(b) => b.stop_position(model),
            None => self.joints,
        };
        self.anchor = rest;
        self.target = rest;
    }

    /// Stops dead (motor power cut): no deceleration.
    pub fn halt(&mut self) {
        self.planned = None;
        self.active.clear();
        self.cycloids = None;
        self.brake = None;
        self.velocity = JointsDeg::ZERO;
        self.anchor = self.joints;
        self.target = self.joints;
    }

    /// Advances by `dt` seconds.
    pub fn tick(&mut self, model: &RobotModel, dt: f64) {
        let prev = self.joints;
        // HOLD ramp.
        let ramp = dt / HOLD_RAMP_S;
        self.hold_scale = if self.held {
            (self.hold_scale - ramp).max(0.0)
        } else {
            (self.hold_scale + ramp).min(1.0)
        };
        let desired = if let Some(b) = &mut self.brake {
            b.elapsed += dt;
            let (q, done) = b.position(model, b.elapsed);
            if done {
                self.brake = None;
                // Exactly the rest position announced by `brake` (no rounding drift).
                self.anchor = self.target;
                self.target
            } else {
                q
            }
        } else {
            self.clock += dt * self.hold_scale;
            let clock = self.clock;
            let anchor = &mut self.anchor;
            let sum = &mut self.cycloids;
            let mut finished = |a: &Active, anchor: &mut JointsDeg| {
                if clock - a.started >= a.duration_s {
                    for j in 0..JOINT_COUNT {
                        anchor[j] += a.motion.to[j] - a.motion.from[j];
                    }
                    if let (Some(_), Some(sum)) = (a.in_sum, sum.as_mut()) {
                        sum.members -= 1;
                        sum.account(a, -1.0);
                    }
                    true
                } else {
                    false
                }
            };
            // Finished segments fold into the anchor, oldest first: those at the front are
            // popped (no move of the others), the rest (rarely any) removed in place. When
            // they end in order (`ends_in_order`: `clock − started` is not larger for a later
            // start, and the duration not smaller), none behind an unfinished first one has
            // finished.
            while self.active.front().is_some_and(|a| finished(a, anchor)) {
                self.active.pop_front();
            }
            if !self.ends_in_order
                && self
                    .active
                    .iter()
                    .any(|a| clock - a.started >= a.duration_s)
            {
                self.active.retain(|a| !finished(a, anchor));
            }
            let mut q = self.anchor;
            let mut in_sum = 0;
            if let Some(sum) = &mut self.cycloids {
                in_sum = sum.members;
                if sum.members > 0 {
                    if clock - sum.epoch > CYCLOIDS_REBASE_S {
                        // A new epoch: the members' phases against it.
                        sum.epoch = clock;
                        for a in &mut self.active {
                            if a.in_sum.is_some() {
                                a.in_sum = Some(sum.phase(a.started));
                            }
                        }
                        sum.dirty = true;
                    }
                    if sum.dirty {
                        sum.rebuild(self.active.iter());
                    }
                    sum.add(clock, &mut q);
                }
            }
            debug_assert_eq!(
                in_sum,
                self.active.iter().filter(|a| a.in_sum.is_some()).count()
            );
            // The segments outside the sum (none while a stream's lines all join it).
            let outside = if self.active.len() > in_sum {
                self.active.len()
            } else {
                0
            };
            for a in self.active.iter_mut().take(outside) {
                if a.in_sum.is_some() {
                    continue;
                }
                let t = clock - a.started;
                if a.from_start && a.tracker.add_in_piece(t, a.duration_s, &mut q) {
                    continue;
                }
                match &a.motion.shape {
                    Shape::Linear(l) if a.from_start => {
                        l.add_displacement_new_piece(a.tracker.last_s, &mut a.tracker, &mut q);
                    }
                    shape => {
                        let p = match shape {
                            Shape::Joint(m) => m.position_at(t),
                            Shape::Linear(l) => l.position_at(t),
                            Shape::Circular(c) => c.position_at(t),
                            Shape::Hybrid(h) => h.position_at(t),
                        };
                        for j in 0..JOINT_COUNT {
                            q[j] += p[j] - a.motion.from[j];
                        }
                    }
                }
            }
            if self.active.is_empty() {
                // Settle exactly on the target (no rounding drift).
                self.anchor = self.target;
                q = self.target;
            }
            q
        };
        // Speed limit, then the joint ranges.
        let mut q = desired;
        for (j, spec) in model.joints.iter().enumerate() {
            let step = spec.max_speed_deg_s * dt;
            q[j] = q[j].clamp(prev[j] - step, prev[j] + step);
            q[j] = q[j].clamp(spec.min_deg, spec.max_deg);
        }
        self.joints = q;
        self.velocity = q.zip_with(&prev, |a, b| (a - b) / dt);
        if self.brake.is_none() && self.active.is_empty() && q == self.target {
            self.velocity = JointsDeg::ZERO;
        }
    }
}

/// `true` when the two configurations are the same numbers bit for bit (a cache key: `-0.0`
/// and `0.0` differ, NaN never matches).
pub(crate) fn same_bits(a: &JointsDeg, b: &JointsDeg) -> bool {
    a.0.iter()
        .zip(b.0.iter())
        .all(|(x, y)| x.to_bits() == y.to_bits() && !x.is_nan())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A long stream of overlapping short lines (most of them one-piece, summed in closed
    /// form, some longer ones evaluated separately): at every tick the robot's joints equal
    /// the lines' separate exact evaluation within rounding, across the sum's epoch changes
    /// (120 s of motion) and its periodic recomputation.
    #[test]
    fn summed_lines_match_their_separate_evaluation() {
        let model = RobotModel::fs020n();
        let mut robot = Arm::new(JointsDeg::new([0.0, 10.0, -80.0, 0.0, -80.0, 0.0]));
        let dt = 0.002;
        let mut worst: f64 = 0.0;
        let mut summed = 0;
        for k in 0..60_000u32 {
            if k % 4 == 0 {
                let from = robot.target();
                let t = f64::from(k) * dt;
                let mut to = from;
                for j in 0..JOINT_COUNT {
                    // Mostly small steps (one piece); every 50th line a longer one.
                    let amp = if k % 200 == 0 { 3.0 } else { 0.02 };
                    to[j] += amp * (0.7 * t + j as f64).sin();
                }
                let path = LinearPath::plan(&model, from, to, 0.1, dt).expect("a line");
                robot.start(Motion {
                    from,
                    to,
                    shape: Shape::Linear(path),
                });
                summed += usize::from(robot.active.back().is_some_and(|a| a.in_sum.is_some()));
            }
            robot.tick(&model, dt);
            let mut reference = robot.anchor;
            for a in &robot.active {
                let p = match &a.motion.shape {
                    Shape::Linear(l) => l.position_at(robot.clock - a.started),
                    Shape::Joint(m) => m.position_at(robot.clock - a.started),
                    Shape::Circular(c) => c.position_at(robot.clock - a.started),
                    Shape::Hybrid(h) => h.position_at(robot.clock - a.started),
                };
                for j in 0..JOINT_COUNT {
                    reference[j] += p[j] - a.motion.from[j];
                }
            }
            worst = worst.max(robot.joints().max_abs_diff(&reference));
        }
        assert!(worst <= 1e-9, "{worst:e}");
        assert!(summed > 10_000, "{summed} lines summed in closed form");
        assert!(robot.clock > CYCLOIDS_REBASE_S);
    }

    #[test]
    fn the_sampling_angle_cosine_is_its_formula() {
        let formula = (0.995 * LINEAR_SAMPLE_DEG / 2.0).to_radians().cos();
        assert!((COS_HALF_SAMPLE_ANGLE - formula).abs() < 1e-15, "{formula}");
    }

    /// The blending test decided by the bound (`FlangeNear`) gives, at every tick, the outcome
    /// of the exact test (the forward kinematics against the target), for ACCURACY from
    /// touching to far, on streams of short lines, long lines and joint moves — and the bound
    /// decides most of them.
    #[test]
    fn blending_test_matches_the_exact_test() {
        let model = RobotModel::fs020n();
        let mut robot = Arm::new(JointsDeg::new([0.0, 10.0, -80.0, 0.0, -80.0, 0.0]));
        let dt = 0.002;
        let accuracies = [0.0, 0.5, 1.0, 10.0, 50.0, 300.0];
        let (mut tests, mut ready, mut exact_runs) = (0u32, 0u32, 0u32);
        for k in 0..20_000u32 {
            if k % 5 == 0 {
                let from = robot.target();
                let t = f64::from(k) * dt;
                let mut to = from;
                let amp = match k % 500 {
                    0 => 20.0,
                    250 => 3.0,
                    _ => 0.3,
                };
                for j in 0..JOINT_COUNT {
                    to[j] += amp * (0.37 * t + 1.3 * j as f64).sin();
                }
                // Joint moves every 1000 ticks and wherever no straight line goes.
                let line = (k % 1000 != 500)
                    .then(|| LinearPath::plan(&model, from, to, 0.1, dt))
                    .flatten();
                let shape = match line {
                    Some(l) => Shape::Linear(l),
                    None => Shape::Joint(JointMove::plan(&model, from, to, 1.0)),
                };
                robot.start(Motion { from, to, shape });
            }
            robot.tick(&model, dt);
            let here = model.flange_position_m(&robot.joints().to_rad());
            let there = model.forward(&robot.target().to_rad()).position_m();
            let distance_mm = (here - there).norm() * 1000.0;
            let accuracy = accuracies[k as usize % accuracies.len()];
            let before = robot.blend_ref;
            let outcome = robot.ready_for_next(&model, accuracy);
            let expected = robot.active.is_empty() || distance_mm <= accuracy;
            assert_eq!(
                outcome, expected,
                "tick {k}: {distance_mm} mm, ACCURACY {accuracy}"
            );
            tests += 1;
            ready += u32::from(outcome);
            exact_runs += u32::from(robot.blend_ref != before);
        }
        assert!(ready > 1000 && tests - ready > 1000, "{ready} of {tests}");
        assert!(
            exact_runs < tests / 4,
            "{exact_runs} exact tests of {tests}"
        );
    }

    /// The tick-by-tick evaluation (piece cursor, rotated sine) matches the direct one within
    /// rounding, with regular 2 ms steps and with the irregular steps of a HOLD ramp, for
    /// short and long lines (many pieces).
    #[test]
    fn tracked_evaluation_matches_direct() {
        let model = RobotModel::fs020n();
        let from = JointsDeg::new([0.0, 10.0, -80.0, 0.0, -80.0, 0.0]);
        let cases = [
            (JointsDeg::new([1.0, 10.5, -80.2, 0.5, -79.0, 1.0]), 0.1),
            (JointsDeg::new([30.0, 20.0, -60.0, 20.0, -50.0, 40.0]), 0.1),
            (JointsDeg::new([30.0, 20.0, -60.0, 20.0, -50.0, 40.0]), 1.0),
            (
                JointsDeg::new([-20.0, 0.0, -90.0, -10.0, -70.0, -30.0]),
                0.02,
            ),
        ];
        for (to, duration) in cases {
            let path = LinearPath::plan(&model, from, to, duration, 0.002).expect("a line");
            for irregular in [false, true] {
                let mut tr = Tracker::default();
                let mut t = 0.0;
                let mut k = 0u32;
                let mut reseeded = 0;
                while t < path.duration_s() + 0.01 {
                    let exact = path.position_at(t);
                    let mut tracked = from;
                    path.add_displacement(t, &mut tr, &mut tracked);
                    let diff = exact.max_abs_diff(&tracked);
                    assert!(diff <= 1e-10, "t = {t}: {exact} vs {tracked} ({diff:e})");
                    reseeded += u32::from(tr.n == 0);
                    k += 1;
                    t += if irregular {
                        0.002 * f64::from(k % 7) / 6.0
                    } else {
                        0.002
                    };
                }
                if !irregular && duration >= 0.1 {
                    // Mostly rotated, not recomputed.
                    assert!(reseeded * 10 < k, "{reseeded} exact of {k}");
                }
            }
        }
    }
}
