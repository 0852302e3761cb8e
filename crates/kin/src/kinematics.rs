//! Forward and inverse kinematics, Jacobian and singularity measures of the 6R arm with a
//! spherical wrist. Frames and sign conventions: `docs/KINEMATICS.md`.
//!
//! Chain (angles `q1..q6` in radians, lengths from [`Geometry`]):
//!
//! ```text
//! T = Rz(q1) · Tr(a1, 0, d1) · Ry(q2) · Tr(0, 0, a2) · Ry(−q3) · Tr(0, 0, d4)
//!       · Rz(q4) · Ry(−q5) · Rz(q6) · Tr(0, 0, d6)
//! ```
//!
//! with `a1 = shoulder_offset_m`, `d1 = base_height_m`, `a2 = upper_arm_m`, `d4 = forearm_m`,
//! `d6 = flange_m`. All joints at zero: arm straight up, flange frame = base frame translated.

use std::f64::consts::{PI, TAU};

use fs020n_proto::{JointsRad, JOINT_COUNT};
use nalgebra::{Matrix3, Matrix6, Vector3};

use crate::model::{Geometry, LimitError, RobotModel};
use crate::pose::Pose;

/// Capacity of [`IkSolutions`]. With the FS020N ranges at most 48 solutions exist (8 branches ×
/// 2 JT4 variants × 3 JT6 variants); models with wider ranges are truncated at this count.
pub const IK_MAX_SOLUTIONS: usize = 64;

/// Wrist centre closer than this to the JT1 axis (metres): shoulder singularity, JT1 is taken
/// from the seed.
pub const SHOULDER_SINGULAR_EPS_M: f64 = 1e-9;

/// `|sin(JT5)|` below this: wrist singularity, JT4 is taken from the seed and JT6 carries the
/// whole rotation about the flange axis.
pub const WRIST_SINGULAR_EPS: f64 = 1e-9;

/// Tolerance on the elbow cosine: a wrist centre up to about a nanometre beyond full stretch is
/// treated as exactly stretched (JT3 = 0) rather than out of reach.
const REACH_EPS: f64 = 1e-9;

/// Joint values within this many radians outside a limit are clamped onto it (round-off of a
/// configuration that is exactly at a limit).
const LIMIT_TOL_RAD: f64 = 1e-10;

/// The margin (degrees) under which the protocol-1040 server treats |JT3| or |JT5| as singular
/// and replaces LMOVE by a 30 % JMOVE.
pub const PROTOCOL_SINGULAR_MARGIN_DEG: f64 = 5.0;

/// Why inverse kinematics found no configuration.
#[derive(Debug, Clone, Copy, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum IkError {
    /// The target pose or the seed contains NaN or infinity.
    #[error("inverse kinematics input is not finite")]
    NonFinite,
    /// The wrist centre is outside the arm's workspace shell (too far, or too close to the
    /// shoulder), whatever the joint ranges.
    #[error("pose is out of reach: the wrist centre is {excess_m:.6} m outside the workspace")]
    OutOfReach {
        /// Distance from the wrist centre to the reachable shell, metres (> 0).
        excess_m: f64,
    },
    /// The pose is kinematically reachable but every solution has a joint outside its range.
    #[error(
        "pose is reachable by {solutions} arm configuration(s) but all are outside the joint \
         ranges (first: {first})"
    )]
    OutsideLimits {
        /// Number of kinematic solutions found before range filtering (branches, without the
        /// 360° variants).
        solutions: usize,
        /// The limit violation of the first of them.
        first: LimitError,
    },
}

/// A fixed-capacity list of IK solutions (no heap allocation). Dereferences to
/// `[JointsRad]`.
#[derive(Clone)]
pub struct IkSolutions {
    len: usize,
    items: [JointsRad; IK_MAX_SOLUTIONS],
}

impl IkSolutions {
    fn new() -> Self {
        Self {
            len: 0,
            items: [JointsRad::ZERO; IK_MAX_SOLUTIONS],
        }
    }

    fn push(&mut self, q: JointsRad) {
        if self.len < IK_MAX_SOLUTIONS {
            self.items[self.len] = q;
            self.len += 1;
        }
    }

    /// The solutions as a slice.
    pub fn as_slice(&self) -> &[JointsRad] {
        &self.items[..self.len]
    }
}

impl std::ops::Deref for IkSolutions {
    type Target = [JointsRad];
    fn deref(&self) -> &[JointsRad] {
        self.as_slice()
    }
}

impl<'a> IntoIterator for &'a IkSolutions {
    type Item = &'a JointsRad;
    type IntoIter = std::slice::Iter<'a, JointsRad>;
    fn into_iter(self) -> Self::IntoIter {
        self.as_slice().iter()
    }
}

impl std::fmt::Debug for IkSolutions {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_list().entries(self.as_slice()).finish()
    }
}

/// Distances to the three singularities of the arm. See `docs/KINEMATICS.md`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SingularityMargins {
    /// `|JT3|` in degrees: 0 = arm stretched (elbow singularity).
    pub elbow_deg: f64,
    /// `|JT5|` in degrees: 0 = wrist straight (JT4 and JT6 aligned).
    pub wrist_deg: f64,
    /// Distance of the wrist centre from the JT1 axis, metres: 0 = shoulder singularity.
    pub shoulder_m: f64,
}

impl SingularityMargins {
    /// `true` when the protocol-1040 server would call this configuration singular
    /// (`|JT3| < 5°` or `|JT5| < 5°`, see [`PROTOCOL_SINGULAR_MARGIN_DEG`]).
    pub fn is_protocol_singular(&self) -> bool {
        self.elbow_deg < PROTOCOL_SINGULAR_MARGIN_DEG
            || self.wrist_deg < PROTOCOL_SINGULAR_MARGIN_DEG
    }
}

#[inline]
fn rz(a: f64) -> Matrix3<f64> {
    let (s, c) = a.sin_cos();
    Matrix3::new(c, -s, 0.0, s, c, 0.0, 0.0, 0.0, 1.0)
}

#[inline]
fn ry(a: f64) -> Matrix3<f64> {
    let (s, c) = a.sin_cos();
    Matrix3::new(c, 0.0, s, 0.0, 1.0, 0.0, -s, 0.0, c)
}

/// Maps an angle to (−π, π].
#[inline]
fn wrap(a: f64) -> f64 {
    let mut a = a % TAU;
    if a <= -PI {
        a += TAU;
    } else if a > PI {
        a -= TAU;
    }
    a
}

/// Intermediate frames of a forward-kinematics evaluation.
struct Frames {
    shoulder: Vector3<f64>,
    elbow: Vector3<f64>,
    wrist: Vector3<f64>,
    r03: Matrix3<f64>,
    r04: Matrix3<f64>,
    r05: Matrix3<f64>,
    r06: Matrix3<f64>,
    flange: Vector3<f64>,
}

/// The arm's first three joints: their sines and cosines, and the points they place.
struct ArmPoints {
    s1: f64,
    c1: f64,
    s23: f64,
    c23: f64,
    shoulder: Vector3<f64>,
    elbow: Vector3<f64>,
    wrist: Vector3<f64>,
}

/// The shoulder, elbow and wrist centre for the joints `q` (JT1–JT3 only), in the base frame.
#[inline(always)]
fn arm_points(g: &Geometry, q: &JointsRad) -> ArmPoints {
    let (s1, c1) = q[0].sin_cos();
    let (s2, c2) = q[1].sin_cos();
    let (s23, c23) = (q[1] - q[2]).sin_cos();
    let shoulder = Vector3::new(
        g.shoulder_offset_m * c1,
        g.shoulder_offset_m * s1,
        g.base_height_m,
    );
    let elbow = shoulder + g.upper_arm_m * Vector3::new(c1 * s2, s1 * s2, c2);
    let wrist = elbow + g.forearm_m * Vector3::new(c1 * s23, s1 * s23, c23);
    ArmPoints {
        s1,
        c1,
        s23,
        c23,
        shoulder,
        elbow,
        wrist,
    }
}

/// The flange position and what it is computed from (JT1–JT5).
struct FlangePoint {
    arm: ArmPoints,
    s4: f64,
    c4: f64,
    /// R04's third column (the JT4 axis).
    r04_z: Vector3<f64>,
    flange: Vector3<f64>,
}

/// The flange position without the orientation: exactly `frames(g, q).flange`. The flange
/// axis is the third column of R06 = R03·Rz(q4)·Ry(−q5)·Rz(q6); Rz(q6) keeps it, so it is
/// R04·(sin(−q5), 0, cos(−q5)) with R04's first and third columns: the same products and sums
/// as `frames` (the terms dropped are exact zeros), without JT6 and the rest of the
/// orientation.
#[inline(always)]
fn flange_point(g: &Geometry, q: &JointsRad) -> FlangePoint {
    let arm = arm_points(g, q);
    let (s1, c1, s23, c23) = (arm.s1, arm.c1, arm.s23, arm.c23);
    let (s4, c4) = q[3].sin_cos();
    let (s5, c5) = (-q[4]).sin_cos();
    // R03's columns: (c1·c23, s1·c23, −s23), (−s1, c1, 0), (c1·s23, s1·s23, c23).
    let r04_x = Vector3::new(c1 * c23 * c4 + -s1 * s4, s1 * c23 * c4 + c1 * s4, -s23 * c4);
    let r04_z = Vector3::new(c1 * s23, s1 * s23, c23);
    let axis = r04_x * s5 + r04_z * c5;
    let flange = arm.wrist + g.flange_m * axis;
    FlangePoint {
        arm,
        s4,
        c4,
        r04_z,
        flange,
    }
}

fn frames(g: &Geometry, q: &JointsRad) -> Frames {
    let ArmPoints {
        s1,
        c1,
        s23,
        c23,
        shoulder,
        elbow,
        wrist,
    } = arm_points(g, q);
    let r03 = Matrix3::new(
        c1 * c23,
        -s1,
        c1 * s23,
        s1 * c23,
        c1,
        s1 * s23,
        -s23,
        0.0,
        c23,
    );
    let r04 = r03 * rz(q[3]);
    let r05 = r04 * ry(-q[4]);
    let r06 = r05 * rz(q[5]);
    let flange = wrist + g.flange_m * r06.column(2);
    Frames {
        shoulder,
        elbow,
        wrist,
        r03,
        r04,
        r05,
        r06,
        flange,
    }
}

/// The flange position at one configuration and its derivatives there
/// ([`RobotModel::flange_near`]): estimates the flange position at other joints to first
/// order, with a bound on the error, far more cheaply than the forward kinematics.
///
/// The bound: along the straight joint-space path from `q` to `q + Δ`, the second derivative
/// of the flange position is `Σ_j Σ_k Δ_j Δ_k ∂²p/∂q_j∂q_k`, and each `∂²p/∂q_j∂q_k` is
/// `a_j × (a_k × (p − o_k))` (for `j ≤ k`; unit axes `a`, points `o` on them), no longer than
/// the lever bound `R_max(j,k)` ([`RobotModel::flange_lever_bounds_m`]). Taylor's theorem then
/// bounds `|p(q + Δ) − p(q) − J·Δ|` by half of `Σ_j Σ_k |Δ_j| |Δ_k| R_max(j,k)`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FlangeNear {
    q: JointsRad,
    position_m: Vector3<f64>,
    /// ∂p/∂q_j, metres per radian, for JT1–JT5 (JT6 does not move the flange position).
    jacobian: [Vector3<f64>; 5],
    levers_m: [f64; JOINT_COUNT],
}

impl FlangeNear {
    /// The joints it was computed at.
    pub fn joints(&self) -> JointsRad {
        self.q
    }

    /// The flange position at [`joints`](Self::joints), metres (exactly
    /// [`RobotModel::flange_position_m`]).
    pub fn position_m(&self) -> Vector3<f64> {
        self.position_m
    }

    /// The flange position at `q` estimated to first order, and a bound on the estimate's
    /// error, metres: the true position is within that distance of the estimate (up to the
    /// rounding of both, ≈ 1e-15 m).
    pub fn estimate_m(&self, q: &JointsRad) -> (Vector3<f64>, f64) {
        let mut p = self.position_m;
        // Σ_j Σ_k |Δ_j| |Δ_k| R_max(j,k), summed by the later joint k:
        // R_k |Δ_k| (|Δ_k| + 2 Σ_{j<k} |Δ_j|).
        let mut second = 0.0;
        let mut before = 0.0;
        for j in 0..JOINT_COUNT {
            let d = q[j] - self.q[j];
            if j < self.jacobian.len() {
                p += self.jacobian[j] * d;
            }
            let a = d.abs();
            second += self.levers_m[j] * a * (a + 2.0 * before);
            before += a;
        }
        (p, 0.5 * second)
    }
}

/// Per-joint list of in-range angle variants (k·360° shifts).
struct Variants {
    values: [[f64; 4]; JOINT_COUNT],
    counts: [usize; JOINT_COUNT],
}

impl RobotModel {
    /// Forward kinematics: the flange pose in the base frame.
    pub fn forward(&self, q: &JointsRad) -> Pose {
        let f = frames(&self.geometry, q);
        Pose::from_parts_matrix(f.flange, &f.r06)
    }

    /// The flange position in the base frame, metres: exactly `forward(q).position_m()`,
    /// without building the orientation (cheaper when only distances matter).
    pub fn flange_position_m(&self, q: &JointsRad) -> Vector3<f64> {
        flange_point(&self.geometry, q).flange
    }

    /// The flange position at `q` with its first derivatives, to estimate the flange position
    /// at nearby joints with a proven error bound (see [`FlangeNear`]). The position is
    /// exactly [`flange_position_m`](Self::flange_position_m)'s.
    pub fn flange_near(&self, q: &JointsRad) -> FlangeNear {
        let FlangePoint {
            arm:
                ArmPoints {
                    s1,
                    c1,
                    s23,
                    c23,
                    shoulder,
                    elbow,
                    wrist,
                },
            s4,
            c4,
            r04_z,
            flange,
        } = flange_point(&self.geometry, q);
        // Each joint turns everything after it about its axis: column j is axis_j × (p − o_j).
        // JT1: the base z axis; JT2: (−s1, c1, 0) through the shoulder; JT3: the opposite
        // direction (it enters as q2 − q3) through the elbow; JT4: R03's z axis through the
        // wrist centre; JT5: −(R04's y axis) (it enters as Ry(−q5)) through the wrist centre.
        // JT6 turns the flange about its own axis: the position does not move.
        let a2 = Vector3::new(-s1, c1, 0.0);
        let r03_x = Vector3::new(c1 * c23, s1 * c23, -s23);
        let r04_y = r03_x * -s4 + a2 * c4;
        let from_wrist = flange - wrist;
        let jacobian = [
            Vector3::new(-flange.y, flange.x, 0.0),
            a2.cross(&(flange - shoulder)),
            (-a2).cross(&(flange - elbow)),
            r04_z.cross(&from_wrist),
            (-r04_y).cross(&from_wrist),
        ];
        FlangeNear {
            q: *q,
            position_m: flange,
            jacobian,
            levers_m: self.flange_lever_bounds_m(),
        }
    }

    /// For each joint, a bound on the distance from its axis to the flange in any
    /// configuration, metres: the lengths of the links after it (JT6: 0, its axis passes
    /// through the flange). Turning joint `j` by `δ` radians moves the flange by at most
    /// `R_j·|δ|`.
    pub fn flange_lever_bounds_m(&self) -> [f64; JOINT_COUNT] {
        let g = &self.geometry;
        let wrist = g.flange_m.abs();
        let forearm = g.forearm_m.abs() + wrist;
        let upper = g.upper_arm_m.abs() + forearm;
        let base = g.shoulder_offset_m.abs() + upper;
        [base, upper, forearm, wrist, wrist, 0.0]
    }

    /// Forward kinematics of a tool point: `forward(q) * tool`, where `tool` is the tool frame
    /// relative to the flange.
    pub fn forward_tool(&self, q: &JointsRad, tool: &Pose) -> Pose {
        self.forward(q) * *tool
    }

    /// The wrist centre (intersection of the JT4, JT5, JT6 axes) in the base frame, metres.
    pub fn wrist_centre_m(&self, q: &JointsRad) -> Vector3<f64> {
        frames(&self.geometry, q).wrist
    }

    /// All inverse-kinematics solutions for a flange pose inside the joint ranges, including
    /// the k·360° variants of every joint that fit in its range. Singular joints (JT1 at the
    /// shoulder singularity, JT4 at the wrist singularity) are taken as 0; use
    /// [`RobotModel::inverse_all_seeded`] to choose them.
    pub fn inverse_all(&self, pose: &Pose) -> Result<IkSolutions, IkError> {
        self.inverse_all_seeded(pose, &JointsRad::ZERO)
    }

    /// Like [`RobotModel::inverse_all`], taking the values of undetermined joints at a
    /// singularity (JT1 at the shoulder, JT4 at the wrist) from `seed`.
    pub fn inverse_all_seeded(
        &self,
        pose: &Pose,
        seed: &JointsRad,
    ) -> Result<IkSolutions, IkError> {
        let mut out = IkSolutions::new();
        self.for_each_branch(pose, seed, |_| false, |v| push_product(&mut out, v))?;
        Ok(out)
    }

    /// The kinematic branches of `pose` (shoulder front/back, elbow up/down, wrist flip, in
    /// the order of [`RobotModel::inverse_all_seeded`]), each with the in-range 360° variants
    /// of its joints, handed to `each`. Fails as `inverse_all_seeded` does when no branch has
    /// an in-range variant. Once one has, `skip` is asked with the first joints of a branch
    /// (JT1, then JT1–JT3) whether the rest of it can be left out.
    fn for_each_branch(
        &self,
        pose: &Pose,
        seed: &JointsRad,
        skip: impl Fn(&[f64]) -> bool,
        mut each: impl FnMut(&Variants),
    ) -> Result<(), IkError> {
        if !pose.is_finite() || !seed.is_finite() {
            return Err(IkError::NonFinite);
        }
        let g = &self.geometry;
        let (a1, d1, a2, d4, d6) = (
            g.shoulder_offset_m,
            g.base_height_m,
            g.upper_arm_m,
            g.forearm_m,
            g.flange_m,
        );
        let r = pose.rotation_matrix();
        let p = pose.position_m();
        let wc = p - d6 * r.column(2);
        let rho = wc.x.hypot(wc.y);
        let q1_front = if rho < SHOULDER_SINGULAR_EPS_M {
            wrap(seed[0])
        } else {
            wc.y.atan2(wc.x)
        };
        let s = wc.z - d1;
        let (inner, outer) = ((a2 - d4).abs(), a2 + d4);

        let mut found = false;
        let mut excess = f64::INFINITY;
        let mut kinematic = 0usize;
        let mut first_violation: Option<LimitError> = None;

        for (q1, r_plane) in [(q1_front, rho - a1), (wrap(q1_front + PI), -rho - a1)] {
            if found && skip(&[q1]) {
                continue;
            }
            let dist = r_plane.hypot(s);
            let cos3 = (dist * dist - a2 * a2 - d4 * d4) / (2.0 * a2 * d4);
            if !(-1.0 - REACH_EPS..=1.0 + REACH_EPS).contains(&cos3) {
                let e = if dist > outer {
                    dist - outer
                } else {
                    inner - dist
                };
                excess = excess.min(e.max(f64::MIN_POSITIVE));
                continue;
            }
            let a3 = cos3.clamp(-1.0, 1.0).acos();
            // Elbow up (JT3 < 0 in the front configuration) first; at a3 = 0 (stretched) or
            // a3 = π (folded) the two elbow branches coincide: one solution only.
            let elbow_branches: &[f64] = if a3 == 0.0 || a3 == PI {
                &[1.0]
            } else {
                &[-1.0, 1.0]
            };
            for &sign in elbow_branches {
                let q3 = sign * a3;
                let (s3, c3) = q3.sin_cos();
                let q2 = wrap(r_plane.atan2(s) - (-d4 * s3).atan2(a2 + d4 * c3));
                if found && skip(&[q1, q2, q3]) {
                    continue;
                }
                let r03 = rz(q1) * ry(q2 - q3);
                let m = r03.transpose() * r;
                let sb = m[(0, 2)].hypot(m[(1, 2)]);
                let cb = m[(2, 2)];
                let mut wrists = [[0.0; 3]; 2];
                let n_wrist = if sb > WRIST_SINGULAR_EPS {
                    let b = sb.atan2(cb);
                    let a = m[(1, 2)].atan2(m[(0, 2)]);
                    let c = m[(2, 1)].atan2(-m[(2, 0)]);
                    wrists[0] = [a, -b, c];
                    wrists[1] = [wrap(a + PI), b, wrap(c + PI)];
                    2
                } else {
                    let q4 = wrap(seed[3]);
                    if cb > 0.0 {
                        // M = Rz(q4 + q6)
                        let th = (m[(1, 0)] - m[(0, 1)]).atan2(m[(0, 0)] + m[(1, 1)]);
                        wrists[0] = [q4, 0.0, wrap(th - q4)];
                    } else {
                        // M = Ry(π) Rz(q6 − q4), q5 = −π
                        let th = (m[(1, 0)] + m[(0, 1)]).atan2(m[(1, 1)] - m[(0, 0)]);
                        wrists[0] = [q4, -PI, wrap(th + q4)];
                    }
                    1
                };
                for w in &wrists[..n_wrist] {
                    kinematic += 1;
                    let base = [q1, q2, q3, w[0], w[1], w[2]];
                    match self.variants(&base) {
                        Ok(v) => {
                            found = true;
                            each(&v);
                        }
                        Err(e) => {
                            first_violation.get_or_insert(e);
                        }
                    }
                }
            }
        }

        if found {
            Ok(())
        } else if let Some(first) = first_violation {
            Err(IkError::OutsideLimits {
                solutions: kinematic,
                first,
            })
        } else {
            Err(IkError::OutOfReach { excess_m: excess })
        }
    }

    /// The in-range solution nearest to `seed` (smallest sum of squared joint differences,
    /// radians). Undetermined joints at a singularity are taken from the seed (see
    /// `docs/KINEMATICS.md`).
    ///
    /// Of the solutions in the order of [`RobotModel::inverse_all_seeded`], the first with the
    /// smallest distance. The distance is a sum over the joints, so within a branch the nearest
    /// solution takes each joint's nearest 360° variant: the branch's variants are not
    /// enumerated (a seed exactly halfway between two variants of a joint, 180° from both, is
    /// a tie either way).
    pub fn inverse_nearest(&self, pose: &Pose, seed: &JointsRad) -> Result<JointsRad, IkError> {
        let best = std::cell::Cell::new(JointsRad::ZERO);
        let best_d = std::cell::Cell::new(f64::INFINITY);
        let mut first = true;
        // A branch whose first joints alone are as far as the best solution so far cannot
        // give a nearer one: the distance's partial sums only grow.
        let skip = |q: &[f64]| {
            let mut partial = -0.0;
            for (i, &x) in q.iter().enumerate() {
                match self.nearest_variant(i, x, seed[i]) {
                    Some((_, d)) => partial += d,
                    None => return true,
                }
            }
            partial >= best_d.get()
        };
        self.for_each_branch(pose, seed, skip, |v| {
            let mut q = JointsRad::ZERO;
            for i in 0..JOINT_COUNT {
                let values = &v.values[i][..v.counts[i]];
                let mut x = values[0];
                let mut dx = (x - seed[i]) * (x - seed[i]);
                for &y in &values[1..] {
                    let dy = (y - seed[i]) * (y - seed[i]);
                    if dy < dx {
                        (x, dx) = (y, dy);
                    }
                }
                q[i] = x;
            }
            let d: f64 = q
                .iter()
                .zip(seed.iter())
                .map(|(a, b)| (a - b) * (a - b))
                .sum();
            if first {
                // The first solution, kept when no distance is smaller than infinity.
                let mut q0 = JointsRad::ZERO;
                for i in 0..JOINT_COUNT {
                    q0[i] = v.values[i][0];
                }
                best.set(q0);
                first = false;
            }
            if d < best_d.get() {
                best_d.set(d);
                best.set(q);
            }
        })?;
        Ok(best.get())
    }

    /// All solutions placing the tool frame `tool` (relative to the flange) at `target`.
    pub fn inverse_tool_all(&self, target: &Pose, tool: &Pose) -> Result<IkSolutions, IkError> {
        self.inverse_all(&(*target * tool.inverse()))
    }

    /// The solution nearest to `seed` placing the tool frame `tool` at `target`.
    pub fn inverse_tool_nearest(
        &self,
        target: &Pose,
        tool: &Pose,
        seed: &JointsRad,
    ) -> Result<JointsRad, IkError> {
        self.inverse_nearest(&(*target * tool.inverse()), seed)
    }

    /// The in-range k·360° variants of joint `i` at `q` radians (at most 4), and how many.
    fn joint_variants(&self, i: usize, q: f64) -> ([f64; 4], usize) {
        let spec = &self.joints[i];
        let (lo, hi) = (spec.min_deg.to_radians(), spec.max_deg.to_radians());
        let k_min = ((lo - LIMIT_TOL_RAD - q) / TAU).ceil() as i64;
        let k_max = ((hi + LIMIT_TOL_RAD - q) / TAU).floor() as i64;
        let mut values = [0.0; 4];
        let mut count = 0;
        for k in k_min..=k_max {
            if count == 4 {
                break;
            }
            values[count] = (q + k as f64 * TAU).clamp(lo, hi);
            count += 1;
        }
        (values, count)
    }

    /// The smallest `(x − seed)²` over the in-range variants `x` of joint `i` at `q`, and the
    /// first variant that has it (`None`: no variant in range).
    fn nearest_variant(&self, i: usize, q: f64, seed: f64) -> Option<(f64, f64)> {
        let (values, count) = self.joint_variants(i, q);
        let values = &values[..count];
        let mut x = *values.first()?;
        let mut dx = (x - seed) * (x - seed);
        for &y in &values[1..] {
            let dy = (y - seed) * (y - seed);
            if dy < dx {
                (x, dx) = (y, dy);
            }
        }
        Some((x, dx))
    }

    fn variants(&self, base: &[f64; JOINT_COUNT]) -> Result<Variants, LimitError> {
        let mut v = Variants {
            values: [[0.0; 4]; JOINT_COUNT],
            counts: [0; JOINT_COUNT],
        };
        for (i, spec) in self.joints.iter().enumerate() {
            let q = base[i];
            (v.values[i], v.counts[i]) = self.joint_variants(i, q);
            if v.counts[i] == 0 {
                return Err(LimitError {
                    joint: i + 1,
                    value_deg: q.to_degrees(),
                    min_deg: spec.min_deg,
                    max_deg: spec.max_deg,
                });
            }
        }
        Ok(v)
    }

    /// The 6×6 geometric Jacobian at the flange, in the base frame: rows 0..3 linear velocity
    /// of the flange origin (m/s per rad/s), rows 3..6 angular velocity (rad/s per rad/s);
    /// column `i` belongs to JT(i+1).
    pub fn jacobian(&self, q: &JointsRad) -> Matrix6<f64> {
        let f = frames(&self.geometry, q);
        jacobian_at(&f, &f.flange)
    }

    /// The geometric Jacobian at a tool point: the origin of `tool` (relative to the flange).
    pub fn jacobian_tool(&self, q: &JointsRad, tool: &Pose) -> Matrix6<f64> {
        let f = frames(&self.geometry, q);
        let point = f.flange + f.r06 * tool.position_m();
        jacobian_at(&f, &point)
    }

    /// Distance to singularity: the smallest singular value of the flange Jacobian
    /// ([`RobotModel::jacobian`], metres and radians). Zero exactly at a singularity (arm
    /// stretched, wrist straight, wrist centre on the JT1 axis); grows smoothly away from it.
    /// See [`RobotModel::singularity_margins`] for per-singularity margins.
    /// NaN when a joint is not finite (the SVD would not converge).
    pub fn singularity_distance(&self, q: &JointsRad) -> f64 {
        if !q.is_finite() {
            return f64::NAN;
        }
        let sv = self.jacobian(q).singular_values();
        sv.iter().copied().fold(f64::INFINITY, f64::min)
    }

    /// Yoshikawa manipulability `sqrt(det(J Jᵀ)) = |det J|` of the flange Jacobian. For this
    /// arm it equals `a2 · d4 · |sin JT3| · |sin JT5| · ρ`, where `ρ` is the distance between
    /// the wrist centre and the JT1 axis (metres³). Zero at every singularity.
    pub fn manipulability(&self, q: &JointsRad) -> f64 {
        self.jacobian(q).determinant().abs()
    }

    /// Per-singularity margins: `|JT3|`, `|JT5|` in degrees and the wrist-centre distance from
    /// the JT1 axis in metres.
    pub fn singularity_margins(&self, q: &JointsRad) -> SingularityMargins {
        let wc = frames(&self.geometry, q).wrist;
        SingularityMargins {
            elbow_deg: q[2].to_degrees().abs(),
            wrist_deg: q[4].to_degrees().abs(),
            shoulder_m: wc.x.hypot(wc.y),
        }
    }
}

fn push_product(out: &mut IkSolutions, v: &Variants) {
    let mut idx = [0usize; JOINT_COUNT];
    loop {
        let mut q = JointsRad::ZERO;
        for i in 0..JOINT_COUNT {
            q[i] = v.values[i][idx[i]];
        }
        out.push(q);
        // odometer increment
        let mut i = JOINT_COUNT;
        loop {
            if i == 0 {
                return;
            }
            i -= 1;
            idx[i] += 1;
            if idx[i] < v.counts[i] {
                break;
            }
            idx[i] = 0;
        }
    }
}

fn jacobian_at(f: &Frames, point: &Vector3<f64>) -> Matrix6<f64> {
    let z1 = Vector3::z();
    let z2 = f.r03.column(1).into_owned(); // Rz(q1)·ŷ, unaffected by the Ry rotations
    let z3 = -z2;
    let z4 = f.r03.column(2).into_owned();
    let z5 = -f.r04.column(1).into_owned();
    let z6 = f.r05.column(2).into_owned();
    let axes = [
        (z1, Vector3::zeros()),
        (z2, f.shoulder),
        (z3, f.elbow),
        (z4, f.wrist),
        (z5, f.wrist),
        (z6, f.wrist),
    ];
    let mut j = Matrix6::zeros();
    for (c, (z, o)) in axes.iter().enumerate() {
        let lin = z.cross(&(point - o));
        for r in 0..3 {
            j[(r, c)] = lin[r];
            j[(r + 3, c)] = z[r];
        }
    }
    j
}

#[cfg(test)]
mod tests {
    use super::*;
    use fs020n_proto::JointsDeg;

    #[test]
    fn wrap_range() {
        assert_eq!(wrap(PI), PI);
        assert!((wrap(-PI) - PI).abs() < 1e-15);
        assert!((wrap(3.0 * PI) - PI).abs() < 1e-12);
        assert!((wrap(-0.5) + 0.5).abs() < 1e-15);
    }

    #[test]
    fn zero_pose_identity_orientation() {
        let m = RobotModel::fs020n();
        let p = m.forward(&JointsRad::ZERO);
        assert!(p.angle_to_rad(&Pose::IDENTITY) < 1e-12);
        assert!((p.position_m() - Vector3::new(0.15, 0.0, 2.0465)).norm() < 1e-12);
    }

    #[test]
    fn flange_position_is_the_forward_position_bit_for_bit() {
        let m = RobotModel::fs020n();
        for q in [
            [0.0, 0.0, -90.0, 0.0, -90.0, 0.0],
            [20.0, 30.0, -60.0, 40.0, -50.0, 70.0],
            [-150.0, 100.0, -10.0, 250.0, 120.0, -300.0],
        ] {
            let q = JointsDeg::new(q).to_rad();
            assert_eq!(m.flange_position_m(&q), m.forward(&q).position_m());
        }
    }

    /// Uniform numbers in [0, 1) from `seed`: a small deterministic generator (xorshift, no
    /// dependency).
    fn uniform_numbers(seed: u64) -> impl FnMut() -> f64 {
        let mut state = seed;
        move || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state >> 11) as f64 / (1u64 << 53) as f64
        }
    }

    /// `flange_near`: the position is `flange_position_m`'s bit for bit, the derivatives are
    /// the flange Jacobian's linear rows, and the estimate at nearby joints is within its
    /// error bound of the forward kinematics (which it nearly reaches for some steps).
    #[test]
    fn flange_near_estimates_within_its_bound() {
        let m = RobotModel::fs020n();
        let mut uniform = uniform_numbers(0x9e37_79b9_7f4a_7c15);
        let mut tightest: f64 = 0.0;
        for _ in 0..2000 {
            let mut q = JointsRad::ZERO;
            let mut dq = JointsRad::ZERO;
            let scale = [1e-4, 1e-2, 0.1, 0.5][(uniform() * 4.0) as usize % 4];
            for j in 0..JOINT_COUNT {
                q[j] = (uniform() * 2.0 - 1.0) * PI;
                dq[j] = (uniform() * 2.0 - 1.0) * scale;
            }
            let near = m.flange_near(&q);
            assert_eq!(near.position_m(), m.flange_position_m(&q));
            assert_eq!(near.joints(), q);
            let jac = m.jacobian(&q);
            for j in 0..5 {
                for r in 0..3 {
                    assert!((near.jacobian[j][r] - jac[(r, j)]).abs() < 1e-12, "{j} {r}");
                }
            }
            let mut there = q;
            for j in 0..JOINT_COUNT {
                there[j] += dq[j];
            }
            let (estimate, bound) = near.estimate_m(&there);
            let error = (m.flange_position_m(&there) - estimate).norm();
            assert!(
                error <= bound + 1e-12,
                "{error} > {bound} at {q:?} + {dq:?}"
            );
            if bound > 1e-9 {
                tightest = tightest.max(error / bound);
            }
        }
        // The bound is not loose by orders of magnitude.
        assert!(tightest > 0.05, "{tightest}");
    }

    /// `inverse_nearest` picks exactly the solution a scan of all solutions picks (the first
    /// with the smallest sum of squared differences), over many poses and seeds, near and far.
    #[test]
    fn inverse_nearest_is_the_nearest_of_all_solutions() {
        let m = RobotModel::fs020n();
        let mut uniform = uniform_numbers(0x2545_f491_4f6c_dd1d);
        let mut checked = 0;
        for _ in 0..3000 {
            let mut q = JointsDeg::ZERO;
            let mut seed = JointsDeg::ZERO;
            for (i, spec) in m.joints.iter().enumerate() {
                q[i] = spec.min_deg + (spec.max_deg - spec.min_deg) * uniform();
                // Seeds near the configuration (the planner's case) and anywhere.
                seed[i] = if checked % 2 == 0 {
                    q[i] + 4.0 * (uniform() - 0.5)
                } else {
                    -400.0 + 800.0 * uniform()
                };
            }
            let (pose, seed) = (m.forward(&q.to_rad()), seed.to_rad());
            let all = m.inverse_all_seeded(&pose, &seed);
            let nearest = m.inverse_nearest(&pose, &seed);
            match (all, nearest) {
                (Ok(all), Ok(nearest)) => {
                    let mut best = all[0];
                    let mut best_d = f64::INFINITY;
                    for s in &all {
                        let d: f64 = s
                            .iter()
                            .zip(seed.iter())
                            .map(|(a, b)| (a - b) * (a - b))
                            .sum();
                        if d < best_d {
                            (best, best_d) = (*s, d);
                        }
                    }
                    assert_eq!(nearest, best, "pose {pose:?} seed {seed:?}");
                    checked += 1;
                }
                (Err(a), Err(b)) => assert_eq!(a, b),
                (a, b) => panic!("{a:?} vs {b:?}"),
            }
        }
        assert!(checked > 2500, "{checked}");
    }

    #[test]
    fn jacobian_matches_finite_differences() {
        let m = RobotModel::fs020n();
        let q = JointsDeg::new([20.0, 30.0, -60.0, 40.0, -50.0, 70.0]).to_rad();
        let j = m.jacobian(&q);
        let h = 1e-6;
        for c in 0..6 {
            let mut qp = q;
            let mut qm = q;
            qp[c] += h;
            qm[c] -= h;
            let (pp, pm) = (m.forward(&qp), m.forward(&qm));
            let dp = (pp.position_m() - pm.position_m()) / (2.0 * h);
            let dr = (pp.rotation() * pm.rotation().inverse()).scaled_axis() / (2.0 * h);
            for r in 0..3 {
                assert!((j[(r, c)] - dp[r]).abs() < 1e-6, "lin r{r} c{c}");
                assert!((j[(r + 3, c)] - dr[r]).abs() < 1e-6, "ang r{r} c{c}");
            }
        }
    }
}
