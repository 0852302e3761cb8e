//! Signals: numbers, outputs (`SIGNAL`, `PULSE`, `DLYSIG`, `BITS`), the changes due later and
//! the interrupts they arm.

use crate::compile::RExpr;
use crate::error::RuntimeError;
use crate::system::System;

use super::arith::{ns, signal_number, truthy, Ns, R};
use super::task::{Flow, Interrupt, SignalState, TaskSlot};
use super::Interpreter;

/// How long `PULSE n` keeps its signal ON when no time is given.
pub(super) const PULSE_DEFAULT: std::time::Duration = std::time::Duration::from_millis(200);

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

    /// An output or internal signal number from a statement (E0106 otherwise).
    fn output_number(
        &mut self,
        i: TaskSlot,
        e: &RExpr,
        sys: &mut dyn System,
        what: &str,
    ) -> R<i32> {
        let s = signal_number(self.eval_r(i, e, sys)?);
        if s == 0 || !Self::signal_number_ok(s, true) {
            return Err(Box::new(RuntimeError::IllegalValue(format!(
                "{what} {s} (outputs 1–999, internal 2001–2960)"
            ))));
        }
        Ok(s)
    }

    /// A time in seconds from a statement: finite and not negative (E0106 otherwise).
    fn seconds(&mut self, i: TaskSlot, e: &RExpr, sys: &mut dyn System, what: &str) -> R<Ns> {
        let t = self.eval_r(i, e, sys)?;
        if !(t.is_finite() && t >= 0.0) {
            return Err(Box::new(RuntimeError::IllegalValue(format!(
                "{what} time {t}"
            ))));
        }
        Ok(ns(std::time::Duration::from_secs_f64(f64::from(t))))
    }

    /// Schedules signal `n` to become `on` at `at` (a later change of the same signal due
    /// earlier stays; the latest scheduled one wins at its time).
    pub(super) fn schedule_signal(&mut self, at: Ns, n: i32, on: bool) {
        self.timed_signals.push((at, n, on));
    }

    /// The time of the next scheduled signal change.
    pub(super) fn timed_next(&self) -> Option<Ns> {
        self.timed_signals.iter().map(|(t, ..)| *t).min()
    }

    /// Applies every scheduled signal change due at the current time, in the order scheduled.
    pub(super) fn apply_timed_signals(&mut self) {
        let now = self.now;
        let due: Vec<(Ns, i32, bool)> = self
            .timed_signals
            .iter()
            .copied()
            .filter(|(t, ..)| *t <= now)
            .collect();
        self.timed_signals.retain(|(t, ..)| *t > now);
        for (_, n, on) in due {
            self.write_signal(n, on);
        }
    }

    /// `PULSE n[, t]`: output `n` ON now and OFF `t` seconds later (0.2 s by default); the
    /// program goes on at once.
    #[inline(always)]
    pub(super) fn pulse(
        &mut self,
        i: TaskSlot,
        sig: &RExpr,
        time: &Option<RExpr>,
        sys: &mut dyn System,
        now: Ns,
    ) -> R<Flow> {
        let s = self.output_number(i, sig, sys, "PULSE")?;
        if s < 0 {
            return Err(Box::new(RuntimeError::IllegalValue(format!(
                "PULSE {s} (a pulse turns a signal ON: give a positive number)"
            ))));
        }
        let d = match time {
            Some(t) => self.seconds(i, t, sys, "PULSE")?,
            None => ns(PULSE_DEFAULT),
        };
        self.write_signal(s, true);
        self.schedule_signal(now.saturating_add(d), s, false);
        Ok(Flow::Shared)
    }

    /// `DLYSIG n, t`: signal `n` (negative: OFF) changes `t` seconds later; the program goes on.
    #[inline(always)]
    pub(super) fn dlysig(
        &mut self,
        i: TaskSlot,
        sig: &RExpr,
        time: &RExpr,
        sys: &mut dyn System,
        now: Ns,
    ) -> R<Flow> {
        let s = self.output_number(i, sig, sys, "DLYSIG")?;
        let d = self.seconds(i, time, sys, "DLYSIG")?;
        if d == 0 {
            self.write_signal(s.abs(), s > 0);
            return Ok(Flow::Shared);
        }
        self.schedule_signal(now.saturating_add(d), s.abs(), s > 0);
        // Shared: the runs of steps end where the change is due.
        Ok(Flow::Shared)
    }

    /// `BITS start, count = value`: signals `start` … `start + count − 1` set to the binary
    /// digits of `value` (`start` the least significant).
    #[inline(always)]
    /// `SOUT n = logic` (AS-E p.6-88): output `n` ON when the logic of signals holds (a
    /// negative `n`: OFF then), evaluated when the step runs (**M**: the manual's ladder
    /// pictures could also be read as a lasting connection).
    pub(super) fn sout(
        &mut self,
        i: TaskSlot,
        signal: &RExpr,
        logic: &RExpr,
        sys: &mut dyn System,
    ) -> R<Flow> {
        let n = signal_number(self.eval_r(i, signal, sys)?);
        if n == 0 || !Self::signal_number_ok(n.abs(), true) {
            return Err(Box::new(RuntimeError::IllegalValue(format!(
                "SOUT {n} (an output or internal signal)"
            ))));
        }
        let holds = truthy(self.eval_r(i, logic, sys)?);
        self.write_signal(n.abs(), holds == (n > 0));
        Ok(Flow::Shared)
    }

    pub(super) fn bits_out(
        &mut self,
        i: TaskSlot,
        wide: bool,
        start: &RExpr,
        count: &RExpr,
        value: &RExpr,
        sys: &mut dyn System,
    ) -> R<Flow> {
        let s = self.output_number(i, start, sys, "BITS")?;
        let n = self.bits_count(i, count, sys, if wide { 32 } else { 16 })?;
        let v = self.eval_r(i, value, sys)?.trunc();
        let max = (1u64 << n) - 1;
        if s < 0 || !(0.0..=max as f32).contains(&v) {
            return Err(Box::new(RuntimeError::IllegalValue(format!(
                "BITS {s}, {n} = {v} (the value must fit {n} signals: 0–{max})"
            ))));
        }
        let last = s + n as i32 - 1;
        if !Self::signal_number_ok(last, true) {
            return Err(Box::new(RuntimeError::IllegalValue(format!(
                "BITS {s}, {n}: signal {last} is outside the outputs and internal signals"
            ))));
        }
        let v = v as u64;
        for k in 0..n {
            self.write_signal(s + k as i32, v >> k & 1 == 1);
        }
        Ok(Flow::Shared)
    }

    /// `BITS(start, count)`: the value the signals `start` … `start + count − 1` form.
    pub(super) fn bits_in(&self, start: f32, count: f32, most: u32) -> R<f32> {
        let s = signal_number(start);
        let n = count.trunc();
        if !(1.0..=most as f32).contains(&n) {
            return Err(Box::new(RuntimeError::IllegalValue(format!(
                "BITS count {n} (1–{most})"
            ))));
        }
        let n = n as u32;
        let last = s + n as i32 - 1;
        if s <= 0 || !Self::signal_number_ok(s, false) || !Self::signal_number_ok(last, false) {
            return Err(Box::new(RuntimeError::IllegalValue(format!(
                "BITS({s}, {n}): signals outside 1–999, 1001–1999, 2001–2960"
            ))));
        }
        let mut v = 0u64;
        for k in 0..n {
            if self.signal(s + k as i32) {
                v |= 1 << k;
            }
        }
        // An AS real: above 2^24 the value is rounded to 24 significant bits.
        Ok(v as f32)
    }

    fn bits_count(
        &mut self,
        i: TaskSlot,
        count: &RExpr,
        sys: &mut dyn System,
        most: u32,
    ) -> R<u32> {
        let n = self.eval_r(i, count, sys)?.trunc();
        if !(1.0..=most as f32).contains(&n) {
            return Err(Box::new(RuntimeError::IllegalValue(format!(
                "BITS count {n} (1–{most})"
            ))));
        }
        Ok(n as u32)
    }

    /// `RUNMASK n[, count]`: outputs `n` … `n + count − 1` go OFF when the robot program
    /// stops; a negative `n` takes them off the mask.
    #[inline(always)]
    pub(super) fn run_mask(
        &mut self,
        i: TaskSlot,
        sig: &RExpr,
        count: &Option<RExpr>,
        sys: &mut dyn System,
    ) -> R<Flow> {
        let s = self.output_number(i, sig, sys, "RUNMASK")?;
        let n = match count {
            Some(c) => self.bits_count(i, c, sys, 16)?,
            None => 1,
        };
        let first = s.abs();
        let last = first + n as i32 - 1;
        if !Self::signal_number_ok(last, true) {
            return Err(Box::new(RuntimeError::IllegalValue(format!(
                "RUNMASK {s}, {n}: signal {last} is outside the outputs and internal signals"
            ))));
        }
        self.run_mask.retain(|x| !(first..=last).contains(x));
        if s > 0 {
            self.run_mask.extend(first..=last);
        }
        Ok(Flow::Next)
    }

    /// The robot program stopped: the outputs of `RUNMASK` go OFF.
    pub(super) fn apply_run_mask(&mut self) {
        for n in self.run_mask.clone() {
            self.write_signal(n, false);
        }
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
            return Err(Box::new(RuntimeError::RobotOnly(
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
