//! Forward and inverse kinematics of the FS020N model.

use fs020n_kin::{IkError, JointsDeg, Pose, RobotModel, Xyzoat};
use pyo3::prelude::*;

use crate::errors::limit_error;
use crate::six;

fn model() -> &'static RobotModel {
    static MODEL: std::sync::OnceLock<RobotModel> = std::sync::OnceLock::new();
    MODEL.get_or_init(RobotModel::fs020n)
}

/// The flange pose (X, Y, Z in mm; O, A, T in degrees, AS convention) of the FS020N at
/// these joints (degrees).
///
/// ```python
/// fs020n.fk([0, 0, -90, 0, -90, 0])
/// (850.0, 0.0, 1153.5, 0.0, 180.0, 0.0)
/// ```
#[pyfunction]
#[pyo3(signature = (joints))]
pub fn fk(py: Python<'_>, joints: &Bound<'_, PyAny>) -> PyResult<(f64, f64, f64, f64, f64, f64)> {
    let q = JointsDeg::new(six(joints, "joints")?);
    if !q.is_finite() {
        return Err(limit_error(py, "the joints must be finite numbers"));
    }
    Ok(pose_of(&q))
}

/// The flange pose of joints (degrees) as (X, Y, Z, O, A, T).
pub(crate) fn pose_of(q: &JointsDeg) -> (f64, f64, f64, f64, f64, f64) {
    let p = model().forward(&q.to_rad()).to_xyzoat().to_array();
    // -0.0 prints as such; report it as 0.
    let z = |v: f64| if v == 0.0 { 0.0 } else { v };
    (z(p[0]), z(p[1]), z(p[2]), z(p[3]), z(p[4]), z(p[5]))
}

/// Every joint solution (degrees, inside the joint ranges) that puts the flange at `pose`
/// (X, Y, Z in mm; O, A, T in degrees). With `near` (joints, degrees) the solutions are
/// sorted nearest first (the first is what `Robot.move_pose` would use). An unreachable pose
/// gives an empty list; non-finite values raise `LimitError`.
///
/// ```python
/// fs020n.ik((850, 0, 1153.5, 0, 180, 0), near=[0, 0, -90, 0, -90, 0])[0]
/// [0.0, 0.0, -90.0, 0.0, -90.0, 0.0]
/// ```
#[pyfunction]
#[pyo3(signature = (pose, near=None))]
pub fn ik(
    py: Python<'_>,
    pose: &Bound<'_, PyAny>,
    near: Option<&Bound<'_, PyAny>>,
) -> PyResult<Vec<Vec<f64>>> {
    let p = six(pose, "pose")?;
    let target = Xyzoat::new(p[0], p[1], p[2], p[3], p[4], p[5]);
    if !target.is_finite() {
        return Err(limit_error(py, "the pose must be finite numbers"));
    }
    let seed = match near {
        Some(n) => {
            let q = JointsDeg::new(six(n, "near")?);
            if !q.is_finite() {
                return Err(limit_error(py, "near must be finite joint values"));
            }
            Some(q)
        }
        None => None,
    };
    let pose = Pose::from_xyzoat(target);
    let found = match seed {
        Some(q) => model().inverse_all_seeded(&pose, &q.to_rad()),
        None => model().inverse_all(&pose),
    };
    let mut solutions: Vec<JointsDeg> = match found {
        Ok(s) => s.as_slice().iter().map(|q| q.to_deg()).collect(),
        Err(IkError::OutOfReach { .. } | IkError::OutsideLimits { .. }) => Vec::new(),
        Err(e) => return Err(limit_error(py, &e.to_string())),
    };
    if let Some(q) = seed {
        let d = |s: &JointsDeg| {
            s.iter()
                .zip(q.iter())
                .map(|(a, b)| (a - b).powi(2))
                .sum::<f64>()
        };
        solutions.sort_by(|a, b| d(a).total_cmp(&d(b)));
    }
    Ok(solutions
        .into_iter()
        .map(|q| q.iter().map(|v| if v == 0.0 { 0.0 } else { v }).collect())
        .collect())
}

/// The joint ranges of the FS020N model: six (min, max) pairs in degrees.
#[pyfunction]
pub fn joint_limits() -> Vec<(f64, f64)> {
    model()
        .joints
        .iter()
        .map(|j| (j.min_deg, j.max_deg))
        .collect()
}
