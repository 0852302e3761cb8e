//! Signals: numbers, outputs and the interrupts they arm.

use crate::compile::RExpr;
use crate::error::RuntimeError;
use crate::system::System;

use super::arith::{signal_number, Ns, R};
use super::task::{Flow, Interrupt, SignalState, TaskSlot};
use super::Interpreter;

impl Interpreter {
    pub(super) fn signal_number_ok(n: i32, output: bool) -> bool {
        let n = n.abs();
        (1..=999).contains(&n)
            || (2001..=2960).contains(&n)
            || (!output && (1001..=1999).contains(&n))
    }

    pub(super) fn write_signal(&mut self, n: i32, on: bool) {
        let now = self.now;
        let e = self.signals.entry(n).or_insert(SignalState {
            on: false,
            changed: 0,
        });
        if e.on != on {
            e.on = on;
            e.changed = now;
            self.int_epoch += 1;
        }
    }

    /// `SIGNAL n, -m, …`: sets and resets output and internal signals.
    #[inline(always)]
    pub(super) fn signal_out(&mut self, i: TaskSlot, v: &[RExpr], sys: &mut dyn System) -> R<Flow> {
        for e in v.iter() {
            let s = signal_number(self.eval_r(i, e, sys)?);
            if s == 0 || !Self::signal_number_ok(s, true) {
                return Err(Box::new(RuntimeError::IllegalValue(format!(
                    "SIGNAL {s} (outputs 1–999, internal 2001–2960)"
                ))));
            }
            self.write_signal(s.abs(), s > 0);
        }
        Ok(Flow::Shared)
    }

    /// `ON`/`ONI signal GOTO/CALL`: arms an interrupt.
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    pub(super) fn arm_interrupt(
        &mut self,
        i: TaskSlot,
        immediate: &bool,
        signal: &RExpr,
        goto: &Option<usize>,
        call: &Option<usize>,
        sys: &mut dyn System,
        now: Ns,
        robot: bool,
    ) -> R<Flow> {
        if *immediate && !robot {
            return Err(Box::new(RuntimeError::WrongTask(
                "ONI is allowed only in robot programs".into(),
            )));
        }
        let s = signal_number(self.eval_r(i, signal, sys)?);
        if s == 0 || !Self::signal_number_ok(s, false) {
            return Err(Box::new(RuntimeError::IllegalValue(format!(
                "signal number {s}"
            ))));
        }
        let depth = self.tasks[i].frames.len();
        let t = &mut self.tasks[i];
        t.interrupts.retain(|x| x.signal.abs() != s.abs());
        t.interrupts.push(Interrupt {
            signal: s,
            immediate: *immediate,
            goto: *goto,
            call: *call,
            depth,
            armed_at: now,
        });
        self.int_epoch += 1;
        Ok(Flow::Next)
    }

    /// `IGNORE signal`: disarms its interrupt.
    #[inline(always)]
    pub(super) fn ignore(&mut self, i: TaskSlot, e: &RExpr, sys: &mut dyn System) -> R<Flow> {
        let s = signal_number(self.eval_r(i, e, sys)?);
        self.tasks[i]
            .interrupts
            .retain(|x| x.signal.abs() != s.abs());
        self.int_epoch += 1;
        Ok(Flow::Next)
    }
}
