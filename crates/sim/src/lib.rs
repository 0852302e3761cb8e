//! # fs020n-sim
//!
//! An emulator of the Kawasaki FS020N controller running the protocol-1040 AS server program,
//! rule for rule (docs/EMULATOR.md).
//!
//! - [`Controller`]: the deterministic core (a machine — clock, arm, panel, error, faults — and
//!   the server program on it), advanced by a clock it is given — virtual time in tests, real
//!   time for users. Its doc maps its API.
//! - [`Emulator`]: the controller on a tokio clock, served over TCP with the controller's listen
//!   windows ([`Emulator::serve_tcp`]) or in memory ([`Emulator::connect`]).
//! - `serve_pendant` (default feature `pendant`): the pendant API (HTTP + JSON): state,
//!   switches, E-stop, reset, monitor speed, fault injection ([`Fault`]); behind the HTTP guard
//!   (`RequestGuard`: Host, Origin, JSON POSTs, bearer token) that the web faces share.
//! - [`run_robot`] with [`SimOptions`]: a whole robot (robot port + pendant) for a command line.
//! - [`Snapshot`]: the serializable state.
//! - [`Controller::with_program`]: the controller running an AS program ([`ServerProgram`], e.g.
//!   this project's AS text of the protocol-1040 server, or a user's modified copy) instead of
//!   the native server, on the same machine: motion planner, panel, pendant and faults
//!   (docs/AS.md).
//!
//! - [`Controller::bare`] and the AS monitor terminal ([`TerminalLink`],
//!   [`Emulator::serve_terminal`]): a new controller that programs are loaded into, started,
//!   listed and saved through the terminal, and a power cycle ([`Controller::power_cycle`])
//!   that runs the AUTOSTART programs (docs/EMULATOR.md, "The controller's terminal").
//!
//! Inside, the arrows run one way: `controller` (the façade) over `native` (the native
//! protocol-1040 server) and `program` (the AS program server), both over `machine` (clock,
//! arm, panel, error, faults, counters), over `motion`, `fault`, `panel` and `snapshot`;
//! `controller` also holds `store` (the program memory and switches); `terminal` (the monitor
//! commands) drives the controller from above, as does the tokio side (`server`, `pendant`,
//! `run`).
#![forbid(unsafe_code)]
#![warn(missing_docs)]

mod controller;
mod fault;
#[cfg(feature = "pendant")]
mod guard;
mod machine;
mod motion;
mod native;
mod network;
mod panel;
#[cfg(feature = "pendant")]
mod pendant;
mod program;
mod run;
mod server;
mod snapshot;
mod store;
mod terminal;

pub use controller::{
    Abort, Controller, ImmediateRefusal, MemoryLoad, MemoryMut, MemoryView, NativeView, PoseValue,
    PowerCycle, ProgramMut, ProgramStart, ProgramView, StartSpecError,
};
pub use fault::{Fault, ReplyFault, MAX_FAULT_BYTES, MAX_FAULT_COUNT, MAX_FAULT_MS};
/// The terminal protocol the emulator's terminal speaks (its [`fs020n_term::SessionConfig`]
/// configures [`Emulator::serve_terminal`]).
pub use fs020n_term as term;
#[cfg(feature = "pendant")]
pub use guard::{GuardRefusal, PendantAccess, RequestGuard};
pub use machine::{
    Behaviour, ControllerConfig, PanelChange, PanelError, PlannedAfterBrake, Timing, LISTEN_GAP,
    PASS_TIME, SIGNAL_EDGE, TICK,
};
pub use motion::{
    Arm, CircularPath, CircularPlanError, HybridPath, LinearPath, Motion, MotionPhase, Shape,
    CIRCULAR_SAMPLE_DEG, HOLD_RAMP_S, LINEAR_MAX_JOINT_STEP_DEG, LINEAR_SAMPLE_DEG,
    LINEAR_SAMPLE_MM,
};
pub use native::{Handled, SessionGone, SessionId};
pub use network::{Network, PortMap, Route, UnlistedPorts, DEFAULT_ADDRESS};
pub use panel::Panel;
#[cfg(feature = "pendant")]
pub use pendant::{parse_fault, pendant_router, serve_pendant, ApiError, PendantServer};
pub use program::{
    ClientId, ClientRead, ProgramDial, ProgramError, ServerProgram, CLIENT_BUFFER,
    MAX_TOOL_SPEED_MM_S, SNAPSHOT_TERMINAL_LINES,
};
pub use run::{run_robot, RunningRobot, SimOptions};
pub use server::{
    Emulator, FleetServer, FleetStop, ProgramPorts, TcpServer, PIPE_CAPACITY, RECEIVE_BUFFER,
    SEND_BUFFER,
};
pub use snapshot::{
    CommandInfo, Counters, ErrorInfo, LastEnd, MotionTaskState, MoveKind, PassInfo, PassMotion,
    ProgramInfo, Refused, SessionEnd, SessionInfo, Snapshot,
};
pub use store::{AUTOSTART_SWITCHES, OVERWRITE_EXISTING};
pub use terminal::TerminalLink;

/// The README's examples, compiled as doctests.
#[cfg(doctest)]
#[doc = include_str!("../README.md")]
struct ReadmeDoctests;
