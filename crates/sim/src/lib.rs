//! # fs020n-sim
//!
//! An emulator of the Kawasaki FS020N controller running the protocol-1040 AS server program,
//! rule for rule (docs/EMULATOR.md).
//!
//! - [`Controller`]: the deterministic core (panel, error, communication task, motion program,
//!   arm), advanced by a clock it is given — virtual time in tests, real time for users.
//! - [`Emulator`]: the controller on a tokio clock, served over TCP with the controller's listen
//!   windows ([`Emulator::serve_tcp`]) or in memory ([`Emulator::connect`]).
//! - `serve_pendant` (default feature `pendant`): the pendant API (HTTP + JSON): state, switches, E-stop, reset, monitor
//!   speed, fault injection ([`Fault`]).
//! - [`run_robot`] with [`SimOptions`]: a whole robot (robot port + pendant) for a command line.
//! - [`Snapshot`]: the serializable state.
#![forbid(unsafe_code)]
#![warn(missing_docs)]

pub mod controller;
pub mod fault;
pub mod motion;
pub mod panel;
#[cfg(feature = "pendant")]
pub mod pendant;
pub mod run;
pub mod server;
pub mod snapshot;

pub use controller::{
    Behaviour, Controller, ControllerConfig, Counters, Handled, MoveKind, PanelChange, PanelError,
    PassInfo, PassMotion, PlannedAfterBrake, Refused, SessionEnd, SessionGone, SessionId,
    TaskState, Timing, PASS_TIME, SIGNAL_EDGE, TICK,
};
pub use fault::{Fault, ReplyFault};
pub use motion::MotionPhase;
pub use panel::Panel;
#[cfg(feature = "pendant")]
pub use pendant::{pendant_router, serve_pendant, PendantAccess, PendantServer};
pub use run::{run_robot, RunningRobot, SimOptions};
pub use server::{Emulator, TcpServer};
pub use snapshot::{CommandInfo, ErrorInfo, LastEnd, SessionInfo, Snapshot};

/// The README's examples, compiled as doctests.
#[cfg(doctest)]
#[doc = include_str!("../README.md")]
struct ReadmeDoctests;
