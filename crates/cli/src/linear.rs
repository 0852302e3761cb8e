//! `move --pose … --linear`: a straight line of the flange (position along a line, orientation
//! by spherical interpolation) as a joint trajectory for command 7.

use fs020n_client::{Trajectory, TrajectoryPoint};
use fs020n_kin::{Pose, RobotModel};
use fs020n_proto::{JointsDeg, JointsRad, JOINT_COUNT};

use crate::error::{CliError, CliResult};

/// Spacing of the trajectory's points, seconds.
pub(crate) const SAMPLE_S: f64 = 0.02;
/// Shortest line, seconds.
const MIN_DURATION_S: f64 = 0.2;
/// Largest joint change between two neighbouring points of the geometric path, degrees: more
/// means the inverse kinematics switched configuration (a singularity on the way).
const MAX_JUMP_DEG: f64 = 5.0;
/// Peak of ds/du and of d²s/du² of the minimum-jerk profile s(u) = 10u³ − 15u⁴ + 6u⁵.
const PEAK_DS: f64 = 1.875;
const PEAK_DDS: f64 = 5.773_502_691_896_258;
/// Share of a joint's maximum acceleration the line may use (the rest covers the path's
/// curvature in joint space and the controller's blending).
const ACCEL_SHARE: f64 = 0.5;

fn min_jerk(u: f64) -> f64 {
    let u = u.clamp(0.0, 1.0);
    u * u * u * (10.0 - 15.0 * u + 6.0 * u * u)
}

/// The pose a fraction `s` along the line from `from` to `to`.
fn pose_at(from: &Pose, to: &Pose, s: f64) -> CliResult<Pose> {
    let rotation = from
        .rotation()
        .try_slerp(&to.rotation(), s, 1e-9)
        .ok_or_else(|| {
            CliError::input(
                "the orientation turns by 180°, which has no unique straight path; give an \
                 intermediate pose first",
            )
        })?;
    let position = from.position_m() + (to.position_m() - from.position_m()) * s;
    Ok(Pose::new(position, rotation))
}

/// Joints at a fraction `s` of the line, the solution nearest `seed`; refused when the line
/// leaves the reachable space or the solution jumps (a singularity on the way).
fn joints_at(
    model: &RobotModel,
    from: &Pose,
    to: &Pose,
    s: f64,
    seed: &JointsRad,
) -> CliResult<JointsRad> {
    let q = model
        .inverse_nearest(&pose_at(from, to, s)?, seed)
        .map_err(|e| {
            CliError::input(format!(
                "the straight line leaves the reachable space {:.0} % of the way: {e}",
                s * 100.0
            ))
            .with_remedy("choose another pose, or move without --linear (a joint move)")
        })?;
    let jump = q.to_deg().max_abs_diff(&seed.to_deg());
    if jump > MAX_JUMP_DEG {
        return Err(CliError::input(format!(
            "the straight line passes a singularity {:.0} % of the way (a joint would jump \
             {jump:.1} deg)",
            s * 100.0
        ))
        .with_remedy("choose another pose, or move without --linear (a joint move)"));
    }
    Ok(q)
}

/// The line from the flange pose at `start` to `target`, paced so that no joint exceeds
/// `pace` (0–1] of its maximum speed nor half its maximum acceleration, as points every
/// [`SAMPLE_S`] on a minimum-jerk profile (at rest at both ends).
pub(crate) fn line(
    model: &RobotModel,
    start: JointsDeg,
    target: &Pose,
    pace: f64,
) -> CliResult<Trajectory> {
    let from = model.forward(&start.to_rad());
    // The geometric path, finely: 1 mm or 0.5° apart.
    let dist_mm = from.distance_m(target) * 1000.0;
    let angle_deg = from.angle_to_rad(target).to_degrees();
    let n = (dist_mm.max(angle_deg * 2.0).ceil() as usize).clamp(2, 200_000);
    let mut path = vec![start];
    let mut seed = start.to_rad();
    for k in 1..=n {
        seed = joints_at(model, &from, target, k as f64 / n as f64, &seed)?;
        path.push(seed.to_deg());
    }
    // Joint derivatives along the path (per unit of the path parameter s).
    let (vmax, amax) = (model.max_speeds_deg_s(), model.max_accels_deg_s2());
    let mut duration = MIN_DURATION_S;
    for j in 0..JOINT_COUNT {
        let d1 = path
            .windows(2)
            .map(|w| (w[1][j] - w[0][j]).abs() * n as f64)
            .fold(0.0, f64::max);
        let d2 = path
            .windows(3)
            .map(|w| (w[2][j] - 2.0 * w[1][j] + w[0][j]).abs() * (n * n) as f64)
            .fold(0.0, f64::max);
        let a = ACCEL_SHARE * amax[j];
        duration = duration
            .max(PEAK_DS * d1 / (pace * vmax[j]))
            .max((PEAK_DDS * d1 / a).sqrt())
            .max(PEAK_DS * (d2 / a).sqrt());
    }
    let steps = (duration / SAMPLE_S).ceil().max(1.0) as usize;
    let mut points = Vec::with_capacity(steps + 1);
    let mut seed = start.to_rad();
    points.push(TrajectoryPoint::new(0.0, start));
    for i in 1..=steps {
        let s = min_jerk(i as f64 / steps as f64);
        seed = joints_at(model, &from, target, s, &seed)?;
        points.push(TrajectoryPoint::new(i as f64 * SAMPLE_S, seed.to_deg()));
    }
    Trajectory::new(points).map_err(|e| CliError::input(format!("the straight line: {e}")))
}

#[cfg(test)]
mod tests {
    use super::*;
    use fs020n_client::StreamOptions;
    use nalgebra::Vector3;

    #[test]
    fn a_line_is_straight_paced_and_streamable() {
        let model = RobotModel::fs020n();
        let start = JointsDeg::new([0.0, 10.0, -80.0, 0.0, -80.0, 0.0]);
        let from = model.forward(&start.to_rad());
        let to = Pose::new(
            from.position_m() + Vector3::new(0.0, 0.1, -0.05),
            from.rotation(),
        );
        let t = line(&model, start, &to, 0.1).unwrap();
        StreamOptions::default().validate(&model, &t).unwrap();
        // Every point is on the segment, with the start's orientation.
        let (a, b) = (from.position_m(), to.position_m());
        for p in t.points() {
            let here = model.forward(&p.position.to_rad());
            let x = here.position_m();
            let s = (x - a).dot(&(b - a)) / (b - a).norm_squared();
            let off = (x - (a + (b - a) * s)).norm();
            assert!(off < 1e-6, "{off} m off the line at {}", p.time_s);
            assert!(here.angle_to_rad(&from) < 1e-6);
        }
        let end = model.forward(&t.last().to_rad());
        assert!(end.distance_m(&to) < 1e-6);
        // Faster pace, shorter line.
        let fast = line(&model, start, &to, 0.5).unwrap();
        assert!(fast.duration_s() < t.duration_s());
        assert!(t.duration_s() >= MIN_DURATION_S);
    }

    #[test]
    fn an_unreachable_line_is_refused() {
        let model = RobotModel::fs020n();
        let start = JointsDeg::new([0.0, 10.0, -80.0, 0.0, -80.0, 0.0]);
        let from = model.forward(&start.to_rad());
        let far = Pose::new(
            from.position_m() + Vector3::new(5.0, 0.0, 0.0),
            from.rotation(),
        );
        let e = line(&model, start, &far, 0.1).unwrap_err();
        assert!(e.message.contains("reachable space"), "{e}");
    }
}
