//! A URDF description of the arm, generated from the robot model: what ROS tools, Foxglove's 3D
//! panel and RViz need to draw the arm from joint states.
//!
//! The kinematic chain is exactly the one of [`RobotModel::forward`] (see
//! `docs/KINEMATICS.md`):
//!
//! ```text
//! joint_1  at (0, 0, 0)                 about +Z
//! joint_2  at (shoulder_offset, 0, base_height)   about +Y
//! joint_3  at (0, 0, upper_arm)          about −Y   (negative turns the forearm forward/down)
//! joint_4  at (0, 0, forearm)            about +Z   (at the wrist centre: same motion of the flange)
//! joint_5  at (0, 0, 0)                  about −Y
//! joint_6  at (0, 0, 0)                  about +Z
//! flange   at (0, 0, flange)             fixed;  tool0 = flange (ROS-Industrial name)
//! ```
//!
//! Joint names are `joint_1` … `joint_6`, links `base_link`, `link_1` … `link_6`, `flange` and
//! `tool0`. Limits come from the model's ranges (radians) and maximum speeds (rad/s); the model
//! has no torque data, so `effort` is 0. Link visuals are plain cylinders and spheres sized from
//! the geometry (no meshes: the arm is drawn from the model file alone).
//!
//! ## Collision geometry
//!
//! Every link that carries a part of the arm (`base_link`, `link_1` … `link_6`, `flange`) has
//! collision geometry, [`RobotModel::collision_shapes`]: capsules (a cylinder with a sphere at
//! each end, written to the URDF as those three primitives, which MoveIt and every URDF reader
//! understand) and flat-ended cylinders where the arm meets a plane (the base on its mounting
//! face, the flange where a tool is bolted). `tool0` is a frame without a body.
//!
//! The model file has lengths but no cross-sections, so the radii are **estimates scaled from
//! the lengths, chosen generous**: every collision shape encloses the link's visual with a
//! margin (tested), the upper arm's radius is 18 % of its length (0.144 m on the FS020N), the
//! forearm reaches 20 % of its length behind the elbow (where the wrist motors sit on arms of
//! this class). A planner that keeps these shapes apart keeps the arm apart; it may refuse
//! paths that would have just passed. Measure your arm if you plan close to obstacles.
//! [`RobotModel::link_frames`] places the links for collision checks (self-collision sampling
//! for MoveIt's SRDF).

use std::fmt::Write;

use nalgebra::{Isometry3, Translation3, Unit, UnitQuaternion, Vector3};

use crate::model::RobotModel;
use crate::pose::Pose;
use fs020n_proto::JointsRad;

/// Names of the six joints in the URDF and in joint-state messages.
pub const URDF_JOINT_NAMES: [&str; 6] = [
    "joint_1", "joint_2", "joint_3", "joint_4", "joint_5", "joint_6",
];

/// Names of the URDF's links, root first: index `i + 1` is the child of joint `i`; `flange` and
/// `tool0` hang from fixed joints (`flange_joint`, `tool0_joint`).
pub const URDF_LINK_NAMES: [&str; 9] = [
    "base_link",
    "link_1",
    "link_2",
    "link_3",
    "link_4",
    "link_5",
    "link_6",
    "flange",
    "tool0",
];

/// Number of links in the URDF ([`URDF_LINK_NAMES`]).
pub const URDF_LINK_COUNT: usize = URDF_LINK_NAMES.len();

/// A joint of the URDF: parent and child (indices into [`URDF_LINK_NAMES`]), origin in the
/// parent's frame (metres), axis (revolute) or none (fixed).
struct JointRow {
    parent: usize,
    child: usize,
    origin_m: [f64; 3],
    axis: Option<[f64; 3]>,
}

/// The URDF's joints: the six revolute joints, then `flange_joint` and `tool0_joint`.
fn joint_table(model: &RobotModel) -> [JointRow; 8] {
    let g = &model.geometry;
    let row = |parent: usize, origin_m: [f64; 3], axis: Option<[f64; 3]>| JointRow {
        parent,
        child: parent + 1,
        origin_m,
        axis,
    };
    [
        row(0, [0.0, 0.0, 0.0], Some([0.0, 0.0, 1.0])),
        row(
            1,
            [g.shoulder_offset_m, 0.0, g.base_height_m],
            Some([0.0, 1.0, 0.0]),
        ),
        row(2, [0.0, 0.0, g.upper_arm_m], Some([0.0, -1.0, 0.0])),
        row(3, [0.0, 0.0, g.forearm_m], Some([0.0, 0.0, 1.0])),
        row(4, [0.0, 0.0, 0.0], Some([0.0, -1.0, 0.0])),
        row(5, [0.0, 0.0, 0.0], Some([0.0, 0.0, 1.0])),
        row(6, [0.0, 0.0, g.flange_m], None),
        row(7, [0.0, 0.0, 0.0], None),
    ]
}

/// A collision shape of a link, in the link's frame: the solid within `radius_m` of the segment
/// `from_m` → `to_m` (a capsule; a sphere when both ends coincide), or with `flat_ends` the
/// cylinder of that segment and radius (which the capsule of the same segment and radius
/// encloses: checks made on capsules are conservative for it).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CollisionShape {
    /// One end of the axis, metres.
    pub from_m: [f64; 3],
    /// The other end of the axis, metres.
    pub to_m: [f64; 3],
    /// Radius, metres (> 0).
    pub radius_m: f64,
    /// A flat-ended cylinder instead of a capsule.
    pub flat_ends: bool,
}

impl CollisionShape {
    fn capsule(from_m: [f64; 3], to_m: [f64; 3], radius_m: f64) -> CollisionShape {
        CollisionShape {
            from_m,
            to_m,
            radius_m,
            flat_ends: false,
        }
    }

    fn cylinder(from_m: [f64; 3], to_m: [f64; 3], radius_m: f64) -> CollisionShape {
        CollisionShape {
            flat_ends: true,
            ..CollisionShape::capsule(from_m, to_m, radius_m)
        }
    }
}

/// Radius of the visual cylinders: a tenth of the upper arm, at least 2 cm.
fn visual_radius_m(model: &RobotModel) -> f64 {
    (model.geometry.upper_arm_m / 10.0).max(0.02)
}

/// Escapes text for an XML attribute value.
fn xml_escape(s: &str) -> String {
    let mut out = String::with_capacity(s.len());
    for c in s.chars() {
        match c {
            '&' => out.push_str("&amp;"),
            '<' => out.push_str("&lt;"),
            '>' => out.push_str("&gt;"),
            '"' => out.push_str("&quot;"),
            '\'' => out.push_str("&apos;"),
            c if c.is_control() => out.push(' '),
            c => out.push(c),
        }
    }
    out
}

/// A cylinder of `length` along the link's Z axis, from its origin.
fn cylinder(out: &mut String, length: f64, radius: f64, colour: &str) {
    if length <= 0.0 {
        return;
    }
    let z = length / 2.0;
    let _ = write!(
        out,
        "    <visual>\n      <origin xyz=\"0 0 {z}\" rpy=\"0 0 0\"/>\n      \
         <geometry><cylinder radius=\"{radius}\" length=\"{length}\"/></geometry>\n      \
         <material name=\"{colour}\"/>\n    </visual>\n"
    );
}

fn sphere(out: &mut String, radius: f64, colour: &str) {
    let _ = write!(
        out,
        "    <visual>\n      <origin xyz=\"0 0 0\" rpy=\"0 0 0\"/>\n      \
         <geometry><sphere radius=\"{radius}\"/></geometry>\n      \
         <material name=\"{colour}\"/>\n    </visual>\n"
    );
}

/// Writes `shape` as URDF `<collision>` elements: a cylinder, and for a capsule a sphere at
/// each end.
fn write_collision(out: &mut String, shape: &CollisionShape) {
    let [ax, ay, az] = shape.from_m;
    let [bx, by, bz] = shape.to_m;
    let (dx, dy, dz) = (bx - ax, by - ay, bz - az);
    let length = (dx * dx + dy * dy + dz * dz).sqrt();
    let r = shape.radius_m;
    let mut element = |xyz: [f64; 3], rpy: [f64; 3], geometry: String| {
        let _ = write!(
            out,
            "    <collision>\n      <origin xyz=\"{} {} {}\" rpy=\"{} {} {}\"/>\n      \
             <geometry>{geometry}</geometry>\n    </collision>\n",
            xyz[0], xyz[1], xyz[2], rpy[0], rpy[1], rpy[2]
        );
    };
    if length > 0.0 {
        // URDF's rpy is Rz(yaw) · Ry(pitch) · Rx(roll): this pitch and yaw turn the cylinder's
        // Z axis onto the segment.
        let pitch = dx.hypot(dy).atan2(dz);
        let yaw = if dx == 0.0 && dy == 0.0 {
            0.0
        } else {
            dy.atan2(dx)
        };
        element(
            [(ax + bx) / 2.0, (ay + by) / 2.0, (az + bz) / 2.0],
            [0.0, pitch, yaw],
            format!("<cylinder radius=\"{r}\" length=\"{length}\"/>"),
        );
    }
    if !shape.flat_ends {
        element(shape.from_m, [0.0; 3], format!("<sphere radius=\"{r}\"/>"));
        if length > 0.0 {
            element(shape.to_m, [0.0; 3], format!("<sphere radius=\"{r}\"/>"));
        }
    }
}

impl RobotModel {
    /// The collision shapes of each link of the URDF (index as in [`URDF_LINK_NAMES`]), in
    /// the link's frame; see the [module documentation](crate::urdf#collision-geometry).
    /// `tool0` has none (a frame: a tool gets its own geometry).
    ///
    /// ```
    /// let shapes = fs020n_kin::RobotModel::fs020n().collision_shapes();
    /// assert!(shapes[..8].iter().all(|s| !s.is_empty()));
    /// assert!(shapes[8].is_empty());
    /// ```
    pub fn collision_shapes(&self) -> [Vec<CollisionShape>; URDF_LINK_COUNT] {
        let g = &self.geometry;
        let (h, s, u, f, fl) = (
            g.base_height_m,
            g.shoulder_offset_m,
            g.upper_arm_m,
            g.forearm_m,
            g.flange_m,
        );
        let z = |z: f64| [0.0, 0.0, z];
        // Radii from the lengths (see the module documentation), never below the visuals'.
        let rv = visual_radius_m(self);
        let r_base = (0.7 * h).max(s + 0.2 * u).max(2.5 * rv + 0.02);
        let r_column = (0.5 * h).max(1.6 * rv + 0.02);
        let r_shoulder = (0.2 * u).max(1.2 * rv + 0.02);
        let r_upper = (0.18 * u).max(rv + 0.02);
        let r_fore = (0.16 * f).max(0.8 * rv + 0.02);
        let r_wrist = (0.15 * f).max(0.9 * rv + 0.02);
        let r_flange = (0.09 * f).max(0.6 * rv + 0.02);
        [
            // The base standing on its mounting face.
            vec![CollisionShape::cylinder(z(0.0), z(0.4 * h), r_base)],
            // The turning column up to JT2, and the shoulder housing around JT2's axis.
            vec![
                CollisionShape::cylinder(z(0.0), z(h), r_column),
                CollisionShape::capsule(z(h), [s, 0.0, h], r_shoulder),
                CollisionShape::capsule([s, -0.1 * u, h], [s, 0.1 * u, h], r_shoulder),
            ],
            // The upper arm, JT2 to JT3.
            vec![CollisionShape::capsule(z(0.0), z(u), r_upper)],
            // The forearm from behind the elbow (motors) to the wrist centre.
            vec![CollisionShape::capsule(z(-0.2 * f), z(f), r_fore)],
            // The wrist around its centre.
            vec![CollisionShape::capsule(z(-0.1 * f), z(0.0), r_wrist)],
            vec![CollisionShape::capsule(z(0.0), z(0.0), r_wrist)],
            // The flange roll to the flange face.
            vec![CollisionShape::cylinder(z(0.0), z(fl.max(0.01)), r_flange)],
            // The flange plate, behind the flange face.
            vec![CollisionShape::cylinder(z(-0.01), z(0.0), r_flange)],
            Vec::new(),
        ]
    }

    /// The pose of every link's frame in the base frame at joints `q` (index as in
    /// [`URDF_LINK_NAMES`]), by the URDF's own joint table: `flange` is
    /// [`RobotModel::forward`] (tested).
    ///
    /// ```
    /// let m = fs020n_kin::RobotModel::fs020n();
    /// let q = m.home.to_rad();
    /// let frames = m.link_frames(&q);
    /// assert!(frames[7].distance_m(&m.forward(&q)) < 1e-12);
    /// ```
    pub fn link_frames(&self, q: &JointsRad) -> [Pose; URDF_LINK_COUNT] {
        let mut frames = [Isometry3::identity(); URDF_LINK_COUNT];
        for (i, row) in joint_table(self).iter().enumerate() {
            let [x, y, z] = row.origin_m;
            let mut local =
                Isometry3::from_parts(Translation3::new(x, y, z), UnitQuaternion::identity());
            if let Some([ax, ay, az]) = row.axis {
                let axis = Unit::new_normalize(Vector3::new(ax, ay, az));
                local *= UnitQuaternion::from_axis_angle(&axis, q.0[i]);
            }
            frames[row.child] = frames[row.parent] * local;
        }
        frames.map(Pose)
    }

    /// The arm as a URDF document (see the [module documentation](crate::urdf)): six revolute
    /// joints `joint_1` … `joint_6` with the model's ranges and speeds, links with simple
    /// cylinder visuals, and the `flange`/`tool0` frames. Forward kinematics of this URDF equal
    /// [`RobotModel::forward`].
    ///
    /// ```
    /// let urdf = fs020n_kin::RobotModel::fs020n().to_urdf();
    /// assert!(urdf.contains(r#"<joint name="joint_3" type="revolute">"#));
    /// assert!(urdf.contains(r#"<axis xyz="0 -1 0"/>"#));
    /// ```
    pub fn to_urdf(&self) -> String {
        self.to_urdf_named(&URDF_JOINT_NAMES)
    }

    /// [`RobotModel::to_urdf`] with other joint names (JT1 first), e.g. those a ROS
    /// configuration uses. Names are escaped for XML.
    ///
    /// ```
    /// let urdf = fs020n_kin::RobotModel::fs020n().to_urdf_named(&["a1", "a2", "a3", "a4", "a5", "a6"]);
    /// assert!(urdf.contains(r#"<joint name="a6" type="revolute">"#));
    /// ```
    pub fn to_urdf_named<S: AsRef<str>>(&self, joint_names: &[S; 6]) -> String {
        let g = &self.geometry;
        let r = visual_radius_m(self);
        let shapes = self.collision_shapes();
        let mut out = String::new();
        let _ = write!(
            out,
            "<?xml version=\"1.0\"?>\n<!-- Generated from the robot model \"{}\" by fs020n-kin. \
             Joint limits: the model's ranges and maximum speeds; effort 0 (no torque data). -->\n\
             <robot name=\"fs020n\">\n  \
             <material name=\"base\"><color rgba=\"0.25 0.25 0.28 1\"/></material>\n  \
             <material name=\"arm\"><color rgba=\"0.95 0.6 0.1 1\"/></material>\n  \
             <material name=\"wrist\"><color rgba=\"0.3 0.3 0.33 1\"/></material>\n",
            xml_escape(&self.name)
        );
        // Links: visuals, then collision shapes.
        let collisions = |out: &mut String, link: usize| {
            for shape in &shapes[link] {
                write_collision(out, shape);
            }
        };
        out.push_str("  <link name=\"base_link\">\n");
        cylinder(&mut out, 0.05, r * 2.5, "base");
        collisions(&mut out, 0);
        out.push_str("  </link>\n  <link name=\"link_1\">\n");
        cylinder(&mut out, g.base_height_m, r * 1.6, "arm");
        // The shoulder offset, at the height of JT2.
        if g.shoulder_offset_m > 0.0 {
            let _ = write!(
                out,
                "    <visual>\n      <origin xyz=\"{} 0 {}\" rpy=\"0 {} 0\"/>\n      \
                 <geometry><cylinder radius=\"{}\" length=\"{}\"/></geometry>\n      \
                 <material name=\"arm\"/>\n    </visual>\n",
                g.shoulder_offset_m / 2.0,
                g.base_height_m,
                std::f64::consts::FRAC_PI_2,
                r * 1.2,
                g.shoulder_offset_m
            );
        }
        collisions(&mut out, 1);
        out.push_str("  </link>\n  <link name=\"link_2\">\n");
        cylinder(&mut out, g.upper_arm_m, r, "arm");
        collisions(&mut out, 2);
        out.push_str("  </link>\n  <link name=\"link_3\">\n");
        cylinder(&mut out, g.forearm_m, r * 0.8, "arm");
        collisions(&mut out, 3);
        out.push_str("  </link>\n  <link name=\"link_4\">\n");
        sphere(&mut out, r * 0.9, "wrist");
        collisions(&mut out, 4);
        out.push_str("  </link>\n  <link name=\"link_5\">\n");
        collisions(&mut out, 5);
        out.push_str("  </link>\n  <link name=\"link_6\">\n");
        cylinder(&mut out, g.flange_m, r * 0.6, "wrist");
        collisions(&mut out, 6);
        out.push_str("  </link>\n  <link name=\"flange\">\n");
        collisions(&mut out, 7);
        out.push_str("  </link>\n  <link name=\"tool0\"/>\n");
        // Joints.
        let fmt3 = |v: [f64; 3]| format!("{} {} {}", v[0], v[1], v[2]);
        for (i, row) in joint_table(self).iter().enumerate() {
            let origin = fmt3(row.origin_m);
            let (parent, child) = (URDF_LINK_NAMES[row.parent], URDF_LINK_NAMES[row.child]);
            match (row.axis, self.joints.get(i), joint_names.get(i)) {
                (Some(axis), Some(spec), Some(name)) => {
                    let _ = write!(
                        out,
                        "  <joint name=\"{}\" type=\"revolute\">\n    \
                         <parent link=\"{parent}\"/><child link=\"{child}\"/>\n    \
                         <origin xyz=\"{origin}\" rpy=\"0 0 0\"/>\n    \
                         <axis xyz=\"{}\"/>\n    \
                         <limit lower=\"{}\" upper=\"{}\" effort=\"0\" velocity=\"{}\"/>\n  </joint>\n",
                        xml_escape(name.as_ref()),
                        fmt3(axis),
                        spec.min_deg.to_radians(),
                        spec.max_deg.to_radians(),
                        spec.max_speed_deg_s.to_radians(),
                    );
                }
                _ => {
                    let _ = write!(
                        out,
                        "  <joint name=\"{child}_joint\" type=\"fixed\">\n    \
                         <parent link=\"{parent}\"/><child link=\"{child}\"/>\n    \
                         <origin xyz=\"{origin}\" rpy=\"0 0 0\"/>\n  </joint>\n"
                    );
                }
            }
        }
        out.push_str("</robot>\n");
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_are_escaped() {
        assert_eq!(xml_escape("a&b<\"c\">"), "a&amp;b&lt;&quot;c&quot;&gt;");
        let mut m = RobotModel::fs020n();
        m.name = "evil --> <robot>".into();
        let urdf = m.to_urdf();
        assert!(!urdf.contains("<robot>"));
        assert_eq!(urdf.matches("<robot ").count(), 1);
    }

    #[test]
    fn other_joint_names() {
        let urdf = RobotModel::fs020n().to_urdf_named(&["a&1", "b", "c", "d", "e", "f"]);
        assert!(urdf.contains(r#"<joint name="a&amp;1" type="revolute">"#));
        assert!(!urdf.contains("joint_1"));
    }

    #[test]
    fn limits_are_in_radians() {
        let urdf = RobotModel::fs020n().to_urdf();
        let lower = (-160.0f64).to_radians();
        assert!(urdf.contains(&format!("lower=\"{lower}\"")), "{urdf}");
        let v = 610.0f64.to_radians();
        assert!(urdf.contains(&format!("velocity=\"{v}\"")));
    }

    #[test]
    fn link_frames_put_the_flange_where_forward_kinematics_does() {
        let m = RobotModel::fs020n();
        for deg in [
            [0.0; 6],
            [0.0, 0.0, -90.0, 0.0, -90.0, 0.0],
            [30.0, 20.0, -60.0, 10.0, -45.0, 90.0],
            [-150.0, 130.0, 110.0, -260.0, 140.0, -350.0],
        ] {
            let q = crate::JointsDeg::new(deg).to_rad();
            let frames = m.link_frames(&q);
            let fk = m.forward(&q);
            assert!(frames[7].distance_m(&fk) < 1e-12, "{deg:?}");
            assert!(frames[7].angle_to_rad(&fk) < 1e-9, "{deg:?}");
            assert!(frames[8].distance_m(&fk) < 1e-12);
            assert_eq!(frames[0], Pose(Isometry3::identity()));
        }
    }

    #[test]
    fn every_link_but_tool0_has_collision_shapes_with_positive_radii() {
        let urdf = RobotModel::fs020n().to_urdf();
        for (name, shapes) in URDF_LINK_NAMES
            .iter()
            .zip(RobotModel::fs020n().collision_shapes())
        {
            assert_eq!(shapes.is_empty(), *name == "tool0", "{name}");
            assert!(shapes
                .iter()
                .all(|s| s.radius_m > 0.0 && s.radius_m.is_finite()));
            let start = urdf.find(&format!("<link name=\"{name}\"")).unwrap();
            let body = &urdf[start..];
            let body = &body[..body.find("</link>").unwrap_or(body.len())];
            assert_eq!(body.contains("<collision>"), *name != "tool0", "{name}");
        }
    }
}
