//! The controller's tasks as the monitor starts and stops them (`PCEXECUTE`, `PCABORT`,
//! `PCKILL`/`KILL`, `EXECUTE`, `ABORT`) and the power cycle; the stacks and the rebuild of the
//! interpreter are in `memory.rs`.

use std::time::Duration;

use fs020n_as::TaskId;
use fs020n_term::text::{self, MonitorError};

use super::memory::{refusal_error, task_index, Abort, PowerCycle};
use super::{Controller, ProgramMut, Server};
use crate::native::NativeServer;
use crate::store::AUTOSTART_SWITCHES;

/// The longest a start at the terminal runs the program before the prompt comes back.
const FIRST_STEPS: Duration = Duration::from_millis(50);

impl ProgramMut<'_> {
    /// `PCEXECUTE task: program, cycles`: the program run `cycles` times (0 counts as 1;
    /// negative, the usual `-1`, until `PCABORT`) in PC task `task`: P1019 while the task
    /// runs, P1038 without the program, P1014 when the program runs in another task (or the
    /// running tasks could not take the programs loaded meanwhile, which then wait).
    pub fn pc_execute(&mut self, task: u8, program: &str, cycles: i64) -> Result<(), MonitorError> {
        let c = &mut *self.c;
        let name = program.to_ascii_lowercase();
        if !(1..=5).contains(&task) {
            return Err(text::P1019_PC_RUNNING);
        }
        if c.task_facts(usize::from(task)).0 {
            return Err(text::P1019_PC_RUNNING);
        }
        if c.memory.program(&name).is_none() {
            return Err(text::P1038_NO_PROGRAM);
        }
        if (0..6).any(|i| c.task_facts(i).0 && c.monitor.stacks[i].as_deref() == Some(&name)) {
            return Err(text::P1014_IN_USE);
        }
        c.sync_runtime()?;
        let p = c.server_program_mut().ok_or(text::P1038_NO_PROGRAM)?;
        p.interpreter_mut()
            .pc_execute_cycles(task, &name, cycles)
            .map_err(|r| refusal_error(&r))?;
        let i = usize::from(task);
        c.monitor.stacks[i] = Some(name);
        c.monitor.kept[i] = false;
        // Seen running: a program that ends within its first steps (before the prompt) is
        // announced `Program completed.No = n` all the same.
        c.monitor.ran[i] = true;
        c.bump();
        Ok(())
    }

    /// `PCABORT task:`: stops the task after its current step (AS-E p.10-4, p.5-42): at once
    /// between steps, or when the `TWAIT`/`TCP_ACCEPT`/`TCP_RECV`… it is in completes (its
    /// program stays on the stack). Until then the task runs (`TASK` reads 1, `PCKILL` gets
    /// P1026).
    pub fn pc_abort(&mut self, task: u8) -> Abort {
        let i = usize::from(task.clamp(1, 5));
        self.c.abort_task(TaskId::Pc(task.clamp(1, 5)), i)
    }

    /// Runs the controller on, from one program event to the next and at most 50 ms of its
    /// time, until `task` waits or stops: a program started at the terminal has run
    /// its first steps (its `TCP_LISTEN`, say) when the prompt comes back, as on the
    /// controller. The clock moves only by those steps' own time.
    pub(crate) fn run_first_steps(&mut self, task: TaskId) {
        let c = &mut *self.c;
        let end = c.now() + FIRST_STEPS;
        for _ in 0..10_000 {
            let waiting = c
                .program()
                .tasks()
                .and_then(|t| t.get(task_index(task)).cloned())
                .is_none_or(|t| t.state == fs020n_as::TaskState::Idle || t.waiting.is_some());
            if waiting {
                break;
            }
            match c.program().next_event() {
                Some(t) if t <= end => c.advance_to(t.max(c.now())),
                _ => break,
            }
        }
    }

    /// `PCKILL task:` (and `KILL` for the robot task): takes the program off the stack;
    /// P1026 while it runs.
    pub fn kill(&mut self, task: TaskId) -> Result<(), MonitorError> {
        let c = &mut *self.c;
        let i = task_index(task);
        if c.task_facts(i).0 {
            return Err(text::P1026_CANNOT_KILL_RUNNING);
        }
        c.monitor.stacks[i] = None;
        c.monitor.kept[i] = false;
        if i == 0 {
            c.monitor.primed = None;
        }
        c.bump();
        let _ = c.sync_runtime();
        Ok(())
    }

    /// `EXECUTE program, cycles` in robot task 1, the program run `cycles` times (0 counts as
    /// 1; negative until `ABORT`), with the controller's checks (power, REPEAT, teach lock,
    /// error, already running).
    pub fn execute(&mut self, program: &str, cycles: i64) -> Result<(), MonitorError> {
        let c = &mut *self.c;
        let name = program.to_ascii_lowercase();
        if c.task_facts(0).0 {
            return Err(text::P1009_ALREADY_RUNNING);
        }
        if c.memory.program(&name).is_none() {
            return Err(text::P1038_NO_PROGRAM);
        }
        c.sync_runtime()?;
        let Server::Program(p) = &mut c.server else {
            return Err(text::P1038_NO_PROGRAM);
        };
        p.execute(&mut c.machine, &name, cycles)
            .map_err(|r| refusal_error(&r))?;
        c.monitor.stacks[0] = Some(name);
        c.monitor.kept[0] = false;
        c.monitor.primed = None;
        c.monitor.ran[0] = true;
        c.bump();
        Ok(())
    }

    /// `PRIME program, cycles` (AS-E p.5-39): the robot program is put on robot task 1's
    /// stack, ready, and does not run; `CONTINUE` ([`ProgramMut::resume`]) starts it. Without
    /// a name, the program last executed or primed. P1009 while the task runs, P1038 without
    /// the program. The stack is started anew: a held program's place is lost.
    pub fn prime(&mut self, program: Option<&str>, cycles: i64) -> Result<(), MonitorError> {
        let c = &mut *self.c;
        if c.task_facts(0).0 {
            return Err(text::P1009_ALREADY_RUNNING);
        }
        let name = match program {
            Some(p) => p.to_ascii_lowercase(),
            None => (c.monitor.primed.as_ref().map(|(n, _)| n.clone()))
                .or_else(|| c.monitor.stacks[0].clone())
                .ok_or(text::P1038_NO_PROGRAM)?,
        };
        if c.memory.program(&name).is_none() {
            return Err(text::P1038_NO_PROGRAM);
        }
        c.monitor.stacks[0] = Some(name.clone());
        c.monitor.kept[0] = true;
        c.monitor.primed = Some((name, cycles));
        c.bump();
        Ok(())
    }

    /// `CONTINUE`: starts the program `PRIME` prepared (with `EXECUTE`'s checks), or resumes
    /// a held one (the panel's RUN).
    pub fn resume(&mut self) -> Result<(), MonitorError> {
        let primed = self.c.monitor.primed.clone();
        if let (Some((name, cycles)), false) = (primed, self.c.task_facts(0).0) {
            self.execute(&name, cycles)?;
        }
        self.hold(false);
        Ok(())
    }

    /// `ABORT`: stops the robot program after its current step, as [`ProgramMut::pc_abort`].
    /// A motion step is complete when its motion is: the arm finishes the motions already
    /// planned (AS-E p.5-42), it is not braked (`HOLD` stops it at once).
    pub fn abort(&mut self) -> Abort {
        self.c.abort_task(TaskId::Robot, 0)
    }

    /// `HOLD` (`true`): the robot program pauses, its motion decelerates and stops;
    /// `CONTINUE` (`false`) resumes it. The emulator plays both on the panel's HOLD/RUN
    /// switch.
    pub fn hold(&mut self, hold: bool) {
        self.c.set_run(!hold);
        self.c.bump();
    }
}

impl Controller {
    fn abort_task(&mut self, task: TaskId, i: usize) -> Abort {
        if !self.task_facts(i).0 {
            return Abort::NotRunning;
        }
        let now = self
            .server_program_mut()
            .is_none_or(|p| p.interpreter_mut().abort_after_step(task));
        self.monitor.kept[i] = true;
        self.bump();
        if now {
            Abort::Stopped
        } else {
            self.monitor.aborting[i] = true;
            Abort::AfterStep
        }
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
        self.monitor.primed = None;
        self.monitor.aborting = [false; 6];
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
            match self.program_mut().pc_execute(task, name, 1) {
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
}
