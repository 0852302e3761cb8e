//! The controller's program memory (loaded, listed, deleted), the task stacks, the switches
//! and the interpreter built from the memory, as the monitor terminal operates them
//! (`terminal/` drives these; `store.rs` holds the memory; `tasks.rs` starts and stops tasks
//! and power-cycles; `sessions.rs` holds the terminal's sessions, transfers and output).
//!
//! Choices and limits (docs/EMULATOR.md, "The controller's terminal"):
//! - a program is *on a task's stack* from its start until `KILL`/`PCKILL`, unless it
//!   completed: a running, aborted or error-stopped program is on the stack, and so are the
//!   programs a running task has `CALL`ed and not yet returned from;
//! - when programs change, the interpreter takes the new programs at once, whether tasks run
//!   or not ([`fs020n_as::Interpreter::adopt`]): its tasks go on untouched, globals, signals
//!   and timers keep their values, the data sections of the file just loaded overwrite theirs
//!   (AS-E: a `LOAD` overwrites variables silently); the first programs of a bare controller
//!   build it. Should the running tasks not map onto the new programs (a program named by an
//!   armed interrupt was deleted), the new programs wait: a start is refused with P1014 until
//!   every task has stopped;
//! - a power cycle keeps the memory and the switches, closes every socket, stops every task,
//!   empties the stacks, restarts the interpreter (its timers and variables start again),
//!   clears the error (unless the emergency stop is pressed), turns motor power off and
//!   starts `autostart.pc` (… `autostart5.pc`) in PC task 1 (… 5) whose AUTOSTART switch is ON.

use std::collections::VecDeque;
use std::time::Duration;

use fs020n_as::ast::DataItem;
use fs020n_as::keywords::SYSTEM_SWITCHES;
use fs020n_as::{Interpreter, Refusal, TaskId};
use fs020n_term::text::{self, MonitorError};

use super::{Controller, Server};
use crate::machine::{Machine, OnTick};
use crate::program::ProgramServer;
use crate::snapshot::SessionInfo;
use crate::store::{sections, StoredProgram, AUTOSTART_SWITCHES};

/// Terminal lines kept for sessions that read them late.
pub(super) const OUTPUT_LINES: usize = 200;

/// The machine's tick with no server on it.
pub(crate) struct Idle;

impl OnTick for Idle {
    fn is_idle(&self) -> bool {
        true
    }
    fn deadline(&self) -> Option<Duration> {
        None
    }
    fn on_time(&mut self, _m: &mut Machine) {}
    fn before_motion(&mut self, _m: &mut Machine) {}
    fn after_motion(&mut self, _m: &mut Machine) {}
}

/// The session part of a snapshot without a server.
pub(crate) fn no_session() -> SessionInfo {
    SessionInfo {
        open: false,
        id: None,
        timer1_s: None,
        newest_command: None,
        newest_index: None,
        listening: false,
        reading_paused: false,
        last_end: None,
    }
}

/// What the monitor keeps beside the memory.
#[derive(Debug, Clone, Default)]
pub(crate) struct MonitorState {
    /// The program each task was started with ([robot, pc1 … pc5]), until killed.
    pub(crate) stacks: [Option<String>; 6],
    /// The task was aborted (its program stays on the stack until killed).
    pub(super) kept: [bool; 6],
    /// `PRIME program, cycles`: the robot program `CONTINUE` starts.
    pub(super) primed: Option<(String, i64)>,
    /// An abort waits for the task's current step: `PC program aborted.No = n` is printed
    /// when it stops.
    pub(super) aborting: [bool; 6],
    /// The memory generation the interpreter was built from.
    pub(crate) built: Option<u64>,
    /// Terminal slots AUX1–AUX3 in use.
    pub(super) sessions: [bool; text::MAX_SESSIONS],
    /// A transfer was abandoned: every LOAD/SAVE gets P2076 until a power cycle.
    pub(super) transfer_open: bool,
    /// Sessions in the middle of a transfer now.
    pub(super) transfers_running: usize,
    /// Loading a program whose name is in memory is refused (AS-E p.5-34) instead of
    /// overwriting it.
    pub(super) refuse_overwrite: bool,
    /// Lines the programs printed, numbered, for the terminal sessions.
    pub(super) output: VecDeque<(u64, String)>,
    pub(super) next_line: u64,
    /// The newest interpreter line taken: its time and how many lines had that time.
    pub(super) seen: (Duration, usize),
    /// The PC tasks that ran when the output was last taken (a completion is announced).
    pub(super) ran: [bool; 6],
    /// Bumped by every change the monitor makes (a network layer waits for it).
    pub(super) generation: u64,
}

/// What a `LOAD` did to the emulated controller's memory (the terminal client's view of a
/// load is `fs020n_term::LoadReport`).
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct MemoryLoad {
    /// The programs loaded: name and parameter text, in file order.
    pub loaded: Vec<(String, String)>,
    /// The programs not loaded, each with the monitor's error line.
    pub refused: Vec<(String, MonitorError)>,
    /// Errors to report in `File load completed. (N errors)`.
    pub errors: usize,
    /// Other lines the load printed.
    pub notes: Vec<String>,
}

/// What `ABORT`/`PCABORT` did.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Abort {
    /// The task did not run.
    NotRunning,
    /// The task stopped now.
    Stopped,
    /// The task stops when its current step completes.
    AfterStep,
}

/// What a power cycle started.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct PowerCycle {
    /// The autostart programs started: PC task and program.
    pub started: Vec<(u8, String)>,
    /// AUTOSTART switches ON whose program is not loaded: PC task and program.
    pub missing: Vec<(u8, String)>,
}

pub(super) fn task_index(task: TaskId) -> usize {
    match task {
        TaskId::Robot => 0,
        TaskId::Pc(n) => usize::from(n.clamp(1, 5)),
    }
}

pub(super) fn refusal_error(r: &Refusal) -> MonitorError {
    match r {
        Refusal::Controller { code, .. } => match code.0 {
            -11000 => text::P1000_POWER_OFF,
            -11001 => text::P1001_TEACH_MODE,
            -11002 => text::P1002_TEACH_LOCK,
            -11013 => text::P1013_IN_ERROR,
            _ => text::P1009_ALREADY_RUNNING,
        },
        Refusal::NoProgram(_) => text::P1038_NO_PROGRAM,
        Refusal::Other(_) => text::P1019_PC_RUNNING,
    }
}

/// The lines of a syntax check: `(line, text)` of each error in `file`'s text.
fn error_lines(err: &fs020n_as::LoadError, file: &str, text: &[u8]) -> Vec<(u32, String)> {
    let lines: Vec<&[u8]> = text.split(|&b| b == b'\n').collect();
    err.errors
        .iter()
        .map(|e| {
            let quoted = if &*e.file == file {
                lines
                    .get(e.span.line.saturating_sub(1) as usize)
                    .map(|l| String::from_utf8_lossy(l.trim_ascii()).into_owned())
                    .unwrap_or_else(|| e.message.clone())
            } else {
                e.message.clone()
            };
            (e.span.line, quoted)
        })
        .collect()
}

/// Why the interpreter could not take the memory's programs.
#[derive(Debug, thiserror::Error)]
enum AdoptError {
    #[error("the programs in memory do not build: {0}")]
    Build(fs020n_as::LoadError),
    #[error("{0}")]
    Reload(fs020n_as::ReloadError),
    #[error("no interpreter runs")]
    NoInterpreter,
}

/// The name the new text gets while it is checked.
const LOAD_FILE: &str = "load";

impl Controller {
    // ----------------------------------------------------------------- memory

    /// The syntax errors of an AS file (its bytes, in any code page) as the controller's
    /// `LOAD` finds them, with the programs in memory it would join: `(line, text)` each, in
    /// file order; empty when it loads.
    fn check_bytes(&self, text: &[u8]) -> Vec<(u32, String)> {
        // The controller knows its keywords: a step whose word is in no keyword table is a
        // syntax error of its LOAD (what loads as not emulated elsewhere).
        let strict = self.memory.load_options().clone().known_words_only();
        let load = self.memory.load_options();
        let m = match fs020n_as::parse_bytes(LOAD_FILE, text, &strict) {
            Ok(m) => m,
            Err(e) => return error_lines(&e, LOAD_FILE, text),
        };
        let replaced: Vec<String> = sections(text)
            .programs
            .into_iter()
            .map(|p| p.name)
            .collect();
        let replaced: Vec<&str> = replaced.iter().map(String::as_str).collect();
        let rest = self.memory.text_without(&replaced);
        let rest = match fs020n_as::parse_bytes("controller", &rest, load) {
            Ok(r) => r,
            Err(e) => return error_lines(&e, LOAD_FILE, text),
        };
        match Interpreter::new(&[rest, m], self.memory.config().clone()) {
            Ok(_) => Vec::new(),
            Err(e) => error_lines(&e, LOAD_FILE, text),
        }
    }

    /// [`MemoryMut::load`].
    fn load_bytes(&mut self, text: &[u8], comment_out: bool) -> MemoryLoad {
        let mut report = MemoryLoad::default();
        if matches!(self.server, Server::Native(_)) {
            report.errors = 1;
            report.notes.push(text::EMULATOR_NATIVE_NO_LOAD.to_owned());
            return report;
        }
        let mut text: Vec<u8> = text.iter().copied().filter(|&b| b != b'\r').collect();
        let errors = self.check_bytes(&text);
        if !errors.is_empty() {
            if !comment_out {
                report.errors = errors.len();
                return report;
            }
            report.errors = errors.len();
            let mut lines: Vec<Vec<u8>> = text.split(|&b| b == b'\n').map(<[u8]>::to_vec).collect();
            for (line, _) in &errors {
                if let Some(l) = lines.get_mut(line.saturating_sub(1) as usize) {
                    if !l.trim_ascii_start().starts_with(b".") {
                        l.splice(0..0, *b"; ");
                    }
                }
            }
            text = lines.join(&b'\n');
            if !self.check_bytes(&text).is_empty() {
                return report;
            }
        }
        let assigned = fs020n_as::parse_bytes(LOAD_FILE, &text, self.memory.load_options())
            .map(|m| m.data)
            .unwrap_or_default();
        let s = sections(&text);
        let mut aborted = false;
        for p in s.programs {
            if self.monitor.refuse_overwrite && self.memory.program(&p.name).is_some() {
                // AS-E p.5-34: programs are not overwritten; the LOAD is aborted here.
                report
                    .refused
                    .push((p.name.clone(), text::P1039_PROGRAM_EXISTS));
                report.errors += 1;
                aborted = true;
                break;
            }
            if self.on_any_stack(&p.name) {
                report.refused.push((p.name.clone(), text::P1014_IN_USE));
                report.errors += 1;
                continue;
            }
            report.loaded.push((p.name.clone(), p.params.clone()));
            self.memory.put(p);
        }
        if !aborted {
            for d in s.data {
                self.memory.put_data(d);
            }
        }
        self.bump();
        let _ = self.sync_runtime_assigning(&assigned);
        report
    }

    /// [`MemoryMut::define_pose`].
    fn define_pose_value(&mut self, name: &str, value: PoseValue) -> Result<(), MonitorError> {
        let (bare, section, values) = match value {
            PoseValue::Joints(v) => (name.strip_prefix('#'), "JOINTS", v),
            PoseValue::Trans(v) => (Some(name), "TRANS", v),
        };
        let valid = bare.is_some_and(|n| {
            n.starts_with(|c: char| c.is_ascii_alphabetic())
                && n.chars()
                    .all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '.')
                && n.len() <= 15
        });
        if !valid || !values.iter().all(|v| v.is_finite()) {
            return Err(text::P0117_INVALID_NAME);
        }
        let numbers: Vec<String> = values.iter().map(|v| format!("{v:.6}")).collect();
        let text = format!(".{section}\n{name} {}\n.END\n", numbers.join(" "));
        let assigned =
            fs020n_as::parse_bytes(LOAD_FILE, text.as_bytes(), self.memory.load_options())
                .map(|m| m.data)
                .map_err(|_| text::P0117_INVALID_NAME)?;
        self.memory.put_defined(name, text.into_bytes());
        self.bump();
        let _ = self.sync_runtime_assigning(&assigned);
        Ok(())
    }

    /// [`MemoryMut::delete`].
    fn delete_program(&mut self, name: &str) -> Result<(), MonitorError> {
        if self.on_any_stack(name) {
            return Err(text::P1018_KILL_FIRST);
        }
        if !self.memory.remove(name) {
            return Err(text::P1038_NO_PROGRAM);
        }
        self.bump();
        let _ = self.sync_runtime();
        Ok(())
    }

    /// `SYSINIT` (AS-E p.5-81): every program and variable deleted, the AS interpreter started
    /// anew over the empty memory (the switches stay). Refused while a task runs (P1009 the
    /// robot task, P1019 a PC task) or holds a program on its stack (P1018).
    fn initialize_memory(&mut self) -> Result<(), MonitorError> {
        for i in 0..6 {
            if self.task_facts(i).0 {
                return Err(if i == 0 {
                    text::P1009_ALREADY_RUNNING
                } else {
                    text::P1019_PC_RUNNING
                });
            }
        }
        if (0..6).any(|i| self.stack_program(i).is_some()) {
            return Err(text::P1018_KILL_FIRST);
        }
        self.memory.clear();
        self.monitor.stacks = Default::default();
        self.monitor.primed = None;
        self.bump();
        if matches!(self.server, Server::Program(_)) {
            self.rebuild(false)?;
        }
        Ok(())
    }

    /// Whether `name` is on a task's stack: the program a task was started with (see
    /// [`Controller::stack_program`]) or one a running task has `CALL`ed.
    pub(super) fn on_any_stack(&self, name: &str) -> bool {
        let name = name.to_ascii_lowercase();
        (0..6).any(|i| self.stack_program(i).as_deref() == Some(name.as_str()))
            || self
                .interpreter()
                .is_some_and(|i| i.programs_in_use().contains(&name.as_str()))
    }

    /// The program on the stack of task `i` (0 robot, 1–5 PC): the one the terminal started,
    /// or, for a task a program started (`MC EXECUTE`, `PCEXECUTE` in AS), the one it runs.
    pub(super) fn stack_program(&self, i: usize) -> Option<String> {
        let (running, error) = self.task_facts(i);
        let name = match self.monitor.stacks.get(i)?.clone() {
            Some(name) => name,
            None if running || error => self
                .server_program()?
                .tasks(&self.machine)
                .get(i)?
                .program
                .clone()?
                .to_ascii_lowercase(),
            None => return None,
        };
        (running || error || self.monitor.kept[i]).then_some(name)
    }

    /// Whether task `i` runs (or is paused or finishing), and whether an error stopped it.
    pub(super) fn task_facts(&self, i: usize) -> (bool, bool) {
        self.server_program()
            .and_then(|p| p.tasks(&self.machine).get(i).cloned())
            .map_or((false, false), |t| {
                (
                    t.state != fs020n_as::TaskState::Idle,
                    t.last_error.is_some(),
                )
            })
    }

    /// Brings the interpreter to the memory's programs if they changed: rebuilt when no task
    /// runs, taken by the running interpreter when one does; `Err(P1014)` when the running
    /// tasks do not map onto the new programs (they then wait until every task has stopped).
    pub(super) fn sync_runtime(&mut self) -> Result<(), MonitorError> {
        self.sync_runtime_assigning(&[])
    }

    /// [`Controller::sync_runtime`] after a `LOAD`: `assigned`, the data items of the file
    /// loaded, overwrite the variables they name when the running interpreter takes the
    /// programs (a rebuild applies every data section in memory anyway).
    fn sync_runtime_assigning(&mut self, assigned: &[DataItem]) -> Result<(), MonitorError> {
        if self.monitor.built == Some(self.memory.generation()) {
            return Ok(());
        }
        if matches!(self.server, Server::Native(_)) {
            return Ok(());
        }
        let running = (0..6).any(|i| self.task_facts(i).0);
        if self.server_program().is_none() {
            // The first programs of a bare controller: nothing to keep.
            return self.rebuild(false);
        }
        match self.adopt_memory(assigned) {
            Ok(()) => Ok(()),
            Err(e @ AdoptError::Build(_)) => {
                tracing::warn!(error = %e, "the programs in memory do not build");
                Err(text::P1038_NO_PROGRAM)
            }
            Err(e) if running => {
                tracing::warn!(error = %e, "the running tasks keep the programs they had");
                Err(text::P1014_IN_USE)
            }
            // No task runs, so nothing can fail to map: a rebuild is the safe fallback.
            Err(e) => {
                tracing::warn!(error = %e, "the interpreter is rebuilt from the memory");
                self.rebuild(false)
            }
        }
    }

    /// The interpreter takes the memory's programs ([`Interpreter::adopt`]), whether tasks run
    /// or not, as a controller's `LOAD` does: tasks, sockets, signals, timers, switches,
    /// global variables and terminal output stay as they are; the data sections of the file
    /// just loaded (`assigned`) overwrite the variables they name.
    fn adopt_memory(&mut self, assigned: &[DataItem]) -> Result<(), AdoptError> {
        let interp = self.memory.build().map_err(AdoptError::Build)?;
        let Some(p) = self.server_program_mut() else {
            return Err(AdoptError::NoInterpreter);
        };
        p.interpreter_mut()
            .adopt(interp, assigned)
            .map_err(AdoptError::Reload)?;
        self.monitor.built = Some(self.memory.generation());
        self.bump();
        Ok(())
    }

    /// A new interpreter over the memory (with the switches carried over); `restart` also
    /// closes every socket.
    pub(super) fn rebuild(&mut self, restart: bool) -> Result<(), MonitorError> {
        self.keep_switches();
        let mut interp = match self.memory.build() {
            Ok(i) => i,
            Err(e) => {
                tracing::warn!(error = %e, "the programs in memory do not build");
                return Err(text::P1038_NO_PROGRAM);
            }
        };
        for (name, on) in self.memory.system_switches() {
            interp.set_system_switch(name, *on);
        }
        match &mut self.server {
            Server::Program(p) => {
                if restart {
                    p.restart(interp, &mut self.machine);
                } else {
                    p.replace_interpreter(interp, &mut self.machine);
                }
            }
            _ => {
                let p = ProgramServer::idle(interp, "controller".into(), &mut self.machine);
                self.server = Server::Program(Box::new(p));
            }
        }
        self.monitor.built = Some(self.memory.generation());
        self.monitor.seen = (Duration::ZERO, 0);
        self.monitor.ran = [false; 6];
        self.bump();
        Ok(())
    }

    /// Copies the interpreter's system switches into memory (before it is replaced).
    pub(super) fn keep_switches(&mut self) {
        if let Some(p) = self.server_program() {
            let values: Vec<(&str, bool)> = SYSTEM_SWITCHES
                .iter()
                .filter_map(|(n, _)| p.interpreter().system_switch(n).map(|v| (*n, v)))
                .collect();
            for (n, v) in values {
                self.memory.set_system_switch(n, v);
            }
        }
    }

    pub(super) fn bump(&mut self) {
        self.monitor.generation = self.monitor.generation.wrapping_add(1);
    }

    /// Counts every change the monitor made (loads, starts, stops, power cycles): a network
    /// layer waits for it to change.
    pub(crate) fn monitor_generation(&self) -> u64 {
        self.monitor.generation
    }

    // ----------------------------------------------------------------- switches

    /// [`MemoryView::switch`].
    fn switch_of(&self, name: &str) -> Option<bool> {
        let upper = name.to_ascii_uppercase();
        if let Some(n) = (1u8..)
            .zip(AUTOSTART_SWITCHES)
            .find(|(_, (s, _, _))| *s == upper)
            .map(|(n, _)| n)
        {
            return Some(self.memory.autostart(n));
        }
        let lower = name.to_ascii_lowercase();
        if lower == "abs.speed" {
            return Some(self.abs_speed());
        }
        match self.server_program() {
            Some(p) => p.interpreter().system_switch(&lower),
            None => self
                .memory
                .system_switches()
                .iter()
                .find(|(n, _)| *n == lower)
                .map(|(_, v)| *v),
        }
    }

    /// [`MemoryMut::set_switch`].
    fn set_switch_to(&mut self, name: &str, on: bool) -> bool {
        let upper = name.to_ascii_uppercase();
        if let Some(n) = (1u8..)
            .zip(AUTOSTART_SWITCHES)
            .find(|(_, (s, _, _))| *s == upper)
            .map(|(n, _)| n)
        {
            self.memory.set_autostart(n, on);
            self.bump();
            return true;
        }
        let lower = name.to_ascii_lowercase();
        if self.switch_of(&lower).is_none() {
            return false;
        }
        self.memory.set_system_switch(&lower, on);
        if lower == "abs.speed" {
            self.set_abs_speed(on);
        } else if let Some(p) = self.server_program_mut() {
            p.interpreter_mut().set_system_switch(&lower, on);
        }
        self.bump();
        true
    }

    /// The interpreter, when the controller runs AS programs.
    pub(crate) fn interpreter(&self) -> Option<&Interpreter> {
        self.server_program().map(ProgramServer::interpreter)
    }

    /// The stored programs.
    pub(crate) fn stored_programs(&self) -> &[StoredProgram] {
        self.memory.programs()
    }
}

/// The program memory and switches of a [`Controller`], borrowed to read
/// ([`Controller::memory`]).
#[derive(Debug, Clone, Copy)]
pub struct MemoryView<'a> {
    pub(super) c: &'a Controller,
}

/// A pose variable's value as a monitor command defines it ([`MemoryMut::define_pose`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum PoseValue {
    /// Joint displacement values (`#name`), JT1…JT6 in degrees.
    Joints([f32; 6]),
    /// Transformation values (`name`): X, Y, Z in mm, O, A, T in degrees.
    Trans([f32; 6]),
}

impl PoseValue {
    /// The six values.
    pub fn values(&self) -> [f32; 6] {
        match self {
            PoseValue::Joints(v) | PoseValue::Trans(v) => *v,
        }
    }

    /// The same kind of value with `values`.
    pub fn with_values(self, values: [f32; 6]) -> PoseValue {
        match self {
            PoseValue::Joints(_) => PoseValue::Joints(values),
            PoseValue::Trans(_) => PoseValue::Trans(values),
        }
    }
}

/// The program memory and switches of a [`Controller`], borrowed to change
/// ([`Controller::memory_mut`]).
#[derive(Debug)]
pub struct MemoryMut<'a> {
    pub(super) c: &'a mut Controller,
}

impl<'a> MemoryView<'a> {
    /// The programs in memory, in load order (lower case).
    pub fn programs(&self) -> Vec<String> {
        (self.c.memory.programs().iter())
            .map(|p| p.name.clone())
            .collect()
    }

    /// A program's bytes as loaded, `.PROGRAM` to `.END`, LF line ends (in any code page:
    /// `String::from_utf8_lossy` shows them as text).
    pub fn program(&self, name: &str) -> Option<&'a [u8]> {
        self.c.memory.program(name).map(|p| p.text.as_slice())
    }

    /// The data sections in memory (`.REALS` … `.END`, …), as the bytes loaded (LF line
    /// ends).
    pub fn data_sections(&self) -> Vec<&'a [u8]> {
        self.c.memory.data().collect()
    }

    /// The syntax errors of an AS file (its bytes or text, in any code page) as the
    /// controller's `LOAD` finds them, with the programs in memory it would join:
    /// `(line, text)` each, in file order; empty when it loads.
    pub fn check(&self, text: impl AsRef<[u8]>) -> Vec<(u32, String)> {
        self.c.check_bytes(text.as_ref())
    }

    /// A switch by name (case-insensitive): AUTOSTART.PC … AUTOSTART5.PC, and the system
    /// switches the interpreter models (ABS.SPEED, CP, SCREEN, …). `None` for another name.
    pub fn switch(&self, name: &str) -> Option<bool> {
        self.c.switch_of(name)
    }

    /// Every switch with its state, AUTOSTART ones first (upper case, as `SWITCH` lists them).
    pub fn switches(&self) -> Vec<(String, bool)> {
        let mut out: Vec<(String, bool)> = (1u8..)
            .zip(AUTOSTART_SWITCHES)
            .map(|(n, (s, _, _))| (s.to_owned(), self.c.memory.autostart(n)))
            .collect();
        for (n, _) in SYSTEM_SWITCHES {
            if let Some(v) = self.c.switch_of(n) {
                out.push((n.to_ascii_uppercase(), v));
            }
        }
        out
    }

    /// `true` while a `LOAD`/`SAVE` is in progress in a terminal session, and once a transfer
    /// was abandoned (every `LOAD`/`SAVE` then gets P2076 until a power cycle).
    pub fn transfer_open(&self) -> bool {
        self.c.monitor.transfer_open || self.c.monitor.transfers_running > 0
    }
}

impl MemoryMut<'_> {
    /// Loads an AS file (its bytes or text, in any code page) into memory as `LOAD` does:
    /// each program is added (a program of the same name is overwritten) unless it is on a
    /// task's stack (P1014); data sections are added. With `comment_out`, the lines with
    /// syntax errors are commented out first (the answer `0` to the controller's question);
    /// without, a file with syntax errors loads nothing. The memory keeps the bytes (CR LF as
    /// LF), so `SAVE` gives back what was loaded. The programs take effect at once: the
    /// interpreter takes them (running tasks go on; the file's data sections overwrite the
    /// variables they name, other variables, signals and timers keep their values).
    pub fn load(&mut self, text: impl AsRef<[u8]>, comment_out: bool) -> MemoryLoad {
        self.c.load_bytes(text.as_ref(), comment_out)
    }

    /// Defines the pose variable `name` (`#name` for joint values) as the monitor's `HERE`
    /// does: a data section of its own in memory (`SAVE` writes it; a later definition of the
    /// name replaces it), and the running programs see the value at once. P0117 for a name
    /// that is not a variable's (or a `#` that does not match the value).
    pub fn define_pose(&mut self, name: &str, value: PoseValue) -> Result<(), MonitorError> {
        self.c.define_pose_value(name, value)
    }

    /// Deletes a program from memory (`DELETE/P`): P1018 while it is on a task's stack,
    /// P1038 when there is none.
    pub fn delete(&mut self, name: &str) -> Result<(), MonitorError> {
        self.c.delete_program(name)
    }

    /// `SYSINIT`: deletes every program and variable; refused while a task runs (P1009,
    /// P1019) or holds a program (P1018). The switches stay.
    pub fn initialize(&mut self) -> Result<(), MonitorError> {
        self.c.initialize_memory()
    }

    /// Sets a switch (see [`MemoryView::switch`]); `false` for an unknown name.
    pub fn set_switch(&mut self, name: &str, on: bool) -> bool {
        self.c.set_switch_to(name, on)
    }

    /// Whether a `LOAD` refuses a program whose name is in memory (AS-E p.5-34, the C/D
    /// terminal) instead of overwriting it (E/F captures, the default).
    pub(crate) fn set_refuse_overwrite(&mut self, refuse: bool) {
        self.c.monitor.refuse_overwrite = refuse;
    }
}
