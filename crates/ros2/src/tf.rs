//! `/tf` and `/tf_static` from the robot model: the URDF's joints as transforms, so that RViz
//! and MoveIt see the arm without a `robot_state_publisher` (which would publish a second
//! `robot_description`). The six revolute joints go to `/tf` with every joint state; the fixed
//! `flange` and `tool0` go to `/tf_static` once (transient local). Frame names are the URDF's
//! link names ([`fs020n_kin::urdf::URDF_LINK_NAMES`]).

use fs020n_kin::urdf::URDF_LINK_NAMES;
use fs020n_kin::{JointsRad, Pose, RobotModel};

use crate::msg::{Header, Quaternion, Time, Transform, TransformStamped, Vector3};

fn transform(parent: &Pose, child: &Pose) -> Transform {
    let local = parent.inverse() * *child;
    let p = local.position_m();
    let q = local.rotation();
    Transform {
        translation: Vector3 {
            x: p[0],
            y: p[1],
            z: p[2],
        },
        rotation: Quaternion {
            x: q.i,
            y: q.j,
            z: q.k,
            w: q.w,
        },
    }
}

/// Every link in its parent's frame at joints `q`: the six moving links first (for `/tf`),
/// then `flange` and `tool0` (for `/tf_static`).
pub fn link_transforms(model: &RobotModel, q: &JointsRad, stamp: Time) -> Vec<TransformStamped> {
    let frames = model.link_frames(q);
    (1..URDF_LINK_NAMES.len())
        .map(|i| TransformStamped {
            header: Header {
                stamp,
                frame_id: URDF_LINK_NAMES[i - 1].to_owned(),
            },
            child_frame_id: URDF_LINK_NAMES[i].to_owned(),
            transform: transform(&frames[i - 1], &frames[i]),
        })
        .collect()
}

/// Joint velocities, rad/s, from two successive replies: joints in degrees and the
/// controller's clock (TIMER(1)) in seconds. Empty when they cannot tell (no earlier reply, the
/// clock not advancing or jumping more than a second).
pub fn joint_velocities(previous: Option<(&[f64; 6], f64)>, current: (&[f64; 6], f64)) -> Vec<f64> {
    let Some((q0, t0)) = previous else {
        return Vec::new();
    };
    let (q1, t1) = current;
    let dt = t1 - t0;
    if !(dt > 1e-6 && dt <= 1.0) {
        return Vec::new();
    }
    q0.iter()
        .zip(q1.iter())
        .map(|(a, b)| (b - a).to_radians() / dt)
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn chaining_the_transforms_gives_the_flange_of_forward_kinematics() {
        let m = RobotModel::fs020n();
        let q = fs020n_kin::JointsDeg::new([30.0, 20.0, -60.0, 10.0, -45.0, 90.0]).to_rad();
        let mut pose = Pose::from_translation_m(0.0, 0.0, 0.0);
        for t in link_transforms(&m, &q, Time::default()).iter().take(7) {
            let v = t.transform.translation;
            let r = t.transform.rotation;
            let local = Pose::new(
                nalgebra::Vector3::new(v.x, v.y, v.z),
                nalgebra::UnitQuaternion::from_quaternion(nalgebra::Quaternion::new(
                    r.w, r.x, r.y, r.z,
                )),
            );
            pose = pose * local;
        }
        let fk = m.forward(&q);
        assert!(pose.distance_m(&fk) < 1e-12);
        assert!(pose.angle_to_rad(&fk) < 1e-9);
    }

    #[test]
    fn velocities_come_from_successive_replies_on_the_controller_clock() {
        let a = [0.0, 10.0, 0.0, 0.0, 0.0, 0.0];
        let b = [1.0, 10.0, 0.0, 0.0, 0.0, -2.0];
        let v = joint_velocities(Some((&a, 5.0)), (&b, 5.01));
        assert!((v[0] - 100f64.to_radians()).abs() < 1e-9);
        assert_eq!(v[1], 0.0);
        assert!((v[5] + 200f64.to_radians()).abs() < 1e-9);
        assert!(joint_velocities(None, (&b, 1.0)).is_empty());
        assert!(joint_velocities(Some((&a, 5.0)), (&b, 5.0)).is_empty());
        assert!(joint_velocities(Some((&a, 5.0)), (&b, 9.0)).is_empty());
    }
}
