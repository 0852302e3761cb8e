//! `PRINT`/`TYPE`: terminal lines from the encoded items, and the time printing takes.

use crate::compile::Item;
use crate::system::System;

use super::arith::{ns, Ns, R};
use super::task::TaskSlot;
use super::Interpreter;

impl Interpreter {
    /// `PRINT`/`TYPE items`: the terminal lines (a line ends unless `/S`); the extra time
    /// printing takes ([`crate::CostModel::print`] and per byte).
    #[inline(always)]
    pub(super) fn print(&mut self, i: TaskSlot, items: &[Item], sys: &mut dyn System) -> R<Ns> {
        let (bytes, no_newline) = self.encode(i, items, sys)?;
        let cost =
            ns(self.cfg.cost.print
                + self.cfg.cost.print_per_byte * bytes.len().min(100_000) as u32);
        let text = String::from_utf8_lossy(&bytes).into_owned();
        let id = self.tasks[i].id;
        let mut parts: Vec<&str> = text.split('\n').collect();
        let last = parts.pop().unwrap_or("");
        for part in parts {
            let mut line = std::mem::take(&mut self.tasks[i].line_buf);
            line.push_str(part);
            self.message(sys, id, line);
        }
        self.tasks[i].line_buf.push_str(last);
        // A line ends unless /S says otherwise (and never grows without bound).
        if !no_newline || self.tasks[i].line_buf.len() > 4096 {
            let line = std::mem::take(&mut self.tasks[i].line_buf);
            self.message(sys, id, line);
        }
        Ok(cost)
    }
}
