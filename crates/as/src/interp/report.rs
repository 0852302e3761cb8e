//! What the interpreter reports: task states, terminal and trace lines, refusals.

use std::time::Duration;

use fs020n_proto::ErrorCode;
use serde::Serialize;

use crate::system::TaskId;

/// What `TASK(n)` returns.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum TaskState {
    /// 0: not executing.
    Idle,
    /// 1: running.
    Running,
    /// 2: paused (HOLD, `MC HOLD`, `PAUSE`).
    Paused,
    /// 3: every step done, waiting for the robot's motion to finish.
    WaitingMotion,
}

impl TaskState {
    /// The number `TASK(n)` returns.
    pub fn number(self) -> f32 {
        match self {
            TaskState::Idle => 0.0,
            TaskState::Running => 1.0,
            TaskState::Paused => 2.0,
            TaskState::WaitingMotion => 3.0,
        }
    }
}

/// A task as the pendant shows it.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct TaskInfo {
    /// `robot` or `pc1` … `pc5`.
    pub task: String,
    /// What `TASK(n)` returns.
    pub state: TaskState,
    /// The program (the innermost one when a CALL is in progress).
    pub program: Option<String>,
    /// The program the task was started with (the outermost of its calls).
    pub main: Option<String>,
    /// The source line about to execute (or waiting).
    pub line: Option<u32>,
    /// Its text.
    pub text: Option<String>,
    /// What the task waits for, if anything.
    pub waiting: Option<String>,
    /// The error that last stopped it.
    pub last_error: Option<String>,
    /// Steps executed since start.
    pub steps: u64,
}

/// A terminal line (`PRINT`/`TYPE`, or a controller message).
#[derive(Debug, Clone, PartialEq, Eq, Serialize)]
pub struct TerminalLine {
    /// When, since the interpreter started.
    #[serde(serialize_with = "ser_secs")]
    pub at: Duration,
    /// Which task printed it.
    pub task: TaskId,
    /// The text.
    pub text: String,
}

/// One executed step (see [`Interpreter::set_trace`](crate::Interpreter::set_trace)).
#[derive(Debug, Clone, PartialEq, Eq, Serialize)]
pub struct TraceLine {
    /// When it executed.
    #[serde(serialize_with = "ser_secs")]
    pub at: Duration,
    /// The task.
    pub task: TaskId,
    /// The program.
    pub program: String,
    /// The source line.
    pub line: u32,
    /// Its text.
    pub text: String,
}

impl std::fmt::Display for TraceLine {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "{:>10.4} {:<5} {}:{} {}",
            self.at.as_secs_f64(),
            self.task.to_string(),
            self.program,
            self.line,
            self.text.trim()
        )
    }
}

pub(super) fn ser_secs<S: serde::Serializer>(d: &Duration, s: S) -> Result<S::Ok, S::Error> {
    s.serialize_f64(d.as_secs_f64())
}

/// Why a monitor command (`EXECUTE`, `PCEXECUTE`, …) was refused.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum Refusal {
    /// The controller refuses with a P code (P1000 power off, P1001 TEACH, P1002 teach lock,
    /// P1013 in error, P1009 already running).
    #[error("({code}) {message}")]
    Controller {
        /// The code.
        code: ErrorCode,
        /// Its message.
        message: String,
    },
    /// No program of that name is loaded.
    #[error("program {0} is not loaded")]
    NoProgram(String),
    /// Another refusal (wrong task number, …).
    #[error("{0}")]
    Other(String),
}

/// Why a statement typed at the terminal ([`Interpreter::immediate`]) did not run to its end.
///
/// [`Interpreter::immediate`]: super::Interpreter::immediate
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum ImmediateError {
    /// It does not parse or compile (the loader's message).
    #[error("{0}")]
    Syntax(String),
    /// It stopped with a runtime error: its code and the interpreter's text, as a program's
    /// error is reported (`(E0102) …`).
    #[error("{text}")]
    Runtime {
        /// The error's code.
        code: ErrorCode,
        /// The text, code first.
        text: String,
    },
    /// It would wait (a motion, `TWAIT`, `SWAIT`, a socket call that blocks): the terminal
    /// runs a statement to its end at once; such a statement belongs in a program.
    #[error("{0} waits: the terminal runs a statement at once (put it in a program and EXECUTE or PCEXECUTE it)")]
    Waits(String),
}

/// Why a running interpreter did not take a new set of programs ([`Interpreter::adopt`]):
/// the running tasks could not be mapped onto the new programs. Nothing was changed.
///
/// [`Interpreter::adopt`]: super::Interpreter::adopt
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum ReloadError {
    /// A task is in a program (the one it was started with, or one it `CALL`ed) that the new
    /// set does not hold.
    #[error(
        "{task} is running program {program}, which the new programs do not hold: \
         stop the task (PCABORT/ABORT) before removing the program"
    )]
    ProgramMissing {
        /// The task (`robot`, `pc1` … `pc5`).
        task: String,
        /// The program.
        program: String,
    },
    /// A task is in a program whose text in the new set differs: its place in the program
    /// (step, local variables) would not mean the same.
    #[error(
        "{task} is running program {program}, whose new text differs: \
         stop the task (PCABORT/ABORT) before replacing the program"
    )]
    ProgramChanged {
        /// The task.
        task: String,
        /// The program.
        program: String,
    },
    /// An interrupt armed in a task (`ON … CALL`) or its error program (`ONE`) names a
    /// program the new set does not hold.
    #[error(
        "{task} has an interrupt or error program naming {program}, which the new programs \
         do not hold: stop the task (PCABORT/ABORT) before removing the program"
    )]
    HandlerMissing {
        /// The task.
        task: String,
        /// The program.
        program: String,
    },
}

pub(super) fn p_code(code: i32, message: &str) -> Refusal {
    Refusal::Controller {
        code: ErrorCode(code),
        message: message.to_owned(),
    }
}
