//! The URDF generated from the model (`RobotModel::to_urdf`), read by an independent URDF parser
//! (`urdf-rs`) and evaluated by an independent kinematics library (`k`): its forward kinematics
//! must equal ours, and its limits must be the model's.
#![allow(clippy::expect_used)] // test code: a failed expectation is a failed test

use fs020n_kin::{JointsDeg, JointsRad, RobotModel, URDF_JOINT_NAMES};
use proptest::prelude::*;

fn chain(model: &RobotModel) -> k::Chain<f64> {
    let robot = urdf_rs::read_from_string(&model.to_urdf()).expect("generated URDF parses");
    k::Chain::from(robot)
}

fn check(chain: &k::Chain<f64>, model: &RobotModel, q: &JointsRad) {
    chain
        .set_joint_positions(&q.0)
        .expect("inside the URDF limits");
    chain.update_transforms();
    for frame in ["flange_joint", "tool0_joint"] {
        let t = chain
            .find(frame)
            .expect("frame exists")
            .world_transform()
            .expect("transforms updated");
        let ours = model.forward(q);
        let p = ours.position_m();
        let v = t.translation.vector;
        for (i, kv) in [v.x, v.y, v.z].into_iter().enumerate() {
            assert!(
                (p[i] - kv).abs() < 1e-12,
                "{frame} position {i}: {} vs {kv}",
                p[i]
            );
        }
        let r = ours.rotation();
        let kr = t.rotation;
        let dot = r.w * kr.w + r.i * kr.i + r.j * kr.j + r.k * kr.k;
        assert!(
            1.0 - dot.abs() < 1e-12,
            "{frame} orientation differs: dot = {dot}"
        );
    }
}

#[test]
fn joints_and_limits_are_the_models() {
    let model = RobotModel::fs020n();
    let robot = urdf_rs::read_from_string(&model.to_urdf()).unwrap();
    let revolute: Vec<_> = robot
        .joints
        .iter()
        .filter(|j| matches!(j.joint_type, urdf_rs::JointType::Revolute))
        .collect();
    assert_eq!(revolute.len(), 6);
    for (i, j) in revolute.iter().enumerate() {
        assert_eq!(j.name, URDF_JOINT_NAMES[i]);
        let spec = model.joints[i];
        assert!((j.limit.lower - spec.min_deg.to_radians()).abs() < 1e-12);
        assert!((j.limit.upper - spec.max_deg.to_radians()).abs() < 1e-12);
        assert!((j.limit.velocity - spec.max_speed_deg_s.to_radians()).abs() < 1e-12);
    }
    assert_eq!(chain(&model).dof(), 6);
}

#[test]
fn home_and_zero_match() {
    let m = RobotModel::fs020n();
    let c = chain(&m);
    check(&c, &m, &JointsRad::ZERO);
    check(&c, &m, &m.home.to_rad());
}

#[test]
fn another_geometry_matches_too() {
    let mut m = RobotModel::fs020n();
    m.geometry.base_height_m = 0.6;
    m.geometry.shoulder_offset_m = 0.0;
    m.geometry.upper_arm_m = 0.55;
    m.geometry.forearm_m = 0.9;
    m.geometry.flange_m = 0.2;
    m.validate().unwrap();
    let c = chain(&m);
    check(
        &c,
        &m,
        &JointsDeg::new([30.0, 20.0, -60.0, 45.0, -30.0, 90.0]).to_rad(),
    );
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(300))]

    #[test]
    fn random_configurations_match(
        a in -160.0..160.0f64, b in -105.0..140.0f64, c in -155.0..120.0f64,
        d in -270.0..270.0f64, e in -145.0..145.0f64, f in -360.0..360.0f64,
    ) {
        let m = RobotModel::fs020n();
        check(&chain(&m), &m, &JointsDeg::new([a, b, c, d, e, f]).to_rad());
    }
}
