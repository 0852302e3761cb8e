//! The controller's kinematics in the interpreter's units: flange transformations as AS
//! `Trans` (X, Y, Z mm; O, A, T degrees, robot base frame) and joints in degrees, on a
//! [`RobotModel`]. Every [`System`](crate::System) with a robot model answers `HERE`, `POINT`
//! and the posture commands through these, so the emulator and the test system agree.

use fs020n_kin::{Pose, RobotModel, Xyzoat};
use fs020n_proto::JointsDeg;

use crate::system::{Joints, Trans};

/// An AS transformation as the kinematics' pose.
pub fn pose_of(t: &Trans) -> Pose {
    Pose::from_xyzoat(Xyzoat {
        x_mm: t[0],
        y_mm: t[1],
        z_mm: t[2],
        o_deg: t[3],
        a_deg: t[4],
        t_deg: t[5],
    })
}

/// The flange transformation of `joints`.
pub fn forward(model: &RobotModel, joints: &Joints) -> Trans {
    let x = model.forward(&JointsDeg(*joints).to_rad()).to_xyzoat();
    [x.x_mm, x.y_mm, x.z_mm, x.o_deg, x.a_deg, x.t_deg]
}

/// Every solution within the joint limits that puts the flange at `t`.
pub fn inverse_all(model: &RobotModel, t: &Trans) -> Vec<Joints> {
    match model.inverse_all(&pose_of(t)) {
        Ok(all) => all
            .iter()
            .map(|q| q.to_deg())
            .filter(|q| model.within_limits(q))
            .map(|q| q.0)
            .collect(),
        Err(_) => Vec::new(),
    }
}

/// The solution nearest `near` that puts the flange at `t`, `None` when out of reach or
/// outside the joint limits.
pub fn inverse(model: &RobotModel, t: &Trans, near: &Joints) -> Option<Joints> {
    let q = model
        .inverse_nearest(&pose_of(t), &JointsDeg(*near).to_rad())
        .ok()?
        .to_deg();
    model.within_limits(&q).then_some(q.0)
}
