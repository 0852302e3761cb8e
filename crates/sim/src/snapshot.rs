//! A serializable picture of the whole controller at one instant: what the pendant API returns
//! from `GET /state`, what the CLI prints, what tests compare.

use fs020n_kin::Xyzoat;
use fs020n_proto::{Command, ErrorCode, JointsDeg};
use serde::Serialize;

use crate::controller::{Controller, Counters, PassInfo, SessionEnd, TaskState};
use crate::motion::MotionPhase;
use crate::panel::Panel;

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
    pub task: TaskState,
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

impl Snapshot {
    /// Takes a snapshot of `c` (at its current time).
    pub fn of(c: &Controller) -> Snapshot {
        let model = c.model();
        let joints = c.joints();
        let x = model.forward(&joints.to_rad()).to_xyzoat();
        let session_open = c.session().is_some();
        Snapshot {
            time_s: c.now().as_secs_f64(),
            model: model.name().to_owned(),
            panel: c.panel(),
            error: c.error().into(),
            joints_deg: joints,
            velocities_deg_s: c.velocity(),
            tool: x,
            task: c.task(),
            motion: c.motion_phase(),
            motion_planned: c.robot().has_planned(),
            motion_target_deg: c.robot().target(),
            monitor_speed_percent: c.monitor_speed(),
            abs_speed: c.abs_speed(),
            step_s: c.step_s(),
            last_pass: c.last_pass(),
            start_blockers: c.start_blockers().into_iter().map(str::to_owned).collect(),
            session: SessionInfo {
                open: session_open,
                id: c.session().map(|s| s.0),
                timer1_s: session_open.then(|| c.timer1_s()),
                newest_command: c.newest_command().map(|cmd| CommandInfo {
                    number: cmd.number(),
                    command: cmd,
                }),
                newest_index: c.newest_index(),
                listening: c.is_listening(),
                reading_paused: c.reading_paused_until().is_some(),
                last_end: c
                    .last_session_end()
                    .map(|(id, reason)| LastEnd { id: id.0, reason }),
            },
            pending_faults: c.pending_faults(),
            counters: c.counters(),
        }
    }
}
