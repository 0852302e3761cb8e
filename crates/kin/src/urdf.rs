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

use std::fmt::Write;

use crate::model::RobotModel;

/// Names of the six joints in the URDF and in joint-state messages.
pub const URDF_JOINT_NAMES: [&str; 6] = [
    "joint_1", "joint_2", "joint_3", "joint_4", "joint_5", "joint_6",
];

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

impl RobotModel {
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
        // Link radius: a tenth of the upper arm, at least 2 cm.
        let r = (g.upper_arm_m / 10.0).max(0.02);
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
        // Links and their visuals.
        out.push_str("  <link name=\"base_link\">\n");
        cylinder(&mut out, 0.05, r * 2.5, "base");
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
        out.push_str("  </link>\n  <link name=\"link_2\">\n");
        cylinder(&mut out, g.upper_arm_m, r, "arm");
        out.push_str("  </link>\n  <link name=\"link_3\">\n");
        cylinder(&mut out, g.forearm_m, r * 0.8, "arm");
        out.push_str("  </link>\n  <link name=\"link_4\">\n");
        sphere(&mut out, r * 0.9, "wrist");
        out.push_str("  </link>\n  <link name=\"link_5\"/>\n  <link name=\"link_6\">\n");
        cylinder(&mut out, g.flange_m, r * 0.6, "wrist");
        out.push_str("  </link>\n  <link name=\"flange\"/>\n  <link name=\"tool0\"/>\n");
        // Joints.
        let origins = [
            (0.0, 0.0, 0.0),
            (g.shoulder_offset_m, 0.0, g.base_height_m),
            (0.0, 0.0, g.upper_arm_m),
            (0.0, 0.0, g.forearm_m),
            (0.0, 0.0, 0.0),
            (0.0, 0.0, 0.0),
        ];
        let axes = ["0 0 1", "0 1 0", "0 -1 0", "0 0 1", "0 -1 0", "0 0 1"];
        let parents = [
            "base_link",
            "link_1",
            "link_2",
            "link_3",
            "link_4",
            "link_5",
        ];
        let children = ["link_1", "link_2", "link_3", "link_4", "link_5", "link_6"];
        for i in 0..6 {
            let spec = &self.joints[i];
            let (x, y, z) = origins[i];
            let _ = write!(
                out,
                "  <joint name=\"{}\" type=\"revolute\">\n    \
                 <parent link=\"{}\"/><child link=\"{}\"/>\n    \
                 <origin xyz=\"{x} {y} {z}\" rpy=\"0 0 0\"/>\n    \
                 <axis xyz=\"{}\"/>\n    \
                 <limit lower=\"{}\" upper=\"{}\" effort=\"0\" velocity=\"{}\"/>\n  </joint>\n",
                xml_escape(joint_names[i].as_ref()),
                parents[i],
                children[i],
                axes[i],
                spec.min_deg.to_radians(),
                spec.max_deg.to_radians(),
                spec.max_speed_deg_s.to_radians(),
            );
        }
        let _ = write!(
            out,
            "  <joint name=\"flange_joint\" type=\"fixed\">\n    \
             <parent link=\"link_6\"/><child link=\"flange\"/>\n    \
             <origin xyz=\"0 0 {}\" rpy=\"0 0 0\"/>\n  </joint>\n  \
             <joint name=\"tool0_joint\" type=\"fixed\">\n    \
             <parent link=\"flange\"/><child link=\"tool0\"/>\n    \
             <origin xyz=\"0 0 0\" rpy=\"0 0 0\"/>\n  </joint>\n</robot>\n",
            g.flange_m
        );
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
}
