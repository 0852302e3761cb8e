//! A serializable picture of the whole controller at one instant: what the pendant API returns
//! from `GET /state`, what the CLI prints, what tests compare.

use fs020n_as::{TaskInfo, TerminalLine};
use fs020n_kin::Xyzoat;
use fs020n_proto::{Command, ErrorCode, JointsDeg};
use std::time::Duration;

use serde::Serialize;

use crate::motion::MotionPhase;
use crate::panel::Panel;

/// Why a session ended.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum SessionEnd {
    /// The client sent 255.
    EndCommand,
    /// No request for 5 s.
    ReceiveTimeout,
    /// A reply could not be delivered within 2 s.
    SendTimeout,
    /// The client closed or reset the connection.
    Disconnected,
    /// Closed by fault injection.
    Fault,
}

/// Why a connection was refused.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum Refused {
    /// Between two listen windows.
    #[error("connection refused: the controller is between two listen windows")]
    ListenGap,
    /// Another client holds the session.
    #[error("connection refused: another client holds the session")]
    SessionOpen,
}

/// State of the motion program (robot task 1), as the protocol's field 7 and `TASK(1)` see
/// it. (An AS program's tasks report `fs020n_as::TaskState`, the same four values under the
/// interpreter's names.)
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum MotionTaskState {
    /// Not executing.
    NotRunning,
    /// Running.
    Running,
    /// Paused by HOLD.
    Paused,
    /// The program's steps are done (its loop ended after command 2 cleared the running flag)
    /// and it waits for the robot's last motion to finish.
    Finishing,
}

impl MotionTaskState {
    /// The value of AS `TASK(1)`: 0 not executing, 1 running, 2 paused, 3 steps done and
    /// waiting for the last motion.
    pub fn as_task_value(self) -> i32 {
        match self {
            MotionTaskState::NotRunning => 0,
            MotionTaskState::Running => 1,
            MotionTaskState::Paused => 2,
            MotionTaskState::Finishing => 3,
        }
    }
}

/// Counters, for observers and tests.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize)]
pub struct Counters {
    /// Connections accepted.
    pub sessions: u64,
    /// Connections refused (gap or session open).
    pub refused: u64,
    /// Requests received.
    pub requests: u64,
    /// Requests with version 1040.
    pub effective_requests: u64,
    /// Sessions ended by the receive timeout.
    pub receive_timeouts: u64,
    /// Passes of the motion program.
    pub passes: u64,
    /// Motions started (including blended ones).
    pub motions: u64,
    /// Errors raised.
    pub errors: u64,
    /// Times command 1 was ignored because the server's own test failed (a switch, TASK(1) = 1
    /// or an error).
    pub starts_ignored: u64,
    /// Times command 1 passed the server's test but `MC EXECUTE` was refused by the controller
    /// because the program was still executing (TASK(1) = 2 or 3: P1009).
    pub starts_refused: u64,
    /// Times the motion program stopped with E0102 because it read an argument never assigned
    /// since the controller started.
    pub undefined_arguments: u64,
}

/// What one pass of the motion program decided (for observers and tests).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct PassInfo {
    /// Controller time at the start of the pass.
    #[serde(serialize_with = "ser_duration_s")]
    pub at: Duration,
    /// The server clock `tm` the pass used (TIMER(2), seconds since accept, 1 ms resolution).
    pub tm_s: f64,
    /// `step` as the pass used it (before this pass updated it), seconds.
    pub step_s: f64,
    /// The command number the pass read (0 right after accept).
    pub command: f64,
    /// The motion the pass issued, if any.
    pub motion: Option<PassMotion>,
}

/// A motion issued by a pass.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct PassMotion {
    /// The target, degrees (for command 7: the extrapolated point `pt`).
    pub target: JointsDeg,
    /// JMOVE (`joint`) or LMOVE (`linear`).
    pub kind: MoveKind,
    /// For a JMOVE, the effective speed in percent of the joints' maximum speeds; for an
    /// LMOVE, the planned duration in seconds before stretching to respect joint speeds.
    pub speed: f64,
}

/// Interpolation of a motion.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum MoveKind {
    /// Joint-interpolated (JMOVE).
    Joint,
    /// Straight tool line (LMOVE).
    Linear,
}

fn ser_duration_s<S: serde::Serializer>(d: &Duration, s: S) -> Result<S::Ok, S::Error> {
    s.serialize_f64(d.as_secs_f64())
}

/// The controller's state at one instant.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Snapshot {
    /// Controller time since start, seconds.
    pub time_s: f64,
    /// Name of the robot model.
    pub model: String,
    /// Panel and pendant switches.
    pub panel: Panel,
    /// The current error.
    pub error: ErrorInfo,
    /// Joint angles (encoders), degrees.
    pub joints_deg: JointsDeg,
    /// Joint velocities, degrees per second.
    pub velocities_deg_s: JointsDeg,
    /// Flange pose in the base frame, as the pendant shows it.
    pub tool: Xyzoat,
    /// State of the motion program `ros_move` (robot task 1).
    pub task: MotionTaskState,
    /// What the arm is doing.
    pub motion: MotionPhase,
    /// `true` while a motion waits to blend in (the look-ahead of one motion).
    pub motion_planned: bool,
    /// The final target of the motion in progress, degrees (the joints when idle).
    pub motion_target_deg: JointsDeg,
    /// Monitor speed, percent.
    pub monitor_speed_percent: f64,
    /// `true` once command 3 has switched ABS.SPEED on (speed = min instead of product).
    pub abs_speed: bool,
    /// The program's average pass duration `step`, seconds (0 when not running).
    pub step_s: f64,
    /// What the latest pass of the motion program decided.
    pub last_pass: Option<PassInfo>,
    /// Conditions of command 1 that are not met (empty: command 1 would start the program).
    pub start_blockers: Vec<String>,
    /// The communication task.
    pub session: SessionInfo,
    /// Reply faults waiting to be applied.
    pub pending_faults: usize,
    /// Counters since start.
    pub counters: Counters,
    /// The AS program the controller runs instead of the native server (absent without one):
    /// its tasks, their lines and states, and the terminal.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub program: Option<ProgramInfo>,
}

/// An error as the pendant shows it.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ErrorInfo {
    /// The code as reply field 2 carries it (0 = none; E1088 = −31088).
    pub code: i32,
    /// The name, e.g. `"E1088"`, or `"none"`.
    pub name: String,
    /// The message, when known.
    pub message: Option<String>,
}

impl From<ErrorCode> for ErrorInfo {
    fn from(e: ErrorCode) -> Self {
        ErrorInfo {
            code: e.raw(),
            name: e.to_string(),
            message: e.message().map(str::to_owned),
        }
    }
}

/// The communication task's session.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SessionInfo {
    /// `true` while a client is connected.
    pub open: bool,
    /// The open session's id.
    pub id: Option<u64>,
    /// TIMER(1), seconds since accept (1 ms resolution); `None` without a session.
    pub timer1_s: Option<f64>,
    /// The newest request of the ring (command 0 right after accept).
    pub newest_command: Option<CommandInfo>,
    /// The ring index of the newest request (0–15).
    pub newest_index: Option<usize>,
    /// `true` while connections are accepted (a listen window, no session).
    pub listening: bool,
    /// `true` while fault injection keeps the task from reading.
    pub reading_paused: bool,
    /// How the latest session ended.
    pub last_end: Option<LastEnd>,
}

/// A command of the ring.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct CommandInfo {
    /// The command number (a real, as the server compares it).
    pub number: f64,
    /// The decoded command.
    pub command: Command,
}

/// How a session ended.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct LastEnd {
    /// The session.
    pub id: u64,
    /// Why.
    pub reason: SessionEnd,
}

/// The AS program as the pendant shows it.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ProgramInfo {
    /// The program file.
    pub name: String,
    /// The port served at the robot's address (the first the program listened on).
    pub served_port: Option<u16>,
    /// Every task: program, line, state, what it waits for.
    pub tasks: Vec<TaskInfo>,
    /// The latest terminal lines.
    pub terminal: Vec<TerminalLine>,
}
