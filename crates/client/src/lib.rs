//! # fs020n-client
//!
//! The PC side of protocol 1040: drives a Kawasaki FS020N arm through the AS server program on
//! its controller. It **fails closed**: nothing is sent that the user did not ask for, every
//! value is checked before it is sent, and every fault is reported with what to do about it.
//!
//! * [`Robot`] — the asynchronous (tokio) API; [`blocking::Robot`] — the same, blocking.
//! * One session task owns the connection: one write per request, strict lock-step, a reply
//!   deadline per request, keep-alive polls with a mismatched version (`0 0 0`) so the status
//!   is always fresh ([`Robot::status`], [`Robot::subscribe`]) and the controller's 5 s receive
//!   timeout is never hit.
//! * A lost link kills the handle with a typed error ([`ClientError::LinkLost`]); reconnecting
//!   is explicit ([`Robot::reconnect`]) and never resumes motion.
//! * Motion: [`Robot::move_joints`] / [`Robot::move_pose`] return a [`MoveHandle`] to wait for
//!   ([`Completion`]), watch or cancel ([`Robot::move_joints_and_wait`] does both in one call);
//!   [`Robot::stream`] streams a [`Trajectory`] with command 7 stamped by the estimated server
//!   clock ([`ServerClock`]) or with command 6, checked first by [`StreamOptions::validate`].
//! * Without a robot: the `sim` feature adds [`emulated::EmulatorConnector`], which connects to
//!   an emulated controller in the same process (`examples/emulated_tour.rs`,
//!   `examples/blocking_move.rs`).
//! * Safety: [`Robot::preflight`] lists every [`Blocker`] with its remedy; targets are checked
//!   against the robot model, speeds against 1–100 %, requests against 255 bytes, and every
//!   command-7 sample over everything the controller can extrapolate it to
//!   ([`check_stream_sample`]).
//! * Diagnostics: [`Robot::stats`] (round trips min/mean/p99/max, late replies, reconnects,
//!   underruns) and an optional recording of every request and reply ([`Recording`]).
//!
//! Architecture, clock estimation, error → remedy table and recording format:
//! `docs/CLIENT.md`.
//!
//! ```no_run
//! use fs020n_client::{ClientConfig, Completion, JointsDeg, Robot};
//! # async fn run() -> Result<(), fs020n_client::ClientError> {
//! let robot = Robot::connect("192.168.0.2:10050", ClientConfig::default()).await?;
//! robot.preflight().await?;
//! robot.set_speed(20.0).await?;
//! robot.start().await?;
//! let target = JointsDeg::new([10.0, 0.0, -90.0, 0.0, -90.0, 0.0]);
//! let report = robot.move_joints_and_wait(target, Completion::default()).await?;
//! println!("reached {} in {:?}", report.final_joints, report.elapsed);
//! robot.close().await?;
//! # Ok(()) }
//! ```
#![forbid(unsafe_code)]
#![warn(missing_docs)]

pub mod blocking;
mod check;
pub mod clock;
mod config;
mod curvature;
mod display;
#[cfg(feature = "sim")]
pub mod emulated;
mod error;
mod lag;
mod motion;
mod pacing;
mod record;
pub mod record_format;
mod robot;
mod safety;
pub mod servo;
mod session;
mod stats;
mod stream;
mod trajectory;
mod transport;

pub use clock::{ClockFit, ServerClock};
pub use config::{ClientConfig, RecordFormat, Recording};
pub use curvature::CurvatureCompensation;
pub use error::{Activity, Cancellation, ClientError, ErrorKind, LinkError, RawRefusal};
pub use lag::LagCompensation;
pub use motion::{Completion, MoveHandle, MoveProgress, MoveReport};
pub use pacing::{TargetPacing, MAX_HOLD_FRACTION, MIN_HOLD_FRACTION};
pub use record::{MCAP_CHUNK_INTERVAL, RECORD_QUEUE_LINES};
pub use robot::{Robot, STOP_SETTLE};
pub use safety::{
    blockers, check_stream_sample, extrapolation_window, Blocker, SampleError, ESTOP_REMEDY,
    EXTRAPOLATION_STEP_BOUND_S, MAX_LOOKAHEAD_PASSES,
};
pub use servo::{
    ServoHandle, ServoOptions, ServoOutcome, ServoReport, ServoSample, ServoStats, WatchdogAction,
};
pub use session::StatusSnapshot;
pub use stats::{RttStats, Stats, RTT_WINDOW};
pub use stream::{
    StreamHandle, StreamMode, StreamOptions, StreamOutcome, StreamProgress, StreamReport,
};
pub use trajectory::{OptionError, Trajectory, TrajectoryError, TrajectoryPoint, TrajectorySample};
pub use transport::{AsyncReadWrite, BoxedStream, ConnectFuture, Connector, TcpConnector};

pub use fs020n_kin::{Pose, Xyzoat};
pub use fs020n_proto::{ErrorCode, JointsDeg, ReplyFrame, Status};

/// The README's examples, compiled as doctests.
#[cfg(doctest)]
#[doc = include_str!("../README.md")]
struct ReadmeDoctests;

#[cfg(test)]
mod tests {
    fn send_sync<T: Send + Sync>() {}

    #[test]
    fn handles_can_cross_threads() {
        send_sync::<super::Robot>();
        send_sync::<super::MoveHandle>();
        send_sync::<super::StreamHandle>();
        send_sync::<super::blocking::Robot>();
        send_sync::<super::ClientError>();
        send_sync::<super::StatusSnapshot>();
    }
}
