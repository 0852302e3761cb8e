//! Signals: numbers, outputs and the interrupts they arm.

use super::task::SignalState;
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
}
