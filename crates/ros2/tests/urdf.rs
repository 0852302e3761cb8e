//! The generated URDF, parsed by `urdf-rs` and evaluated by the `k` crate (an independent
//! kinematics implementation), puts the flange where the robot model's forward kinematics
//! does; its limits are the model's, in radians.
#![allow(clippy::expect_used)] // test code: a failed expectation is a failed test

use fs020n_kin::{JointsDeg, RobotModel};
use proptest::prelude::*;

fn names() -> [String; 6] {
    std::array::from_fn(|i| format!("joint_{}", i + 1))
}

fn chain(model: &RobotModel) -> k::Chain<f64> {
    let text = fs020n_ros2::urdf::generate(model, &names());
    let robot = urdf_rs::read_from_string(&text).expect("the generated URDF parses");
    k::Chain::from(robot)
}

fn compare(chain: &k::Chain<f64>, model: &RobotModel, q: &JointsDeg) {
    chain
        .set_joint_positions(&q.to_rad().0)
        .expect("inside the URDF limits");
    chain.update_transforms();
    let t = chain
        .find("flange_joint")
        .expect("flange joint")
        .world_transform()
        .expect("updated");
    let ours = model.forward(&q.to_rad());
    let p = ours.position_m();
    let v = t.translation.vector;
    for (i, kv) in [v.x, v.y, v.z].iter().enumerate() {
        assert!(
            (p[i] - kv).abs() < 1e-9,
            "position {i}: {} vs {kv} at {q:?}",
            p[i]
        );
    }
    let r = ours.rotation();
    let kq = t.rotation;
    let dot = r.w * kq.w + r.i * kq.i + r.j * kq.j + r.k * kq.k;
    assert!(
        1.0 - dot.abs() < 1e-9,
        "orientation differs at {q:?}: {dot}"
    );
}

#[test]
fn six_revolute_joints_with_the_model_limits_in_radians() {
    let model = RobotModel::fs020n();
    let robot = urdf_rs::read_from_string(&fs020n_ros2::urdf::generate(&model, &names())).unwrap();
    let revolute: Vec<_> = robot
        .joints
        .iter()
        .filter(|j| matches!(j.joint_type, urdf_rs::JointType::Revolute))
        .collect();
    assert_eq!(revolute.len(), 6);
    for (j, spec) in revolute.iter().zip(model.joints.iter()) {
        assert!((j.limit.lower - spec.min_deg.to_radians()).abs() < 1e-12);
        assert!((j.limit.upper - spec.max_deg.to_radians()).abs() < 1e-12);
        assert!((j.limit.velocity - spec.max_speed_deg_s.to_radians()).abs() < 1e-12);
    }
    assert_eq!(chain(&model).dof(), 6);
}

#[test]
fn home_and_zero_match_the_model() {
    let model = RobotModel::fs020n();
    let c = chain(&model);
    compare(&c, &model, &model.home);
    compare(&c, &model, &JointsDeg::ZERO);
}

#[test]
fn another_model_file_changes_the_urdf() {
    let mut model = RobotModel::fs020n();
    model.geometry.upper_arm_m = 0.9;
    model.joints[0].max_deg = 100.0;
    model.validate().unwrap();
    let c = chain(&model);
    compare(
        &c,
        &model,
        &JointsDeg::new([30.0, 20.0, -60.0, 10.0, -45.0, 90.0]),
    );
    assert!(fs020n_ros2::urdf::generate(&model, &names())
        .contains(&format!("upper=\"{}\"", 100f64.to_radians())));
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(300))]

    #[test]
    fn random_configurations_match_the_model(
        a in -160.0..160.0f64, b in -105.0..140.0f64, c in -155.0..120.0f64,
        d in -270.0..270.0f64, e in -145.0..145.0f64, f in -360.0..360.0f64,
    ) {
        let model = RobotModel::fs020n();
        compare(&chain(&model), &model, &JointsDeg::new([a, b, c, d, e, f]));
    }
}
