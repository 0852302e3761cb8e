//! Monitor statements from a program: `EXECUTE`, `PCEXECUTE`, `PCABORT`, `MC …`, `TIMER`.

use crate::compile::{CArg, Code, RExpr};
use crate::error::RuntimeError;
use crate::system::{System, TaskId};

use super::arith::{Ns, R};
use super::task::{Flow, TaskSlot, Wait};
use super::Interpreter;

impl Interpreter {
    /// `EXECUTE program` from a PC program: starts it in robot task 1.
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    pub(super) fn execute_stmt(
        &mut self,
        i: TaskSlot,
        program: &usize,
        args: &[CArg],
        cycles: &Option<RExpr>,
        sys: &mut dyn System,
        code: &Code,
        robot: bool,
    ) -> R<Flow> {
        if robot {
            return Err(Box::new(RuntimeError::PcOnly(
                "EXECUTE/MC is allowed only in PC programs".into(),
            )));
        }
        let args = self.eval_args(i, args, sys)?;
        let cycles = match cycles {
            Some(c) => self.eval_r(i, c, sys)?.trunc() as i64,
            None => 1,
        };
        // A program no loaded file defines: found when the task gets here (E0119).
        if !code.programs[*program].defined {
            return Err(Box::new(RuntimeError::NoProgram(
                code.programs[*program].name.clone(),
            )));
        }
        if let Err(r) = self.execute_robot(*program, args, cycles, sys) {
            let id = self.tasks[i].id;
            self.message(
                sys,
                id,
                format!("EXECUTE {}: {r}", code.programs[*program].name),
            );
        }
        Ok(Flow::Shared)
    }

    /// `PCEXECUTE n: program`.
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    pub(super) fn pc_execute_stmt(
        &mut self,
        i: TaskSlot,
        task: &Option<RExpr>,
        program: &usize,
        args: &[CArg],
        cycles: &Option<RExpr>,
        sys: &mut dyn System,
        code: &Code,
    ) -> R<Flow> {
        let n = match task {
            Some(t) => self.eval_r(i, t, sys)?.trunc(),
            None => 1.0,
        };
        let args = self.eval_args(i, args, sys)?;
        let cycles = match cycles {
            Some(c) => self.eval_r(i, c, sys)?.trunc() as i64,
            None => 1,
        };
        // A program no loaded file defines: found when the task gets here (E0119).
        if !code.programs[*program].defined {
            return Err(Box::new(RuntimeError::NoProgram(
                code.programs[*program].name.clone(),
            )));
        }
        if let Err(r) = self.pc_execute_at(n.clamp(0.0, 255.0) as u8, *program, args, cycles) {
            let id = self.tasks[i].id;
            self.message(
                sys,
                id,
                format!("PCEXECUTE {}: {r}", code.programs[*program].name),
            );
        }
        Ok(Flow::Shared)
    }

    /// `PCABORT n`.
    #[inline(always)]
    pub(super) fn pc_abort(
        &mut self,
        i: TaskSlot,
        task: &Option<RExpr>,
        sys: &mut dyn System,
    ) -> R<Flow> {
        let n = match task {
            Some(t) => self.eval_r(i, t, sys)?.trunc(),
            None => 1.0,
        };
        if (1.0..=5.0).contains(&n) {
            self.abort(TaskId::Pc(n as u8));
        }
        Ok(Flow::Shared)
    }

    /// `PCEND [n[: mode]]` (AS-E p.10-5): PC task `n` ends at the end of its current cycle;
    /// mode −1 cancels. A task number outside 1–5 or a mode other than 1 or −1 is E0106.
    pub(super) fn pc_end(
        &mut self,
        i: TaskSlot,
        task: &Option<RExpr>,
        mode: &Option<RExpr>,
        sys: &mut dyn System,
    ) -> R<Flow> {
        let n = match task {
            Some(t) => self.eval_r(i, t, sys)?.trunc(),
            None => 1.0,
        };
        let m = match mode {
            Some(m) => self.eval_r(i, m, sys)?.trunc(),
            None => 1.0,
        };
        if !(1.0..=5.0).contains(&n) || (m != 1.0 && m != -1.0) {
            return Err(Box::new(RuntimeError::IllegalValue(format!(
                "PCEND {n}: {m} (a PC task 1–5; 1, or -1 to cancel)"
            ))));
        }
        self.task_seen_mut(TaskSlot::at(n as usize)).end_after_cycle = m == 1.0;
        Ok(Flow::Shared)
    }

    /// `MC CONTINUE`: resumes the motion and a paused robot program.
    #[inline(always)]
    pub(super) fn mc_continue(&mut self, sys: &mut dyn System, now: Ns) -> R<Flow> {
        self.mc_hold = false;
        sys.set_program_hold(false);
        if matches!(self.tasks[TaskSlot::ROBOT].wait, Some(Wait::Paused)) {
            self.tasks[TaskSlot::ROBOT].wait = None;
            self.tasks[TaskSlot::ROBOT].ready_at = now;
        }
        Ok(Flow::Shared)
    }

    /// `MC SPEED p`: the monitor speed.
    #[inline(always)]
    pub(super) fn mc_speed(&mut self, i: TaskSlot, e: &RExpr, sys: &mut dyn System) -> R<Flow> {
        let v = self.eval_r(i, e, sys)?;
        if let Err(why) = sys.set_monitor_speed(f64::from(v)) {
            let id = self.tasks[i].id;
            self.message(sys, id, format!("MC SPEED {v}: {why}"));
        }
        Ok(Flow::Shared)
    }

    /// `MC ERESET`: resets the error.
    #[inline(always)]
    pub(super) fn mc_ereset(&mut self, i: TaskSlot, sys: &mut dyn System) -> R<Flow> {
        if let Err(why) = sys.reset_error() {
            let id = self.tasks[i].id;
            self.message(sys, id, format!("MC ERESET: {why}"));
        }
        Ok(Flow::Shared)
    }

    /// `MC ZPOWER ON|OFF`: motor power, as the monitor command; a refusal (the emergency
    /// stop) is a message, as for `MC ERESET`.
    pub(super) fn mc_zpower(&mut self, i: TaskSlot, on: bool, sys: &mut dyn System) -> R<Flow> {
        if let Err(why) = sys.set_motor_power(on) {
            let id = self.tasks[i].id;
            let word = if on { "ON" } else { "OFF" };
            self.message(sys, id, format!("MC ZPOWER {word}: {why}"));
        }
        Ok(Flow::Shared)
    }

    /// `TIMER n = t`.
    #[inline(always)]
    pub(super) fn set_timer(
        &mut self,
        i: TaskSlot,
        n: &RExpr,
        v: &RExpr,
        sys: &mut dyn System,
        now: Ns,
    ) -> R<Flow> {
        let n = self.eval_r(i, n, sys)?.trunc();
        let v = self.eval_r(i, v, sys)?;
        if !(1.0..=10.0).contains(&n) {
            return Err(Box::new(RuntimeError::IllegalValue(format!(
                "TIMER {n} (1 to 10)"
            ))));
        }
        let offset = (f64::from(v).clamp(-1.0e9, 1.0e9) * 1e9) as i128;
        self.timers[n as usize] = Some(i128::from(now) - offset);
        Ok(Flow::Next)
    }
}
