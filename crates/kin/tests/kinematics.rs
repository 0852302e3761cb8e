//! Forward/inverse kinematics: known poses, round trips, singularities, errors.

use std::f64::consts::TAU;

use fs020n_kin::{IkError, JointsDeg, JointsRad, Pose, RobotModel, Xyzoat};
use nalgebra::Vector3;
use proptest::prelude::*;

fn deg(v: [f64; 6]) -> JointsRad {
    JointsDeg::new(v).to_rad()
}

fn assert_pose_eq(a: &Pose, b: &Pose, tol: f64) {
    let dp = a.distance_m(b);
    let dr = a.angle_to_rad(b);
    assert!(dp < tol, "position differs by {dp} m: {a:?} vs {b:?}");
    assert!(dr < tol, "orientation differs by {dr} rad");
}

/// Largest joint difference modulo 360 degrees, radians.
fn wrapped_diff(a: &JointsRad, b: &JointsRad) -> f64 {
    a.iter()
        .zip(b.iter())
        .map(|(x, y)| {
            let d = (x - y).rem_euclid(TAU);
            d.min(TAU - d)
        })
        .fold(0.0, f64::max)
}

#[test]
fn zero_pose_arm_straight_up() {
    let m = RobotModel::fs020n();
    let v = m.forward(&JointsRad::ZERO).to_xyzoat();
    assert!((v.x_mm - 150.0).abs() < 1e-9, "{v}");
    assert!(v.y_mm.abs() < 1e-9);
    assert!((v.z_mm - 2046.5).abs() < 1e-9);
    assert!(
        v.a_deg.abs() < 1e-9,
        "tool Z = base Z at the zero pose: {v}"
    );
    let z = m.forward(&JointsRad::ZERO).z_axis();
    assert!((z - Vector3::z()).norm() < 1e-12);
}

#[test]
fn home_pose_numbers() {
    let m = RobotModel::fs020n();
    let home = m.forward(&m.home.to_rad());
    let v = home.to_xyzoat();
    assert!((v.x_mm - 850.0).abs() < 1e-9, "{v}");
    assert!(v.y_mm.abs() < 1e-9, "{v}");
    assert!((v.z_mm - 1153.5).abs() < 1e-9, "{v}");
    assert!((v.a_deg - 180.0).abs() < 1e-9, "{v}");
    assert_eq!(v.o_deg, 0.0);
    assert!(v.t_deg.abs() < 1e-9, "{v}");
    // tool points straight down, wrist centre above the flange
    assert!((home.z_axis() - Vector3::new(0.0, 0.0, -1.0)).norm() < 1e-12);
    let wc = m.wrist_centre_m(&m.home.to_rad());
    assert!((wc - Vector3::new(0.85, 0.0, 1.25)).norm() < 1e-12);
}

#[test]
fn joint_sign_conventions() {
    let m = RobotModel::fs020n();
    // JT1 positive: counter-clockwise seen from above, +X turns to +Y
    let p = m
        .forward(&deg([90.0, 0.0, -90.0, 0.0, -90.0, 0.0]))
        .to_xyzoat();
    assert!(p.x_mm.abs() < 1e-9 && (p.y_mm - 850.0).abs() < 1e-9, "{p}");
    // JT2 positive leans the upper arm forward (+X), lower
    let p = m
        .forward(&deg([0.0, 30.0, 0.0, 0.0, 0.0, 0.0]))
        .position_m();
    assert!(
        (p.x - (0.15 + 1.5965 * 0.5)).abs() < 1e-12 && p.z < 2.0,
        "{p:?}"
    );
    // JT3 = -90 alone: forearm horizontal forward, tool along +X
    let f = m.forward(&deg([0.0, 0.0, -90.0, 0.0, 0.0, 0.0]));
    assert!((f.position_m() - Vector3::new(0.9465, 0.0, 1.25)).norm() < 1e-12);
    assert!((f.z_axis() - Vector3::x()).norm() < 1e-12);
    // JT5 = -90 alone: tool bent forward
    let f = m.forward(&deg([0.0, 0.0, 0.0, 0.0, -90.0, 0.0]));
    assert!((f.z_axis() - Vector3::x()).norm() < 1e-12);
    assert!((f.position_m() - Vector3::new(0.2465, 0.0, 1.95)).norm() < 1e-12);
    // JT4 = +90 at home: right-hand rule about the forearm (+X): tool -Z turns to +Y
    let f = m.forward(&deg([0.0, 0.0, -90.0, 90.0, -90.0, 0.0]));
    assert!((f.z_axis() - Vector3::y()).norm() < 1e-12);
    // JT6 = +90 at zero: flange X axis turns from +X to +Y
    let f = m.forward(&deg([0.0, 0.0, 0.0, 0.0, 0.0, 90.0]));
    assert!((f.rotation() * Vector3::x() - Vector3::y()).norm() < 1e-12);
}

#[test]
fn tool_point_forward_and_inverse() {
    let m = RobotModel::fs020n();
    let tool = Pose::from_translation_m(0.0, 0.0, 0.2);
    let tcp = m.forward_tool(&m.home.to_rad(), &tool).to_xyzoat();
    // tool points down: 200 mm below the flange
    assert!(
        (tcp.z_mm - 953.5).abs() < 1e-9 && (tcp.x_mm - 850.0).abs() < 1e-9,
        "{tcp}"
    );
    let target = Pose::from_xyzoat(tcp);
    let q = m
        .inverse_tool_nearest(&target, &tool, &m.home.to_rad())
        .unwrap();
    assert!(q.to_deg().max_abs_diff(&m.home) < 1e-9);
    let all = m.inverse_tool_all(&target, &tool).unwrap();
    for s in &all {
        assert_pose_eq(&m.forward_tool(s, &tool), &target, 1e-9);
    }
}

#[test]
fn home_ik_all_branches() {
    let m = RobotModel::fs020n();
    let target = m.forward(&m.home.to_rad());
    let all = m.inverse_all(&target).unwrap();
    assert!(
        !all.is_empty() && all.len() <= 48,
        "{} solutions",
        all.len()
    );
    for s in &all {
        assert_pose_eq(&m.forward(s), &target, 1e-9);
        assert!(m.within_limits(&s.to_deg()), "{}", s.to_deg());
    }
    assert!(all.iter().any(|s| s.to_deg().max_abs_diff(&m.home) < 1e-9));
    // elbow-down front solution exists (JT3 > 0)
    // Only the front elbow-up branch is in range here: elbow down would need |JT5| = 172.4 deg,
    // the back branches JT1 = 180 deg. Wrist flip: JT4 = +-180, JT5 = +90, JT6 = +-180.
    // Non-flipped: JT4 in {0} (+-360 is outside +-270), JT6 in {0, 360, -360}.
    assert_eq!(all.len(), 3 + 4, "{all:?}");
    for s in &all {
        let d = s.to_deg();
        assert!(
            d[0].abs() < 1e-9 && d[1].abs() < 1e-9 && (d[2] + 90.0).abs() < 1e-9,
            "{d}"
        );
    }
    let n6 = all
        .iter()
        .filter(|s| (s.to_deg()[4] + 90.0).abs() < 1e-9)
        .count();
    assert_eq!(n6, 3, "{all:?}");
    // no duplicates
    for (i, a) in all.iter().enumerate() {
        for b in all.iter().skip(i + 1) {
            assert!(a.max_abs_diff(b) > 1e-9);
        }
    }
}

#[test]
fn nearest_respects_seed_variants() {
    let m = RobotModel::fs020n();
    let q = deg([10.0, 20.0, -70.0, 30.0, -40.0, 50.0]);
    let target = m.forward(&q);
    let near = m.inverse_nearest(&target, &q).unwrap();
    assert!(near.max_abs_diff(&q) < 1e-9);
    // seed JT6 near -300: the nearest has JT6 = 50 - 360
    let mut seed = q;
    seed[5] = (-300f64).to_radians();
    let near = m.inverse_nearest(&target, &seed).unwrap();
    assert!((near.to_deg()[5] + 310.0).abs() < 1e-9, "{}", near.to_deg());
}

#[test]
fn stretched_arm_singularity() {
    let m = RobotModel::fs020n();
    let q = deg([20.0, 30.0, 0.0, 10.0, -40.0, 15.0]);
    let target = m.forward(&q);
    let all = m.inverse_all(&target).unwrap();
    for s in &all {
        assert_pose_eq(&m.forward(s), &target, 1e-9);
    }
    // the front branch has a single elbow solution: JT3 = 0
    let front: Vec<_> = all.iter().filter(|s| (s[0] - q[0]).abs() < 1e-9).collect();
    assert!(!front.is_empty());
    assert!(front.iter().all(|s| s[2].abs() < 1e-6), "{front:?}");
    let near = m.inverse_nearest(&target, &q).unwrap();
    assert!(near.max_abs_diff(&q) < 1e-6);
    // singular measures vanish
    assert!(m.singularity_distance(&q) < 1e-9);
    assert!(m.manipulability(&q) < 1e-12);
    let margins = m.singularity_margins(&q);
    assert_eq!(margins.elbow_deg, 0.0);
    assert!(margins.is_protocol_singular());
    // slightly beyond full stretch (round-off) still counts as reachable
    let (s1, c1) = q[0].sin_cos();
    let shoulder = Vector3::new(0.15 * c1, 0.15 * s1, 0.45);
    let outward = (m.wrist_centre_m(&q) - shoulder).normalize();
    let mut p = target;
    p.0.translation.vector += outward * 1e-12;
    let beyond = m.inverse_all(&p).unwrap();
    assert!(beyond.iter().any(|s| s.max_abs_diff(&q) < 1e-6));
    // clearly beyond: out of reach by about a millimetre
    p.0.translation.vector += outward * 1e-3;
    match m.inverse_all(&p) {
        Err(IkError::OutOfReach { excess_m }) => assert!((excess_m - 1e-3).abs() < 1e-6),
        other => panic!("expected OutOfReach, got {other:?}"),
    }
}

#[test]
fn straight_wrist_singularity_keeps_seed_jt4() {
    let m = RobotModel::fs020n();
    let q = deg([15.0, 10.0, -80.0, 0.0, 0.0, 30.0]);
    let target = m.forward(&q);
    // seed JT4 = 40 deg: JT4 is kept, JT6 absorbs the rotation (JT4 + JT6 = 30)
    let seed = deg([15.0, 10.0, -80.0, 40.0, 0.0, 0.0]);
    let s = m.inverse_nearest(&target, &seed).unwrap().to_deg();
    assert!((s[3] - 40.0).abs() < 1e-9, "{s}");
    assert!(s[4].abs() < 1e-9, "{s}");
    assert!((s[5] + 10.0).abs() < 1e-9, "{s}");
    assert_pose_eq(&m.forward(&s.to_rad()), &target, 1e-9);
    // without a seed JT4 = 0 (or its 360 variants)
    let all = m.inverse_all(&target).unwrap();
    for s in &all {
        assert_pose_eq(&m.forward(s), &target, 1e-9);
        if s[4].abs() < 1e-9 {
            assert!(wrapped_diff(&JointsRad::new([s[3]; 6]), &JointsRad::ZERO) < 1e-9);
        }
    }
    assert!(m.singularity_distance(&q) < 1e-9);
    assert_eq!(m.singularity_margins(&q).wrist_deg, 0.0);
}

#[test]
fn shoulder_singularity_keeps_seed_jt1() {
    let m = RobotModel::fs020n();
    // wrist centre on the JT1 axis: 0.15 + 0.7 sin(-q3) = 0
    let q3 = -(-0.15f64 / 0.7).asin();
    let q = JointsRad::new([0.0, 0.0, q3, 0.3, -0.5, 0.2]);
    assert!(m.singularity_margins(&q).shoulder_m < 1e-12);
    let target = m.forward(&q);
    let seed = JointsRad::new([0.4, 0.0, q3, 0.0, -0.5, 0.0]);
    let s = m.inverse_nearest(&target, &seed).unwrap();
    assert!((s[0] - 0.4).abs() < 1e-12);
    assert_pose_eq(&m.forward(&s), &target, 1e-9);
    assert!(m.singularity_distance(&q) < 1e-9);
}

#[test]
fn unreachable_and_outside_limits_are_distinguished() {
    let m = RobotModel::fs020n();
    let far = Pose::from_xyzoat(Xyzoat::new(3000.0, 0.0, 1000.0, 0.0, 90.0, 0.0));
    match m.inverse_all(&far) {
        Err(IkError::OutOfReach { excess_m }) => assert!(excess_m > 0.5 && excess_m < 2.0),
        other => panic!("expected OutOfReach, got {other:?}"),
    }
    // far below the base
    let below = Pose::from_translation_m(0.0, 0.0, -2.0);
    assert!(matches!(
        m.inverse_all(&below),
        Err(IkError::OutOfReach { .. })
    ));
    // reachable but JT1 restricted to +-10 degrees; the target needs JT1 = +-90
    let mut narrow = m.clone();
    narrow.joints[0].min_deg = -10.0;
    narrow.joints[0].max_deg = 10.0;
    let target = m.forward(&deg([90.0, 0.0, -90.0, 0.0, -90.0, 0.0]));
    match narrow.inverse_all(&target) {
        Err(e @ IkError::OutsideLimits { solutions, first }) => {
            assert!(solutions >= 4);
            assert_eq!(first.joint, 1);
            assert!(e.to_string().contains("JT1"), "{e}");
        }
        other => panic!("expected OutsideLimits, got {other:?}"),
    }
    let bad = Pose::from_translation_m(f64::NAN, 0.0, 1.0);
    assert_eq!(m.inverse_all(&bad).unwrap_err(), IkError::NonFinite);
    let seed = JointsRad::new([f64::NAN; 6]);
    assert_eq!(
        m.inverse_nearest(&target, &seed).unwrap_err(),
        IkError::NonFinite
    );
}

#[test]
fn manipulability_closed_form() {
    let m = RobotModel::fs020n();
    let q = deg([25.0, 35.0, -65.0, 20.0, -55.0, 10.0]);
    let wc = m.wrist_centre_m(&q);
    let expected = 0.8 * 0.7 * q[2].sin().abs() * q[4].sin().abs() * wc.x.hypot(wc.y);
    assert!((m.manipulability(&q) - expected).abs() < 1e-12);
    assert!(m.singularity_distance(&m.home.to_rad()) > 1e-2);
    let margins = m.singularity_margins(&m.home.to_rad());
    assert!((margins.elbow_deg - 90.0).abs() < 1e-12 && (margins.wrist_deg - 90.0).abs() < 1e-12);
    assert!((margins.shoulder_m - 0.85).abs() < 1e-12);
    assert!(!margins.is_protocol_singular());
}

#[test]
fn jacobian_tool_shifts_linear_part() {
    let m = RobotModel::fs020n();
    let q = deg([10.0, 20.0, -60.0, 30.0, -45.0, 5.0]);
    let tool = Pose::from_translation_m(0.05, 0.0, 0.15);
    let jf = m.jacobian(&q);
    let jt = m.jacobian_tool(&q, &tool);
    let r = m.forward_tool(&q, &tool).position_m() - m.forward(&q).position_m();
    for c in 0..6 {
        let w = Vector3::new(jf[(3, c)], jf[(4, c)], jf[(5, c)]);
        let v = Vector3::new(jf[(0, c)], jf[(1, c)], jf[(2, c)]) + w.cross(&r);
        for k in 0..3 {
            assert!((jt[(k, c)] - v[k]).abs() < 1e-12);
            assert_eq!(jt[(k + 3, c)], jf[(k + 3, c)]);
        }
    }
}

fn reachable_joints() -> impl Strategy<Value = JointsRad> {
    (
        -160.0..160.0f64,
        -105.0..140.0f64,
        -155.0..120.0f64,
        -270.0..270.0f64,
        -145.0..145.0f64,
        -360.0..360.0f64,
    )
        .prop_map(|(a, b, c, d, e, f)| deg([a, b, c, d, e, f]))
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(2000))]

    #[test]
    fn fk_ik_round_trip(q in reachable_joints()) {
        let m = RobotModel::fs020n();
        let margins = m.singularity_margins(&q);
        prop_assume!(margins.elbow_deg > 0.5 && margins.wrist_deg > 0.5 && margins.shoulder_m > 0.01);
        let target = m.forward(&q);
        let all = m.inverse_all(&target).unwrap();
        prop_assert!(!all.is_empty());
        for s in &all {
            let p = m.forward(s);
            prop_assert!(p.distance_m(&target) < 1e-9, "pos err {}", p.distance_m(&target));
            prop_assert!(p.angle_to_rad(&target) < 1e-9, "rot err {}", p.angle_to_rad(&target));
            prop_assert!(m.within_limits(&s.to_deg()));
        }
        // the original configuration is among them, exactly (the 360 variants are enumerated)
        let best = all.iter().map(|s| s.max_abs_diff(&q)).fold(f64::INFINITY, f64::min);
        prop_assert!(best < 1e-7, "closest solution differs by {best} rad");
        let near = m.inverse_nearest(&target, &q).unwrap();
        prop_assert!(near.max_abs_diff(&q) < 1e-7);
        // wrapped comparison agrees
        prop_assert!(wrapped_diff(&near, &q) < 1e-7);
    }

    #[test]
    fn xyzoat_round_trip(x in -2000.0..2000.0f64, y in -2000.0..2000.0f64, z in -500.0..2500.0f64,
                         o in -179.9..180.0f64, a in 0.01..179.99f64, t in -179.9..180.0f64) {
        let v = Xyzoat::new(x, y, z, o, a, t);
        let back = Pose::from_xyzoat(v).to_xyzoat();
        for (p, q) in v.to_array().iter().zip(back.to_array()) {
            prop_assert!((p - q).abs() < 1e-7, "{} vs {}", v, back);
        }
    }
}
