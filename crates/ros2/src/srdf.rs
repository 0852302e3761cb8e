//! MoveIt's semantic description (SRDF) of the arm: the planning group `manipulator` (the chain
//! `base_link` → `flange`), the named states `home` (the model's home pose) and `zero`, and the
//! self-collision matrix: which pairs of links MoveIt need not check.
//!
//! The matrix is computed the way MoveIt's Setup Assistant does, from the URDF's collision
//! shapes ([`RobotModel::collision_shapes`]) placed by [`RobotModel::link_frames`]:
//!
//! * **Adjacent**: links joined by a joint (they touch by construction);
//! * **Always**: pairs in collision in every sampled configuration (e.g. two housings around
//!   the wrist centre): checking them would make every state invalid;
//! * **Never**: pairs in collision in none of [`SELF_COLLISION_SAMPLES`] configurations drawn
//!   uniformly within the joint ranges by a fixed generator ([`SELF_COLLISION_SEED`]; the same
//!   model gives the same SRDF).
//!
//! Every other pair stays checked. Distances are exact between capsules and between a capsule
//! and a flat-ended cylinder; two cylinders are compared as one cylinder and the other's
//! enclosing capsule (same axis and radius), so a pair is reported "Never" only when even that
//! larger shape never met: the matrix disables no more than the shapes justify. "Never" is a sampling result, like the Setup Assistant's: a collision confined
//! to a region smaller than the sampling density could be missed; raise the sample count for a
//! model with unusual proportions.

use std::fmt::Write;

use fs020n_kin::urdf::{CollisionShape, URDF_LINK_COUNT, URDF_LINK_NAMES};
use fs020n_kin::{JointsDeg, Pose, RobotModel};
use fs020n_proto::JOINT_COUNT;

/// Configurations sampled for the self-collision matrix (the Setup Assistant's default density).
pub const SELF_COLLISION_SAMPLES: usize = 10_000;

/// Seed of the generator that draws the sampled configurations.
pub const SELF_COLLISION_SEED: u64 = 20;

/// Why a pair of links is not checked for collisions (the SRDF's `reason`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum DisableReason {
    /// Joined by a joint.
    Adjacent,
    /// In collision in every sample.
    Always,
    /// In collision in no sample.
    Never,
}

impl DisableReason {
    /// The SRDF's spelling.
    pub fn as_str(self) -> &'static str {
        match self {
            DisableReason::Adjacent => "Adjacent",
            DisableReason::Always => "Always",
            DisableReason::Never => "Never",
        }
    }
}

/// A pair of links MoveIt does not check, indices into [`URDF_LINK_NAMES`] (first < second).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct DisabledPair {
    /// The first link.
    pub first: usize,
    /// The second link.
    pub second: usize,
    /// Why.
    pub reason: DisableReason,
}

/// How often each pair of links collided over the samples.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct SelfCollisionCounts {
    /// The number of configurations checked.
    pub samples: usize,
    /// `hits[i][j]` (i < j): in how many of them links `i` and `j` collided.
    pub hits: [[usize; URDF_LINK_COUNT]; URDF_LINK_COUNT],
}

/// SplitMix64: a small, fixed generator (the matrix must not change between runs or builds).
struct SplitMix64(u64);

impl SplitMix64 {
    fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    /// Uniform in [0, 1).
    fn next_unit(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 / (1u64 << 53) as f64
    }
}

/// A shape in the base frame: axis ends, radius, capsule or flat-ended cylinder.
#[derive(Debug, Clone, Copy)]
struct Placed {
    a: [f64; 3],
    b: [f64; 3],
    radius: f64,
    flat_ends: bool,
}

fn place(frame: &Pose, shape: &CollisionShape) -> Placed {
    let at = |p: [f64; 3]| {
        let v = (*frame * Pose::from_translation_m(p[0], p[1], p[2])).position_m();
        [v[0], v[1], v[2]]
    };
    Placed {
        a: at(shape.from_m),
        b: at(shape.to_m),
        radius: shape.radius_m,
        flat_ends: shape.flat_ends,
    }
}

fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// The squared distance between segments `p1 p2` and `q1 q2`.
fn segment_distance_sq(p1: [f64; 3], p2: [f64; 3], q1: [f64; 3], q2: [f64; 3]) -> f64 {
    let d1 = sub(p2, p1);
    let d2 = sub(q2, q1);
    let r = sub(p1, q1);
    let a = dot(d1, d1);
    let e = dot(d2, d2);
    let f = dot(d2, r);
    const EPS: f64 = 1e-18;
    let (s, t) = if a <= EPS && e <= EPS {
        (0.0, 0.0)
    } else if a <= EPS {
        (0.0, (f / e).clamp(0.0, 1.0))
    } else {
        let c = dot(d1, r);
        if e <= EPS {
            ((-c / a).clamp(0.0, 1.0), 0.0)
        } else {
            let b = dot(d1, d2);
            let denom = a * e - b * b;
            let mut s = if denom > EPS {
                ((b * f - c * e) / denom).clamp(0.0, 1.0)
            } else {
                0.0
            };
            let mut t = (b * s + f) / e;
            if t < 0.0 {
                t = 0.0;
                s = (-c / a).clamp(0.0, 1.0);
            } else if t > 1.0 {
                t = 1.0;
                s = ((b - c) / a).clamp(0.0, 1.0);
            }
            (s, t)
        }
    };
    let cp = [p1[0] + d1[0] * s, p1[1] + d1[1] * s, p1[2] + d1[2] * s];
    let cq = [q1[0] + d2[0] * t, q1[1] + d2[1] * t, q1[2] + d2[2] * t];
    let d = sub(cp, cq);
    dot(d, d)
}

/// The distance from point `p` to the solid cylinder `c` (0 inside).
fn cylinder_distance(c: &Placed, p: [f64; 3]) -> f64 {
    let axis = sub(c.b, c.a);
    let length = dot(axis, axis).sqrt();
    let rel = sub(p, c.a);
    if length == 0.0 {
        return (dot(rel, rel).sqrt() - c.radius).max(0.0);
    }
    let along = dot(rel, axis) / length;
    let radial_sq = (dot(rel, rel) - along * along).max(0.0);
    let dz = (-along).max(along - length).max(0.0);
    let dr = (radial_sq.sqrt() - c.radius).max(0.0);
    dz.hypot(dr)
}

/// The distance from the segment `a b` to the cylinder `c`: the distance to a convex solid is
/// convex along a line, so a golden-section search on the segment finds its minimum.
fn segment_cylinder_distance(c: &Placed, a: [f64; 3], b: [f64; 3]) -> f64 {
    let d = sub(b, a);
    let at = |t: f64| cylinder_distance(c, [a[0] + d[0] * t, a[1] + d[1] * t, a[2] + d[2] * t]);
    const INV_PHI: f64 = 0.618_033_988_749_894_8;
    let (mut lo, mut hi) = (0.0f64, 1.0f64);
    let mut x1 = hi - INV_PHI * (hi - lo);
    let mut x2 = lo + INV_PHI * (hi - lo);
    let (mut f1, mut f2) = (at(x1), at(x2));
    for _ in 0..48 {
        if f1 <= f2 {
            hi = x2;
            x2 = x1;
            f2 = f1;
            x1 = hi - INV_PHI * (hi - lo);
            f1 = at(x1);
        } else {
            lo = x1;
            x1 = x2;
            f1 = f2;
            x2 = lo + INV_PHI * (hi - lo);
            f2 = at(x2);
        }
    }
    f1.min(f2).min(at(0.0)).min(at(1.0))
}

fn shapes_touch(x: &Placed, y: &Placed) -> bool {
    match (x.flat_ends, y.flat_ends) {
        (false, false) => {
            let reach = x.radius + y.radius;
            segment_distance_sq(x.a, x.b, y.a, y.b) <= reach * reach
        }
        // A cylinder and a capsule (or a cylinder taken as its enclosing capsule).
        (true, _) => segment_cylinder_distance(x, y.a, y.b) <= y.radius,
        (false, true) => segment_cylinder_distance(y, x.a, x.b) <= x.radius,
    }
}

/// Links `i` and `j` are joined by a joint.
fn adjacent(i: usize, j: usize) -> bool {
    i.abs_diff(j) == 1
}

/// The pairs of links (i < j, both with collision shapes) whose shapes, as capsules, touch at
/// joints `q`.
pub fn colliding_pairs(model: &RobotModel, q: &JointsDeg) -> Vec<(usize, usize)> {
    colliding_with(&model.collision_shapes(), model, q)
}

fn colliding_with(
    shapes: &[Vec<CollisionShape>; URDF_LINK_COUNT],
    model: &RobotModel,
    q: &JointsDeg,
) -> Vec<(usize, usize)> {
    let frames = model.link_frames(&q.to_rad());
    let placed: Vec<Vec<Placed>> = shapes
        .iter()
        .zip(frames.iter())
        .map(|(list, frame)| list.iter().map(|s| place(frame, s)).collect())
        .collect();
    let mut out = Vec::new();
    for i in 0..URDF_LINK_COUNT {
        for j in i + 1..URDF_LINK_COUNT {
            let touch = placed[i]
                .iter()
                .any(|x| placed[j].iter().any(|y| shapes_touch(x, y)));
            if touch {
                out.push((i, j));
            }
        }
    }
    out
}

/// Counts, for every pair of links, the configurations among `samples` (drawn uniformly within
/// the joint ranges from `seed`) in which they collide.
pub fn sample_self_collisions(
    model: &RobotModel,
    samples: usize,
    seed: u64,
) -> SelfCollisionCounts {
    let shapes = model.collision_shapes();
    let mut rng = SplitMix64(seed);
    let mut hits = [[0usize; URDF_LINK_COUNT]; URDF_LINK_COUNT];
    for _ in 0..samples {
        let q = JointsDeg::new(std::array::from_fn(|j| {
            let spec = &model.joints[j];
            spec.min_deg + (spec.max_deg - spec.min_deg) * rng.next_unit()
        }));
        for (i, j) in colliding_with(&shapes, model, &q) {
            hits[i][j] += 1;
        }
    }
    SelfCollisionCounts { samples, hits }
}

/// The pairs MoveIt need not check, from the sampled counts (see the
/// [module documentation](self)). Pairs where a link has no collision shape are left out.
pub fn disabled_pairs(model: &RobotModel, counts: &SelfCollisionCounts) -> Vec<DisabledPair> {
    let shapes = model.collision_shapes();
    let mut out = Vec::new();
    for i in 0..URDF_LINK_COUNT {
        for j in i + 1..URDF_LINK_COUNT {
            if shapes[i].is_empty() || shapes[j].is_empty() {
                continue;
            }
            let hits = counts.hits[i][j];
            let reason = if adjacent(i, j) {
                DisableReason::Adjacent
            } else if hits == 0 {
                DisableReason::Never
            } else if hits == counts.samples {
                DisableReason::Always
            } else {
                continue;
            };
            out.push(DisabledPair {
                first: i,
                second: j,
                reason,
            });
        }
    }
    out
}

/// The SRDF of `model` with the given joint names (JT1 first), with the self-collision matrix
/// of [`SELF_COLLISION_SAMPLES`] samples from [`SELF_COLLISION_SEED`].
///
/// ```
/// let model = fs020n_kin::RobotModel::fs020n();
/// let names = std::array::from_fn(|i| format!("joint_{}", i + 1));
/// let srdf = fs020n_ros2::srdf::generate(&model, &names);
/// assert!(srdf.contains(r#"<chain base_link="base_link" tip_link="flange"/>"#));
/// assert!(srdf.contains(r#"<disable_collisions link1="base_link" link2="link_1" reason="Adjacent"/>"#));
/// ```
pub fn generate(model: &RobotModel, joint_names: &[String; JOINT_COUNT]) -> String {
    let counts = sample_self_collisions(model, SELF_COLLISION_SAMPLES, SELF_COLLISION_SEED);
    generate_with(model, joint_names, &counts)
}

/// [`generate`] with self-collision counts sampled by the caller
/// ([`sample_self_collisions`]; the seed named in the SRDF's comment is
/// [`SELF_COLLISION_SEED`]).
pub fn generate_with(
    model: &RobotModel,
    joint_names: &[String; JOINT_COUNT],
    counts: &SelfCollisionCounts,
) -> String {
    let pairs = disabled_pairs(model, counts);
    let mut out = format!(
        "<?xml version=\"1.0\"?>\n<!-- MoveIt's semantic description of the arm, generated by fs020n \
         from the robot model \"{}\". Self-collision matrix: {} configurations sampled uniformly \
         within the joint ranges (seed {}) on the URDF's collision shapes. -->\n\
         <robot name=\"fs020n\">\n  <group name=\"manipulator\">\n    \
         <chain base_link=\"base_link\" tip_link=\"flange\"/>\n  </group>\n",
        xml_escape(model.name()),
        counts.samples,
        SELF_COLLISION_SEED,
    );
    for (state, q) in [("home", model.home), ("zero", JointsDeg::ZERO)] {
        let _ = writeln!(
            out,
            "  <group_state name=\"{state}\" group=\"manipulator\">"
        );
        for (name, deg) in joint_names.iter().zip(q.iter()) {
            let _ = writeln!(
                out,
                "    <joint name=\"{}\" value=\"{}\"/>",
                xml_escape(name),
                deg.to_radians()
            );
        }
        out.push_str("  </group_state>\n");
    }
    for p in &pairs {
        let _ = writeln!(
            out,
            "  <disable_collisions link1=\"{}\" link2=\"{}\" reason=\"{}\"/>",
            URDF_LINK_NAMES[p.first],
            URDF_LINK_NAMES[p.second],
            p.reason.as_str()
        );
    }
    out.push_str("</robot>\n");
    out
}

fn xml_escape(s: &str) -> String {
    s.chars()
        .map(|c| match c {
            '&' => "&amp;".to_owned(),
            '<' => "&lt;".to_owned(),
            '>' => "&gt;".to_owned(),
            '"' => "&quot;".to_owned(),
            '\'' => "&apos;".to_owned(),
            c if c.is_control() => " ".to_owned(),
            c => c.to_string(),
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn segment_distances_cover_parallel_crossing_and_point_cases() {
        let d = |p1, p2, q1, q2| segment_distance_sq(p1, p2, q1, q2).sqrt();
        // Crossing at right angles, 1 apart in Z.
        assert!(
            (d(
                [-1.0, 0.0, 0.0],
                [1.0, 0.0, 0.0],
                [0.0, -1.0, 1.0],
                [0.0, 1.0, 1.0]
            ) - 1.0)
                .abs()
                < 1e-12
        );
        // Parallel, overlapping, 2 apart.
        assert!(
            (d([0.0; 3], [0.0, 0.0, 1.0], [2.0, 0.0, 0.5], [2.0, 0.0, 3.0]) - 2.0).abs() < 1e-12
        );
        // Collinear, end to end with a gap of 0.5.
        assert!(
            (d([0.0; 3], [0.0, 0.0, 1.0], [0.0, 0.0, 1.5], [0.0, 0.0, 2.0]) - 0.5).abs() < 1e-12
        );
        // Beside a cylinder, above its top, and inside it.
        let c = Placed {
            a: [0.0; 3],
            b: [0.0, 0.0, 1.0],
            radius: 0.5,
            flat_ends: true,
        };
        assert!((cylinder_distance(&c, [2.0, 0.0, 0.5]) - 1.5).abs() < 1e-12);
        assert!((cylinder_distance(&c, [0.3, 0.0, 3.0]) - 2.0).abs() < 1e-12);
        assert!((cylinder_distance(&c, [0.8, 0.0, 1.4]) - 0.5).abs() < 1e-12);
        assert_eq!(cylinder_distance(&c, [0.1, 0.1, 0.5]), 0.0);
        // A segment passing over the top, 0.25 above its rim.
        let s = segment_cylinder_distance(&c, [-2.0, 0.0, 1.25], [2.0, 0.0, 1.25]);
        assert!((s - 0.25).abs() < 1e-9, "{s}");
        // A slanted segment whose nearest point is inside the span.
        let s = segment_cylinder_distance(&c, [1.0, 0.0, -1.0], [1.0, 0.0, 2.0]);
        assert!((s - 0.5).abs() < 1e-9, "{s}");
        // Two points.
        assert!((d([0.0; 3], [0.0; 3], [3.0, 4.0, 0.0], [3.0, 4.0, 0.0]) - 5.0).abs() < 1e-12);
        // A point and a segment, beyond its end.
        assert!(
            (d([0.0, 0.0, 3.0], [0.0, 0.0, 3.0], [0.0; 3], [0.0, 0.0, 1.0]) - 2.0).abs() < 1e-12
        );
    }

    #[test]
    fn the_generator_is_fixed() {
        let mut a = SplitMix64(SELF_COLLISION_SEED);
        let mut b = SplitMix64(SELF_COLLISION_SEED);
        for _ in 0..100 {
            let x = a.next_unit();
            assert!((0.0..1.0).contains(&x));
            assert_eq!(x.to_bits(), b.next_unit().to_bits());
        }
    }
}
