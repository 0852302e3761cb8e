//! MoveIt's robot files: the URDF's collision shapes enclose its visuals, the SRDF names the
//! URDF's links and joints (read back by `urdf-rs`), its self-collision matrix is reproducible
//! and leaves the home and zero states collision-free while still catching the arm folding into
//! its base, and the configuration package holds every file MoveIt needs.
#![allow(clippy::expect_used)] // test code: a failed expectation is a failed test

use fs020n_kin::{JointsDeg, RobotModel};
use std::sync::OnceLock;

use fs020n_ros2::srdf::{
    colliding_pairs, disabled_pairs, generate_with, sample_self_collisions, DisableReason,
    SelfCollisionCounts, SELF_COLLISION_SAMPLES, SELF_COLLISION_SEED,
};
use fs020n_ros2::NodeConfig;

/// The model's self-collision counts as `srdf::generate` samples them (sampled once: a few
/// seconds in a debug build).
fn counts() -> &'static SelfCollisionCounts {
    static COUNTS: OnceLock<SelfCollisionCounts> = OnceLock::new();
    COUNTS.get_or_init(|| {
        sample_self_collisions(
            &RobotModel::fs020n(),
            SELF_COLLISION_SAMPLES,
            SELF_COLLISION_SEED,
        )
    })
}

fn srdf_of(names: &[String; 6]) -> String {
    generate_with(&RobotModel::fs020n(), names, counts())
}

fn names() -> [String; 6] {
    std::array::from_fn(|i| format!("joint_{}", i + 1))
}

/// The values of attribute `attr` of every `<tag …>` in `xml`.
fn attributes(xml: &str, tag: &str, attr: &str) -> Vec<String> {
    xml.split(&format!("<{tag} "))
        .skip(1)
        .filter_map(|rest| {
            let element = &rest[..rest.find('>')?];
            let start = element.find(&format!("{attr}=\""))? + attr.len() + 2;
            let len = element[start..].find('"')?;
            Some(element[start..start + len].to_owned())
        })
        .collect()
}

fn rotate(rpy: [f64; 3], v: [f64; 3]) -> [f64; 3] {
    // URDF: R = Rz(yaw) · Ry(pitch) · Rx(roll).
    let (sr, cr) = rpy[0].sin_cos();
    let (sp, cp) = rpy[1].sin_cos();
    let (sy, cy) = rpy[2].sin_cos();
    let x = [v[0], cr * v[1] - sr * v[2], sr * v[1] + cr * v[2]];
    let y = [cp * x[0] + sp * x[2], x[1], -sp * x[0] + cp * x[2]];
    [cy * y[0] - sy * y[1], sy * y[0] + cy * y[1], y[2]]
}

/// `p` is inside `shape` (plus 1e-9).
fn inside(shape: &fs020n_kin::urdf::CollisionShape, p: [f64; 3]) -> bool {
    let (a, b) = (shape.from_m, shape.to_m);
    let d = [b[0] - a[0], b[1] - a[1], b[2] - a[2]];
    let r = [p[0] - a[0], p[1] - a[1], p[2] - a[2]];
    let len_sq = d.iter().map(|v| v * v).sum::<f64>();
    let t = if len_sq > 0.0 {
        r.iter().zip(d).map(|(x, y)| x * y).sum::<f64>() / len_sq
    } else {
        0.0
    };
    if shape.flat_ends && !(-1e-9..=1.0 + 1e-9).contains(&t) {
        return false;
    }
    let t = t.clamp(0.0, 1.0);
    let dist_sq: f64 = (0..3).map(|i| (r[i] - d[i] * t).powi(2)).sum();
    dist_sq.sqrt() <= shape.radius_m + 1e-9
}

#[test]
fn every_visual_is_inside_its_links_collision_shapes() {
    let model = RobotModel::fs020n();
    let robot = urdf_rs::read_from_string(&fs020n_ros2::urdf::generate(&model, &names()))
        .expect("the URDF parses");
    let shapes = model.collision_shapes();
    let mut checked = 0;
    for link in &robot.links {
        let i = fs020n_kin::urdf::URDF_LINK_NAMES
            .iter()
            .position(|n| *n == link.name)
            .expect("a known link");
        for visual in &link.visual {
            let o = &visual.origin;
            let (xyz, rpy) = (
                [o.xyz[0], o.xyz[1], o.xyz[2]],
                [o.rpy[0], o.rpy[1], o.rpy[2]],
            );
            let mut surface = Vec::new();
            for k in 0..24 {
                let th = k as f64 * std::f64::consts::TAU / 24.0;
                match &visual.geometry {
                    urdf_rs::Geometry::Cylinder { radius, length } => {
                        for z in [-0.5, -0.25, 0.0, 0.25, 0.5] {
                            surface.push([radius * th.cos(), radius * th.sin(), z * length]);
                        }
                    }
                    urdf_rs::Geometry::Sphere { radius } => {
                        for ph in [0.0, 0.5, 1.0, 1.5, 2.0, 2.5, std::f64::consts::PI] {
                            surface.push([
                                radius * ph.sin() * th.cos(),
                                radius * ph.sin() * th.sin(),
                                radius * ph.cos(),
                            ]);
                        }
                    }
                    other => panic!("unexpected visual {other:?}"),
                }
            }
            for p in surface {
                let v = rotate(rpy, p);
                let q = [v[0] + xyz[0], v[1] + xyz[1], v[2] + xyz[2]];
                assert!(
                    shapes[i].iter().any(|s| inside(s, q)),
                    "{}: visual point {q:?} outside the collision shapes",
                    link.name
                );
                checked += 1;
            }
        }
    }
    assert!(checked > 500, "{checked}");
}

#[test]
fn every_link_but_the_tool_frame_has_collision_geometry() {
    let robot = urdf_rs::read_from_string(&fs020n_ros2::urdf::generate(
        &RobotModel::fs020n(),
        &names(),
    ))
    .expect("the URDF parses");
    assert_eq!(robot.links.len(), 9);
    for link in &robot.links {
        assert_eq!(
            link.collision.is_empty(),
            link.name == "tool0",
            "{}",
            link.name
        );
    }
}

#[test]
fn the_srdf_names_the_urdfs_links_and_joints() {
    let model = RobotModel::fs020n();
    let robot = urdf_rs::read_from_string(&fs020n_ros2::urdf::generate(&model, &names()))
        .expect("the URDF parses");
    let srdf = srdf_of(&names());
    let links: Vec<&str> = robot.links.iter().map(|l| l.name.as_str()).collect();
    let joints: Vec<&str> = robot.joints.iter().map(|j| j.name.as_str()).collect();
    for attr in ["link1", "link2"] {
        for l in attributes(&srdf, "disable_collisions", attr) {
            assert!(links.contains(&l.as_str()), "{l}");
        }
    }
    for attr in ["base_link", "tip_link"] {
        for l in attributes(&srdf, "chain", attr) {
            assert!(links.contains(&l.as_str()), "{l}");
        }
    }
    let state_joints = attributes(&srdf, "joint", "name");
    assert_eq!(state_joints.len(), 12, "two states of six joints");
    for j in &state_joints {
        assert!(joints.contains(&j.as_str()), "{j}");
    }
    assert_eq!(attributes(&srdf, "group_state", "name"), ["home", "zero"]);
    // Adjacent pairs are exactly the URDF's parent-child pairs of links with geometry.
    let mut adjacent: Vec<(String, String)> = srdf
        .lines()
        .filter(|l| l.contains("reason=\"Adjacent\""))
        .map(|l| {
            (
                attributes(l, "disable_collisions", "link1")[0].clone(),
                attributes(l, "disable_collisions", "link2")[0].clone(),
            )
        })
        .collect();
    let mut expected: Vec<(String, String)> = robot
        .joints
        .iter()
        .filter(|j| j.child.link != "tool0")
        .map(|j| (j.parent.link.clone(), j.child.link.clone()))
        .collect();
    adjacent.sort();
    expected.sort();
    assert_eq!(adjacent, expected);
    // Other joint names reach the states.
    let mut other = names();
    other[4] = "wrist_bend".into();
    assert!(srdf_of(&other).contains("<joint name=\"wrist_bend\""));
}

#[test]
fn the_matrix_is_reproducible_and_keeps_home_and_zero_collision_free() {
    let model = RobotModel::fs020n();
    // The same seed draws the same configurations.
    assert_eq!(
        sample_self_collisions(&model, 500, SELF_COLLISION_SEED),
        sample_self_collisions(&model, 500, SELF_COLLISION_SEED)
    );
    assert_ne!(
        sample_self_collisions(&model, 500, SELF_COLLISION_SEED).hits,
        sample_self_collisions(&model, 500, SELF_COLLISION_SEED + 1).hits
    );
    let counts = counts();
    assert_eq!(
        srdf_of(&names()),
        fs020n_ros2::srdf::generate(&model, &names())
    );
    let disabled = disabled_pairs(&model, counts);
    let checked = |i: usize, j: usize| !disabled.iter().any(|p| (p.first, p.second) == (i, j));
    for q in [model.home, JointsDeg::ZERO] {
        let hits: Vec<_> = colliding_pairs(&model, &q)
            .into_iter()
            .filter(|&(i, j)| checked(i, j))
            .collect();
        assert!(hits.is_empty(), "{q:?} collides: {hits:?}");
    }
    // Never means never in the samples, Always in all of them.
    for p in &disabled {
        let hits = counts.hits[p.first][p.second];
        match p.reason {
            DisableReason::Never => assert_eq!(hits, 0),
            DisableReason::Always => assert_eq!(hits, counts.samples),
            DisableReason::Adjacent => assert_eq!(p.second, p.first + 1),
        }
    }
}

#[test]
fn the_upper_arm_folded_into_the_base_is_a_checked_collision() {
    let model = RobotModel::fs020n();
    let srdf = srdf_of(&names());
    assert!(
        !srdf.contains(r#"link1="base_link" link2="link_2""#),
        "{srdf}"
    );
    assert!(!srdf.contains(r#"link1="link_1" link2="link_3""#), "{srdf}");
    let folded = JointsDeg::new([0.0, 140.0, 0.0, 0.0, 0.0, 0.0]);
    assert!(colliding_pairs(&model, &folded).contains(&(0, 2)));
    // The forearm folded back onto the column.
    let elbow = JointsDeg::new([0.0, -60.0, 120.0, 0.0, 0.0, 0.0]);
    assert!(
        colliding_pairs(&model, &elbow).iter().any(|&(i, _)| i <= 1),
        "{:?}",
        colliding_pairs(&model, &elbow)
    );
}

#[test]
fn the_configuration_package_has_every_file_moveit_reads() {
    let files = fs020n_ros2::moveit::config_package(&RobotModel::fs020n(), &NodeConfig::default());
    let paths: Vec<&str> = files.iter().map(|(p, _)| p.as_str()).collect();
    for needed in [
        "package.xml",
        "CMakeLists.txt",
        ".setup_assistant",
        "config/fs020n.urdf",
        "config/fs020n.srdf",
        "config/kinematics.yaml",
        "config/joint_limits.yaml",
        "config/moveit_controllers.yaml",
        "launch/move_group.launch.py",
    ] {
        assert!(paths.contains(&needed), "{needed} missing: {paths:?}");
    }
    let text = |p: &str| &files.iter().find(|(q, _)| q == p).expect(p).1;
    assert!(text(".setup_assistant").contains("relative_path: config/fs020n.srdf"));
    assert!(text("config/kinematics.yaml").starts_with("# kinematics.yaml"));
    assert!(text("config/kinematics.yaml").contains("manipulator:\n  kinematics_solver: kdl"));
    assert!(text("package.xml").contains("<name>fs020n_moveit_config</name>"));
}
