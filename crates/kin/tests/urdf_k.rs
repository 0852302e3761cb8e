//! Forward kinematics checked against an independent implementation: the same arm described as
//! a URDF and evaluated with the `k` crate (its own nalgebra version; values are compared as
//! plain numbers).
//!
//! The URDF splits the forearm like the lab URDF of the FS020N (JT4 axis 0.225 m after JT3, the
//! wrist centre 0.475 m further) and gives JT3/JT5 their axes as `0 -1 0`, so it is not a copy of
//! the chain formula in `src/kinematics.rs`.
#![allow(clippy::expect_used)] // test code: a failed expectation is a failed test

use fs020n_kin::{JointsDeg, JointsRad, RobotModel};
use proptest::prelude::*;

const FS020N_URDF: &str = r#"<?xml version="1.0"?>
<robot name="fs020n">
  <link name="base_link"/>
  <link name="link1"/>
  <link name="link2"/>
  <link name="link3"/>
  <link name="link4"/>
  <link name="link5"/>
  <link name="link6"/>
  <link name="flange"/>
  <joint name="joint1" type="revolute">
    <parent link="base_link"/><child link="link1"/>
    <origin xyz="0 0 0" rpy="0 0 0"/>
    <axis xyz="0 0 1"/>
    <limit lower="-10" upper="10" effort="1" velocity="1"/>
  </joint>
  <joint name="joint2" type="revolute">
    <parent link="link1"/><child link="link2"/>
    <origin xyz="0.150 0 0.450" rpy="0 0 0"/>
    <axis xyz="0 1 0"/>
    <limit lower="-10" upper="10" effort="1" velocity="1"/>
  </joint>
  <joint name="joint3" type="revolute">
    <parent link="link2"/><child link="link3"/>
    <origin xyz="0 0 0.800" rpy="0 0 0"/>
    <axis xyz="0 -1 0"/>
    <limit lower="-10" upper="10" effort="1" velocity="1"/>
  </joint>
  <joint name="joint4" type="revolute">
    <parent link="link3"/><child link="link4"/>
    <origin xyz="0 0 0.225" rpy="0 0 0"/>
    <axis xyz="0 0 1"/>
    <limit lower="-10" upper="10" effort="1" velocity="1"/>
  </joint>
  <joint name="joint5" type="revolute">
    <parent link="link4"/><child link="link5"/>
    <origin xyz="0 0 0.475" rpy="0 0 0"/>
    <axis xyz="0 -1 0"/>
    <limit lower="-10" upper="10" effort="1" velocity="1"/>
  </joint>
  <joint name="joint6" type="revolute">
    <parent link="link5"/><child link="link6"/>
    <origin xyz="0 0 0" rpy="0 0 0"/>
    <axis xyz="0 0 1"/>
    <limit lower="-10" upper="10" effort="1" velocity="1"/>
  </joint>
  <joint name="flange_joint" type="fixed">
    <parent link="link6"/><child link="flange"/>
    <origin xyz="0 0 0.0965" rpy="0 0 0"/>
  </joint>
</robot>
"#;

fn chain() -> k::Chain<f64> {
    let robot = urdf_rs::read_from_string(FS020N_URDF).expect("test URDF parses");
    k::Chain::from(robot)
}

/// Flange pose from `k`: position (m) and quaternion (w, x, y, z).
fn k_flange(chain: &k::Chain<f64>, q: &JointsRad) -> ([f64; 3], [f64; 4]) {
    chain
        .set_joint_positions(&q.0)
        .expect("within the URDF limits");
    chain.update_transforms();
    let t = chain
        .find("flange_joint")
        .expect("flange joint exists")
        .world_transform()
        .expect("transforms updated");
    let v = t.translation.vector;
    let r = t.rotation;
    ([v.x, v.y, v.z], [r.w, r.i, r.j, r.k])
}

fn compare(chain: &k::Chain<f64>, model: &RobotModel, q: &JointsRad) {
    let (kp, kq) = k_flange(chain, q);
    let ours = model.forward(q);
    let p = ours.position_m();
    for i in 0..3 {
        assert!(
            (p[i] - kp[i]).abs() < 1e-12,
            "position {i}: {} vs {}",
            p[i],
            kp[i]
        );
    }
    let r = ours.rotation();
    // q and -q are the same rotation
    let dot = r.w * kq[0] + r.i * kq[1] + r.j * kq[2] + r.k * kq[3];
    assert!(1.0 - dot.abs() < 1e-12, "orientation differs: dot = {dot}");
}

#[test]
fn k_chain_has_six_joints() {
    assert_eq!(chain().dof(), 6);
}

#[test]
fn known_poses_match_k() {
    let c = chain();
    let m = RobotModel::fs020n();
    compare(&c, &m, &JointsRad::ZERO);
    compare(&c, &m, &m.home.to_rad());
    let (kp, _) = k_flange(&c, &m.home.to_rad());
    assert!((kp[0] - 0.85).abs() < 1e-12 && (kp[2] - 1.1535).abs() < 1e-12);
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(500))]

    #[test]
    fn random_configurations_match_k(
        a in -160.0..160.0f64, b in -105.0..140.0f64, c in -155.0..120.0f64,
        d in -270.0..270.0f64, e in -145.0..145.0f64, f in -360.0..360.0f64,
    ) {
        let ch = chain();
        let m = RobotModel::fs020n();
        compare(&ch, &m, &JointsDeg::new([a, b, c, d, e, f]).to_rad());
    }
}
