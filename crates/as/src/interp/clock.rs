//! The controller's clock and state as programs read them: `$TIME`, `$DATE(form)`, and the
//! `SYSDATA` keywords the emulator answers.

use chrono::{DateTime, Datelike, FixedOffset, Local, Offset, Timelike, Utc};

use crate::compile::SysData;
use crate::error::RuntimeError;
use crate::system::System;

use crate::compile::{LRef, RExpr};

use super::arith::{Ns, R};
use super::task::{Flow, TaskSlot};
use super::Interpreter;

/// `UTIMER(@t)` at `now`: the seconds since the timer read 0, which its variable holds (in
/// the interpreter's seconds; a 32-bit real, so the millisecond holds for the first hours of
/// a run), truncated to the millisecond as `TIMER`.
pub(super) fn utimer_value(now: Ns, zero_s: f32) -> f32 {
    let ms = ((now as f64 / 1e6) - f64::from(zero_s) * 1e3).floor();
    (ms / 1e3) as f32
}

/// The host's local time now: (Unix seconds, offset from UTC in seconds).
pub(super) fn host_now() -> (i64, i32) {
    let now = Local::now();
    (now.timestamp(), now.offset().local_minus_utc())
}

impl Interpreter {
    /// `UTIMER @t = value` (AS-E p.6-118): the timer shows `value` seconds now and counts on;
    /// its variable holds the interpreter's time at which it read 0.
    pub(super) fn set_utimer(
        &mut self,
        i: TaskSlot,
        l: &LRef,
        v: &RExpr,
        sys: &mut dyn System,
        now: Ns,
    ) -> R<Flow> {
        let v = self.eval_r(i, v, sys)?;
        if !(0.0..=2_147_483_647.0).contains(&v) {
            return Err(Box::new(RuntimeError::IllegalValue(format!(
                "UTIMER value {v} (0 to 2147483647 s)"
            ))));
        }
        let zero_s = now as f64 / 1e9 - f64::from(v);
        self.write_r(i, l, zero_s as f32, sys)?;
        Ok(Flow::Next)
    }

    /// The controller clock at the interpreter's time.
    fn clock(&self) -> DateTime<FixedOffset> {
        let (start_s, offset_s) = self.cfg.clock_at_start.unwrap_or((0, 0));
        let s = start_s.saturating_add((self.now / 1_000_000_000) as i64);
        let offset = FixedOffset::east_opt(offset_s).unwrap_or(Utc.fix());
        DateTime::<Utc>::from_timestamp(s, 0)
            .unwrap_or_default()
            .with_timezone(&offset)
    }

    /// `$TIME`: `hh:mm:ss`, 24 hours.
    pub(super) fn time_text(&self) -> String {
        let t = self.clock();
        format!("{:02}:{:02}:{:02}", t.hour(), t.minute(), t.second())
    }

    /// `$DATE(form)`: 1 `mm/dd/yyyy`, 2 `dd/MMM/yyyy`, 3 `yyyy/mm/dd` (AS-E p.9-73).
    pub(super) fn date_text(&self, form: f32) -> R<String> {
        let t = self.clock();
        const MONTHS: [&str; 12] = [
            "JAN", "FEB", "MAR", "APR", "MAY", "JUN", "JUL", "AUG", "SEP", "OCT", "NOV", "DEC",
        ];
        let month = MONTHS[(t.month0() as usize).min(11)];
        Ok(match form.trunc() as i64 {
            1 => format!("{:02}/{:02}/{:04}", t.month(), t.day(), t.year()),
            2 => format!("{:02}/{month}/{:04}", t.day(), t.year()),
            3 => format!("{:04}/{:02}/{:02}", t.year(), t.month(), t.day()),
            other => {
                return Err(Box::new(RuntimeError::IllegalValue(format!(
                    "$DATE form {other} (1, 2 or 3)"
                ))))
            }
        })
    }

    /// A `SYSDATA` value for task `i`.
    pub(super) fn sysdata(&self, i: TaskSlot, d: SysData, sys: &dyn System) -> f32 {
        match d {
            SysData::MonitorSpeed => sys.monitor_speed() as f32,
            SysData::Step => self.tasks[i]
                .frames
                .last()
                .and_then(|f| {
                    let p = self.code.programs.get(f.prog)?;
                    let line = p.lines.get(f.pc).or(p.lines.last())?;
                    Some(line.saturating_sub(p.header_line) as f32)
                })
                .unwrap_or(0.0),
            SysData::Robots => 1.0,
            SysData::Axes => 6.0,
            SysData::Language => 2.0,
            SysData::FreeMemory => 100.0,
            SysData::ProgramSpeed => {
                let m = &self.tasks[TaskSlot::ROBOT].motion;
                match m.speed_once.unwrap_or(m.speed) {
                    crate::system::Speed::Percent(p) => p as f32,
                    _ => -1.0,
                }
            }
        }
    }
}
