//! The controller's program memory, task stacks, switches and power cycle, as the monitor
//! terminal operates them (`terminal/` drives these; `store.rs` holds the memory).
//!
//! Choices and limits (docs/EMULATOR.md, "The controller's terminal"):
//! - a program is *on a task's stack* from its start until `KILL`/`PCKILL`, unless it
//!   completed: a running, aborted or error-stopped program is on the stack (only the
//!   program a task was started with is tracked, not those it `CALL`s);
//! - the interpreter is rebuilt from the memory when programs change and no task runs; while
//!   a task runs, the new programs wait (a start of any program is then refused with P1014
//!   until every task has stopped);
//! - a power cycle keeps the memory and the switches, closes every socket, stops every task,
//!   empties the stacks, restarts the interpreter (its timers and variables start again),
//!   clears the error (unless the emergency stop is pressed), turns motor power off and
//!   starts `autostart.pc` (… `autostart5.pc`) in PC task 1 (… 5) whose AUTOSTART switch is ON.

use std::collections::VecDeque;
use std::time::Duration;

use fs020n_as::keywords::SYSTEM_SWITCHES;
use fs020n_as::{Interpreter, Refusal, TaskId};
use fs020n_term::text::{self, MonitorError};

use super::{Controller, Server};
use crate::machine::{Machine, OnTick};
use crate::native::NativeServer;
use crate::program::ProgramServer;
use crate::snapshot::SessionInfo;
use crate::store::{sections, StoredProgram, AUTOSTART_SWITCHES};

/// Terminal lines kept for sessions that read them late.
const OUTPUT_LINES: usize = 200;

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
    kept: [bool; 6],
    /// The memory generation the interpreter was built from.
    pub(crate) built: Option<u64>,
    /// Terminal slots AUX1–AUX3 in use.
    sessions: [bool; text::MAX_SESSIONS],
    /// A transfer was abandoned: every LOAD/SAVE gets P2076 until a power cycle.
    transfer_open: bool,
    /// Sessions in the middle of a transfer now.
    transfers_running: usize,
    /// Lines the programs printed, numbered, for the terminal sessions.
    output: VecDeque<(u64, String)>,
    next_line: u64,
    /// The newest interpreter line taken: its time and how many lines had that time.
    seen: (Duration, usize),
    /// The PC tasks that ran when the output was last taken (a completion is announced).
    ran: [bool; 6],
    /// Bumped by every change the monitor makes (a network layer waits for it).
    generation: u64,
}

/// What a `LOAD` did.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct LoadReport {
    /// The programs loaded: name and parameter text, in file order.
    pub loaded: Vec<(String, String)>,
    /// The programs not loaded, each with the monitor's error line.
    pub refused: Vec<(String, MonitorError)>,
    /// Errors to report in `File load completed. (N errors)`.
    pub errors: usize,
    /// Other lines the load printed.
    pub notes: Vec<String>,
}

/// What a power cycle started.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct PowerCycle {
    /// The autostart programs started: PC task and program.
    pub started: Vec<(u8, String)>,
    /// AUTOSTART switches ON whose program is not loaded: PC task and program.
    pub missing: Vec<(u8, String)>,
}

fn task_index(task: TaskId) -> usize {
    match task {
        TaskId::Robot => 0,
        TaskId::Pc(n) => usize::from(n.clamp(1, 5)),
    }
}

fn refusal_error(r: &Refusal) -> MonitorError {
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
fn error_lines(err: &fs020n_as::LoadError, file: &str, text: &str) -> Vec<(u32, String)> {
    let lines: Vec<&str> = text.split('\n').collect();
    err.errors
        .iter()
        .map(|e| {
            let quoted = if &*e.file == file {
                lines
                    .get(e.span.line.saturating_sub(1) as usize)
                    .map(|l| l.trim().to_owned())
                    .unwrap_or_else(|| e.message.clone())
            } else {
                e.message.clone()
            };
            (e.span.line, quoted)
        })
        .collect()
}

/// The name the new text gets while it is checked.
const LOAD_FILE: &str = "load";

impl Controller {
    // ----------------------------------------------------------------- memory

    /// The programs in memory, in load order (lower case).
    pub fn loaded_programs(&self) -> Vec<String> {
        self.memory
            .programs()
            .iter()
            .map(|p| p.name.clone())
            .collect()
    }

    /// A program's text, `.PROGRAM` to `.END`.
    pub fn program_text(&self, name: &str) -> Option<String> {
        self.memory.program(name).map(|p| p.text.clone())
    }

    /// The data sections in memory (`.REALS` … `.END`, …).
    pub fn data_sections(&self) -> Vec<String> {
        self.memory.data().to_vec()
    }

    /// The syntax errors of an AS file as the controller's `LOAD` finds them, with the
    /// programs in memory it would join: `(line, text)` each, in file order; empty when it
    /// loads.
    pub fn check_program_text(&self, text: &str) -> Vec<(u32, String)> {
        let m = match fs020n_as::parse(LOAD_FILE, text) {
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
        let rest = match fs020n_as::parse("controller", &rest) {
            Ok(r) => r,
            Err(e) => return error_lines(&e, LOAD_FILE, text),
        };
        match Interpreter::new(&[rest, m], self.memory.config().clone()) {
            Ok(_) => Vec::new(),
            Err(e) => error_lines(&e, LOAD_FILE, text),
        }
    }

    /// Loads an AS file into memory as `LOAD` does: each program is added (a program of the
    /// same name is overwritten) unless it is on a task's stack (P1014); data sections are
    /// added. With `comment_out`, the lines with syntax errors are commented out first (the
    /// answer `0` to the controller's question); without, a file with syntax errors loads
    /// nothing. The interpreter is rebuilt now if no task runs (else when they have stopped).
    pub fn load_program_text(&mut self, text: &str, comment_out: bool) -> LoadReport {
        let mut report = LoadReport::default();
        if matches!(self.server, Server::Native(_)) {
            report.errors = 1;
            report.notes.push(text::EMULATOR_NATIVE_NO_LOAD.to_owned());
            return report;
        }
        let mut text = text.replace('\r', "");
        let errors = self.check_program_text(&text);
        if !errors.is_empty() {
            if !comment_out {
                report.errors = errors.len();
                return report;
            }
            report.errors = errors.len();
            let mut lines: Vec<String> = text.split('\n').map(str::to_owned).collect();
            for (line, _) in &errors {
                if let Some(l) = lines.get_mut(line.saturating_sub(1) as usize) {
                    if !l.trim_start().starts_with('.') {
                        *l = format!("; {l}");
                    }
                }
            }
            text = lines.join("\n");
            if !self.check_program_text(&text).is_empty() {
                return report;
            }
        }
        let s = sections(&text);
        for p in s.programs {
            if self.on_any_stack(&p.name) {
                report.refused.push((p.name.clone(), text::P1014_IN_USE));
                report.errors += 1;
                continue;
            }
            report.loaded.push((p.name.clone(), p.params.clone()));
            self.memory.put(p);
        }
        for d in s.data {
            self.memory.put_data(d);
        }
        self.bump();
        let _ = self.sync_runtime();
        report
    }

    /// Deletes a program from memory (`DELETE/P`): P1018 while it is on a task's stack,
    /// P1038 when there is none.
    pub fn delete_program(&mut self, name: &str) -> Result<(), MonitorError> {
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

    fn on_any_stack(&self, name: &str) -> bool {
        let name = name.to_ascii_lowercase();
        (0..6).any(|i| self.stack_program(i).as_deref() == Some(name.as_str()))
    }

    /// The program on the stack of task `i` (0 robot, 1–5 PC).
    fn stack_program(&self, i: usize) -> Option<String> {
        let name = self.monitor.stacks.get(i)?.clone()?;
        let (running, error) = self.task_facts(i);
        (running || error || self.monitor.kept[i]).then_some(name)
    }

    /// Whether task `i` runs (or is paused or finishing), and whether an error stopped it.
    fn task_facts(&self, i: usize) -> (bool, bool) {
        self.program()
            .and_then(|p| p.tasks(&self.machine).get(i).cloned())
            .map_or((false, false), |t| {
                (
                    t.state != fs020n_as::TaskState::Idle,
                    t.last_error.is_some(),
                )
            })
    }

    /// `true` while `task` runs (running, paused or finishing its motion).
    pub fn task_running(&self, task: TaskId) -> bool {
        self.task_facts(task_index(task)).0
    }

    /// The program on `task`'s stack: started and not killed (and not completed).
    pub fn task_program(&self, task: TaskId) -> Option<String> {
        self.stack_program(task_index(task))
    }

    /// Rebuilds the interpreter from memory if the programs changed and no task runs;
    /// `Err(P1014)` when a task runs and programs wait.
    fn sync_runtime(&mut self) -> Result<(), MonitorError> {
        if self.monitor.built == Some(self.memory.generation()) {
            return Ok(());
        }
        if matches!(self.server, Server::Native(_)) {
            return Ok(());
        }
        if (0..6).any(|i| self.task_facts(i).0) {
            return Err(text::P1014_IN_USE);
        }
        self.rebuild(false)
    }

    /// A new interpreter over the memory (with the switches carried over); `restart` also
    /// closes every socket.
    fn rebuild(&mut self, restart: bool) -> Result<(), MonitorError> {
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
    fn keep_switches(&mut self) {
        if let Some(p) = self.program() {
            let values: Vec<(&str, bool)> = SYSTEM_SWITCHES
                .iter()
                .filter_map(|(n, _)| p.interpreter().system_switch(n).map(|v| (*n, v)))
                .collect();
            for (n, v) in values {
                self.memory.set_system_switch(n, v);
            }
        }
    }

    fn bump(&mut self) {
        self.monitor.generation = self.monitor.generation.wrapping_add(1);
    }

    /// Counts every change the monitor made (loads, starts, stops, power cycles).
    pub fn monitor_generation(&self) -> u64 {
        self.monitor.generation
    }

    // ----------------------------------------------------------------- tasks

    /// `PCEXECUTE task: program`: P1019 while the task runs, P1038 without the program, P1014
    /// when the program runs in another task (or programs loaded while tasks ran wait).
    pub fn pc_execute(&mut self, task: u8, program: &str) -> Result<(), MonitorError> {
        let name = program.to_ascii_lowercase();
        if !(1..=5).contains(&task) {
            return Err(text::P1019_PC_RUNNING);
        }
        if self.task_facts(usize::from(task)).0 {
            return Err(text::P1019_PC_RUNNING);
        }
        if self.memory.program(&name).is_none() {
            return Err(text::P1038_NO_PROGRAM);
        }
        if (0..6).any(|i| self.task_facts(i).0 && self.monitor.stacks[i].as_deref() == Some(&name))
        {
            return Err(text::P1014_IN_USE);
        }
        self.sync_runtime()?;
        let p = self.program_mut().ok_or(text::P1038_NO_PROGRAM)?;
        p.interpreter_mut()
            .pc_execute(task, &name)
            .map_err(|r| refusal_error(&r))?;
        let i = usize::from(task);
        self.monitor.stacks[i] = Some(name);
        self.monitor.kept[i] = false;
        self.bump();
        Ok(())
    }

    /// `PCABORT task:`: stops the task (its program stays on the stack); `false` when it did
    /// not run.
    pub fn pc_abort(&mut self, task: u8) -> bool {
        let i = usize::from(task.clamp(1, 5));
        self.abort_task(TaskId::Pc(task.clamp(1, 5)), i)
    }

    fn abort_task(&mut self, task: TaskId, i: usize) -> bool {
        if !self.task_facts(i).0 {
            return false;
        }
        if let Some(p) = self.program_mut() {
            p.interpreter_mut().abort(task);
        }
        self.monitor.kept[i] = true;
        self.bump();
        true
    }

    /// `PCKILL task:` (and `KILL` for the robot task): takes the program off the stack;
    /// P1026 while it runs.
    pub fn kill_task(&mut self, task: TaskId) -> Result<(), MonitorError> {
        let i = task_index(task);
        if self.task_facts(i).0 {
            return Err(text::P1026_CANNOT_KILL_RUNNING);
        }
        self.monitor.stacks[i] = None;
        self.monitor.kept[i] = false;
        self.bump();
        let _ = self.sync_runtime();
        Ok(())
    }

    /// `EXECUTE program` in robot task 1, with the controller's checks (power, REPEAT, teach
    /// lock, error, already running).
    pub fn execute_program(&mut self, program: &str) -> Result<(), MonitorError> {
        let name = program.to_ascii_lowercase();
        if self.task_facts(0).0 {
            return Err(text::P1009_ALREADY_RUNNING);
        }
        if self.memory.program(&name).is_none() {
            return Err(text::P1038_NO_PROGRAM);
        }
        self.sync_runtime()?;
        let Server::Program(p) = &mut self.server else {
            return Err(text::P1038_NO_PROGRAM);
        };
        p.execute(&mut self.machine, &name)
            .map_err(|r| refusal_error(&r))?;
        self.monitor.stacks[0] = Some(name);
        self.monitor.kept[0] = false;
        self.bump();
        Ok(())
    }

    /// `ABORT`: stops the robot program (the motion in progress ends as braked); `false` when
    /// it did not run.
    pub fn abort_program(&mut self) -> bool {
        let stopped = self.abort_task(TaskId::Robot, 0);
        if stopped {
            self.machine.brake();
        }
        stopped
    }

    // ----------------------------------------------------------------- switches

    /// A switch by name (case-insensitive): AUTOSTART.PC … AUTOSTART5.PC, and the system
    /// switches the interpreter models (ABS.SPEED, CP, SCREEN, …). `None` for another name.
    pub fn switch(&self, name: &str) -> Option<bool> {
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
        match self.program() {
            Some(p) => p.interpreter().system_switch(&lower),
            None => self
                .memory
                .system_switches()
                .iter()
                .find(|(n, _)| *n == lower)
                .map(|(_, v)| *v),
        }
    }

    /// Sets a switch (see [`Controller::switch`]); `false` for an unknown name.
    pub fn set_switch(&mut self, name: &str, on: bool) -> bool {
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
        if self.switch(&lower).is_none() {
            return false;
        }
        self.memory.set_system_switch(&lower, on);
        if lower == "abs.speed" {
            self.set_abs_speed(on);
        } else if let Some(p) = self.program_mut() {
            p.interpreter_mut().set_system_switch(&lower, on);
        }
        self.bump();
        true
    }

    /// Every switch with its state, AUTOSTART ones first (upper case, as `SWITCH` lists them).
    pub fn switches(&self) -> Vec<(String, bool)> {
        let mut out: Vec<(String, bool)> = (1u8..)
            .zip(AUTOSTART_SWITCHES)
            .map(|(n, (s, _, _))| (s.to_owned(), self.memory.autostart(n)))
            .collect();
        for (n, _) in SYSTEM_SWITCHES {
            if let Some(v) = self.switch(n) {
                out.push((n.to_ascii_uppercase(), v));
            }
        }
        out
    }

    // ----------------------------------------------------------------- power

    /// Switches the controller off and on again: every task stops, every socket closes, the
    /// interpreter starts again (timers, variables), the error is cleared (unless the
    /// emergency stop is pressed), motor power is off; the memory and the switches stay; the
    /// autostart programs whose AUTOSTART switch is ON start in their PC tasks. A controller
    /// running the native server starts it again.
    pub fn power_cycle(&mut self) -> PowerCycle {
        let mut out = PowerCycle::default();
        let _ = self.machine.set_power(false);
        let _ = self.machine.reset_error();
        self.monitor.stacks = Default::default();
        self.monitor.kept = [false; 6];
        self.monitor.transfer_open = false;
        match &self.server {
            Server::Native(_) => {
                self.server = Server::Native(NativeServer::new());
                self.bump();
                return out;
            }
            Server::Empty if self.memory.programs().is_empty() => {
                self.bump();
                return out;
            }
            _ => {}
        }
        self.monitor.built = None;
        if self.rebuild(true).is_err() {
            return out;
        }
        for (n, (_, name, task)) in (1u8..).zip(AUTOSTART_SWITCHES) {
            if !self.memory.autostart(n) {
                continue;
            }
            match self.pc_execute(task, name) {
                Ok(()) => out.started.push((task, name.to_owned())),
                Err(_) => {
                    self.push_output(format!(
                        "{}: {}",
                        name.to_ascii_uppercase(),
                        text::P1038_NO_PROGRAM.line()
                    ));
                    out.missing.push((task, name.to_owned()));
                }
            }
        }
        tracing::info!(started = ?out.started, "power cycle");
        out
    }

    // ----------------------------------------------------------------- terminal

    /// A terminal session opens: its name (`AUX1`…`AUX3`), or `None` when all are in use.
    pub fn open_terminal(&mut self) -> Option<String> {
        let i = self.monitor.sessions.iter().position(|used| !used)?;
        self.monitor.sessions[i] = true;
        Some(format!("AUX{}", i + 1))
    }

    /// A terminal session ended.
    pub fn close_terminal(&mut self, terminal: &str) {
        let slot = terminal
            .strip_prefix("AUX")
            .and_then(|n| n.parse::<usize>().ok())
            .and_then(|n| n.checked_sub(1));
        if let Some(s) = slot.and_then(|i| self.monitor.sessions.get_mut(i)) {
            *s = false;
        }
    }

    /// `true` while a `LOAD`/`SAVE` is in progress in a session, and once a transfer was
    /// abandoned (every `LOAD`/`SAVE` then gets P2076 until a power cycle).
    pub fn transfer_open(&self) -> bool {
        self.monitor.transfer_open || self.monitor.transfers_running > 0
    }

    /// A session began (`true`) or ended (`false`) a transfer.
    pub fn transfer_running(&mut self, running: bool) {
        let n = &mut self.monitor.transfers_running;
        *n = if running {
            n.saturating_add(1)
        } else {
            n.saturating_sub(1)
        };
    }

    /// A `LOAD`/`SAVE` was left open (a dropped link, a client that stopped answering).
    pub fn abandon_transfer(&mut self) {
        tracing::warn!(
            "a terminal transfer was abandoned: SAVE/LOAD in progress until a power cycle"
        );
        self.monitor.transfer_open = true;
    }

    fn push_output(&mut self, line: String) {
        self.monitor
            .output
            .push_back((self.monitor.next_line, line));
        self.monitor.next_line += 1;
        while self.monitor.output.len() > OUTPUT_LINES {
            self.monitor.output.pop_front();
        }
    }

    /// Takes the lines the programs printed since the last call into the terminal's list,
    /// and announces the PC programs that completed since (`Program completed.No = n`).
    fn pull_output(&mut self) {
        self.pull_printed();
        let tasks = self.program().map(|p| p.tasks(&self.machine));
        for n in 1..=5u8 {
            let i = usize::from(n);
            let info = tasks.as_ref().and_then(|t| t.get(i));
            let running = info.is_some_and(|t| t.state != fs020n_as::TaskState::Idle);
            let completed = info.is_some_and(|t| t.last_error.is_none());
            if self.monitor.ran[i] && !running && completed && !self.monitor.kept[i] {
                self.push_output(text::pc_completed(n));
            }
            self.monitor.ran[i] = running;
        }
    }

    /// Takes the lines the programs printed since the last call.
    fn pull_printed(&mut self) {
        let Some(interp) = self.interpreter() else {
            return;
        };
        let (seen_at, seen_n) = self.monitor.seen;
        let mut at_count = 0;
        let mut new = Vec::new();
        let mut newest = (seen_at, seen_n);
        for l in interp.terminal() {
            if l.at < seen_at {
                continue;
            }
            if l.at == seen_at {
                at_count += 1;
                if at_count <= seen_n {
                    continue;
                }
            }
            new.push(l.text.clone());
            newest = if l.at == newest.0 {
                (l.at, newest.1 + 1)
            } else {
                (l.at, 1)
            };
        }
        self.monitor.seen = newest;
        for l in new {
            self.push_output(l);
        }
    }

    /// The lines programs printed (`PRINT`, the controller's messages) numbered from `from`
    /// on, and the number to ask from next time. Lines older than the last 200 are gone.
    pub fn terminal_output_since(&mut self, from: u64) -> (Vec<String>, u64) {
        self.pull_output();
        let lines = self
            .monitor
            .output
            .iter()
            .filter(|(n, _)| *n >= from)
            .map(|(_, l)| l.clone())
            .collect();
        (lines, self.monitor.next_line)
    }

    /// The number the next printed line will have (a new session reads from there).
    pub fn terminal_output_next(&mut self) -> u64 {
        self.pull_output();
        self.monitor.next_line
    }

    /// The interpreter, when the controller runs AS programs.
    pub(crate) fn interpreter(&self) -> Option<&Interpreter> {
        self.program().map(ProgramServer::interpreter)
    }

    /// The stored programs.
    pub(crate) fn stored_programs(&self) -> &[StoredProgram] {
        self.memory.programs()
    }
}
