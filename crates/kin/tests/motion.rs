//! Synchronized trapezoidal joint moves.

use fs020n_kin::motion::MIN_SPEED_FRACTION;
use fs020n_kin::{JointMove, JointsDeg, MotionError, RobotModel};
use proptest::prelude::*;

fn joints() -> impl Strategy<Value = JointsDeg> {
    proptest::array::uniform6(-150.0..150.0f64).prop_map(JointsDeg::new)
}

#[test]
fn zero_length_move() {
    let m = RobotModel::fs020n();
    let mv = JointMove::plan(&m, m.home, m.home, 0.5);
    assert_eq!(mv.duration_s(), 0.0);
    assert_eq!(mv.position_at(0.0), m.home);
    assert_eq!(mv.position_at(1.0), m.home);
    assert_eq!(mv.velocity_at(0.0), JointsDeg::ZERO);
}

#[test]
fn single_joint_closed_form() {
    let m = RobotModel::fs020n();
    let mut to = m.home;
    to[5] += 720.0; // JT6: 610 deg/s, 591 deg/s^2
    let mv = JointMove::plan(&m, m.home, to, 1.0);
    // 610^2/591 = 629.6 < 720: trapezoid
    assert!(!mv.is_triangular());
    let expected = 720.0 / 610.0 + 610.0 / 591.0;
    assert!((mv.duration_s() - expected).abs() < 1e-12);
    assert!((mv.accel_time_s() - 610.0 / 591.0).abs() < 1e-12);
    // cruise at full speed in the middle
    let v = mv.velocity_at(mv.duration_s() / 2.0);
    assert!((v[5] - 610.0).abs() < 1e-9);
    assert!((mv.peak_velocity()[5] - 610.0).abs() < 1e-9);
    // acceleration phase
    assert!((mv.acceleration_at(0.1)[5] - 591.0).abs() < 1e-9);
    assert!((mv.acceleration_at(mv.duration_s() - 0.1)[5] + 591.0).abs() < 1e-9);
    assert!((mv.position_at(0.5)[5] - (0.5 * 591.0 * 0.25)).abs() < 1e-9);
    // halfway in time = halfway in space (symmetric profile)
    assert!((mv.position_at(mv.duration_s() / 2.0)[5] - 360.0).abs() < 1e-9);
}

#[test]
fn slowest_constraint_sets_time_and_others_scale() {
    let m = RobotModel::fs020n();
    let from = JointsDeg::ZERO;
    let to = JointsDeg::new([100.0, 10.0, 0.0, 0.0, 0.0, 50.0]);
    let mv = JointMove::plan(&m, from, to, 0.1);
    // JT1 at 19 deg/s dominates: 100/19 + 19/235
    assert!((mv.duration_s() - (100.0 / 19.0 + 19.0 / 235.0)).abs() < 1e-9);
    let t = mv.duration_s() / 2.0;
    let v = mv.velocity_at(t);
    assert!((v[0] - 19.0).abs() < 1e-9);
    assert!((v[1] - 1.9).abs() < 1e-9 && (v[5] - 9.5).abs() < 1e-9);
    assert_eq!(v[2], 0.0);
}

#[test]
fn invalid_inputs() {
    let m = RobotModel::fs020n();
    assert_eq!(
        JointMove::try_plan(&m, m.home, m.home, 0.0).unwrap_err(),
        MotionError::SpeedFraction(0.0)
    );
    assert!(JointMove::try_plan(&m, m.home, m.home, 1.5).is_err());
    assert!(JointMove::try_plan(&m, m.home, m.home, f64::NAN).is_err());
    let mut bad = m.home;
    bad[3] = f64::INFINITY;
    assert_eq!(
        JointMove::try_plan(&m, m.home, bad, 1.0).unwrap_err(),
        MotionError::NonFinite(4)
    );
    // plan() never fails: non-finite target joints stay put, fraction is clamped
    let mv = JointMove::plan(&m, m.home, bad, f64::NAN);
    assert_eq!(mv.to(), m.home);
    assert_eq!(mv.duration_s(), 0.0);
    assert_eq!(mv.speed_fraction(), MIN_SPEED_FRACTION);
    let mv = JointMove::plan(&m, JointsDeg::ZERO, m.home, 7.0);
    assert_eq!(mv.speed_fraction(), 1.0);
    assert_eq!(mv.position_at(f64::NAN), JointsDeg::ZERO);
    assert!(mv.position_at(f64::INFINITY) == m.home);
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(500))]

    #[test]
    fn endpoints_exact_and_limits_respected(from in joints(), to in joints(), f in 0.01..=1.0f64) {
        let m = RobotModel::fs020n();
        let mv = JointMove::try_plan(&m, from, to, f).unwrap();
        let d = mv.duration_s();
        prop_assert!(d > 0.0);
        prop_assert_eq!(mv.position_at(0.0), from);
        prop_assert_eq!(mv.position_at(d), to);
        prop_assert_eq!(mv.position_at(d + 1.0), to);
        prop_assert_eq!(mv.position_at(-1.0), from);
        // all joints end together: zero velocity at both ends, at rest after the end
        prop_assert_eq!(mv.velocity_at(0.0), JointsDeg::ZERO);
        prop_assert_eq!(mv.velocity_at(d), JointsDeg::ZERO);
        prop_assert_eq!(mv.velocity_at(d + 0.5), JointsDeg::ZERO);
        // sampled: velocity and acceleration within the scaled limits; positions move
        // monotonically from `from` to `to` for every joint
        let mut prev = from;
        for k in 1..=200 {
            let t = d * k as f64 / 200.0;
            let v = mv.velocity_at(t);
            let a = mv.acceleration_at(t);
            let p = mv.position_at(t);
            for i in 0..6 {
                let spec = m.joints[i];
                prop_assert!(v[i].abs() <= f * spec.max_speed_deg_s * (1.0 + 1e-12) + 1e-12);
                prop_assert!(a[i].abs() <= spec.max_accel_deg_s2 * (1.0 + 1e-12) + 1e-12);
                let dir = (to[i] - from[i]).signum();
                prop_assert!((p[i] - prev[i]) * dir >= -1e-9);
            }
            prev = p;
        }
        // some joint reaches a limit (time-optimal for the shared profile)
        let peak = mv.peak_velocity();
        let speed_bound = (0..6).any(|i| (peak[i].abs() - f * m.joints[i].max_speed_deg_s).abs() < 1e-9);
        let accel_bound = (0..6).any(|i| {
            let a = mv.acceleration_at(mv.accel_time_s() / 2.0)[i].abs();
            (a - m.joints[i].max_accel_deg_s2).abs() < 1e-9
        });
        prop_assert!(accel_bound);
        prop_assert!(speed_bound || mv.is_triangular());
        // velocity is the derivative of position (central difference)
        let t = d * 0.37;
        let h = 1e-6;
        let num = mv.position_at(t + h).zip_with(&mv.position_at(t - h), |a, b| (a - b) / (2.0 * h));
        prop_assert!(num.max_abs_diff(&mv.velocity_at(t)) < 1e-4);
    }

    #[test]
    fn duration_monotonic_in_distance_and_speed(from in joints(), to in joints(),
                                                 f1 in 0.01..=1.0f64, f2 in 0.01..=1.0f64,
                                                 shrink in 0.0..1.0f64) {
        let m = RobotModel::fs020n();
        let far = JointMove::try_plan(&m, from, to, f1).unwrap();
        // a move to a point on the same line, closer
        let mid = from.zip_with(&to, |a, b| a + (b - a) * shrink);
        let near = JointMove::try_plan(&m, from, mid, f1).unwrap();
        prop_assert!(near.duration_s() <= far.duration_s() * (1.0 + 1e-12));
        // faster (or equal) speed fraction never takes longer
        let (slow_f, fast_f) = if f1 < f2 { (f1, f2) } else { (f2, f1) };
        let slow = JointMove::try_plan(&m, from, to, slow_f).unwrap();
        let fast = JointMove::try_plan(&m, from, to, fast_f).unwrap();
        prop_assert!(fast.duration_s() <= slow.duration_s() * (1.0 + 1e-12));
        // in the cruise-dominated regime the time is inversely proportional to speed
        if !slow.is_triangular() && !fast.is_triangular() {
            let cruise = |mv: &JointMove| mv.duration_s() - mv.accel_time_s();
            prop_assert!((cruise(&slow) * slow_f - cruise(&fast) * fast_f).abs() < 1e-9 * cruise(&slow).max(1.0));
        }
    }
}

#[test]
fn overflowing_distances_and_unlimited_speeds_stay_defined() {
    let model = RobotModel::fs020n();
    let mut from = model.home;
    let mut to = model.home;
    from[0] = -1e308;
    to[0] = 1e308;
    assert!(JointMove::try_plan(&model, from, to, 1.0).is_err());
    let m = JointMove::plan(&model, from, to, 1.0);
    assert!(m.duration_s().is_finite());
    assert!(m.position_at(0.5 * m.duration_s()).is_finite());
    // A model without a useful speed limit still accelerates (triangular profile), no jump.
    let mut fast = model.clone();
    for j in &mut fast.joints {
        j.max_speed_deg_s = 1e308;
    }
    let target = JointsDeg::new([10.0, 0.0, -90.0, 0.0, -90.0, 0.0]);
    let m = JointMove::plan(&fast, model.home, target, 1.0);
    assert!((m.duration_s() - 2.0 * (10.0_f64 / 235.0).sqrt()).abs() < 1e-9);
    assert!(m.position_at(0.0).max_abs_diff(&model.home) < 1e-12);
}

#[test]
fn singularity_distance_of_non_finite_joints_is_nan() {
    let model = RobotModel::fs020n();
    let mut q = model.home.to_rad();
    q[0] = f64::NAN;
    assert!(model.singularity_distance(&q).is_nan());
    q[0] = f64::INFINITY;
    assert!(model.singularity_distance(&q).is_nan());
}
