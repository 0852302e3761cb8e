//! # fs020n-kin
//!
//! Robot model, units, poses and kinematics of the Kawasaki FS020N 6-axis arm:
//!
//! - [`RobotModel`]: joint ranges, speeds, accelerations, geometry, home pose and controller
//!   defaults, loaded from a TOML model file (the FS020N defaults are embedded:
//!   [`RobotModel::fs020n`]).
//! - [`Pose`] and [`Xyzoat`]: positions in metres with rotations, and the AS
//!   X, Y, Z (mm), O, A, T (deg) representation.
//! - Forward and analytic inverse kinematics, the geometric Jacobian and singularity measures
//!   (methods of [`RobotModel`]).
//! - [`JointMove`]: time-optimal synchronized trapezoidal joint moves.
//! - [`CircularArc`]: the circular tool path through three poses (`C1MOVE`/`C2MOVE`).
//! - [`RobotModel::to_urdf`]: a URDF of the arm generated from the model (ROS, Foxglove).
//!
//! Frames, signs and formulas: `docs/KINEMATICS.md`.
//!
//! ```
//! use fs020n_kin::{RobotModel, Xyzoat};
//! let model = RobotModel::fs020n();
//! let flange = model.forward(&model.home.to_rad()).to_xyzoat();
//! assert!((flange.x_mm - 850.0).abs() < 1e-9 && (flange.z_mm - 1153.5).abs() < 1e-9);
//! assert!((flange.a_deg - 180.0).abs() < 1e-9);
//! let back = model.inverse_nearest(&fs020n_kin::Pose::from_xyzoat(flange), &model.home.to_rad())?;
//! assert!(back.to_deg().max_abs_diff(&model.home) < 1e-9);
//! # Ok::<(), fs020n_kin::IkError>(())
//! ```
#![forbid(unsafe_code)]
#![warn(missing_docs)]

pub mod arc;
pub mod kinematics;
pub mod model;
pub mod motion;
pub mod pose;
pub mod urdf;

pub use arc::{ArcError, CircularArc, ARC_MIN_BULGE_M, ARC_MIN_POINT_DISTANCE_M};
pub use fs020n_proto::{JointsDeg, JointsRad, JOINT_COUNT};
pub use kinematics::{
    FlangeNear, IkError, IkSolutions, SingularityMargins, IK_MAX_SOLUTIONS,
    PROTOCOL_SINGULAR_MARGIN_DEG,
};
pub use model::{
    ControllerDefaults, FilePosition, Geometry, JointSpec, LimitError, ModelError, RobotModel,
    FS020N_TOML, RATED_PAYLOAD_KG,
};
pub use motion::{JointMove, MotionError};
pub use pose::{Pose, Xyzoat};
pub use urdf::URDF_JOINT_NAMES;

/// The README's examples, compiled as doctests.
#[cfg(doctest)]
#[doc = include_str!("../README.md")]
struct ReadmeDoctests;
