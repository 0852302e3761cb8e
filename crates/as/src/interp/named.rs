//! Things a string names, looked up when the function is read: `STRTOPOS($s)` (AS-E p.9-36),
//! the pose variable; `STRTOVAL($s)` (p.9-37), the real variable; `WHICHTASK($s)` (p.9-19),
//! the task running the program.

use crate::compile::Ty;
use crate::error::RuntimeError;
use crate::system::TaskId;

use super::arith::R;
use super::task::{LocVal, TaskSlot};
use super::Interpreter;

/// `name` or `name[1,2]` as a string holds it: the name in lower case (its `#`, `$` or `@`
/// kept) and the indices; `None` when the brackets are not 1–3 whole numbers.
fn variable_name(text: &[u8]) -> Option<(String, Vec<i32>)> {
    let text = String::from_utf8_lossy(text).trim().to_ascii_lowercase();
    match text.split_once('[') {
        Some((base, tail)) => {
            let idx = (tail.strip_suffix(']')?.split(','))
                .map(|x| x.trim().parse::<i32>().ok())
                .collect::<Option<Vec<i32>>>()
                .filter(|v| (1..=3).contains(&v.len()))?;
            Some((base.trim().to_owned(), idx))
        }
        None => Some((text, Vec::new())),
    }
}

impl Interpreter {
    /// The global pose variable `name` names: `#pos` (or `#pos[1,2]`) a joint point, `pos` a
    /// transformation; E0103 when it holds no value (the manual: "an error occurs").
    pub(super) fn named_pose(&self, name: &[u8]) -> R<LocVal> {
        let undefined = || {
            Box::new(RuntimeError::LocationUndefined(
                String::from_utf8_lossy(name).trim().to_owned(),
            ))
        };
        let (text, idx) = variable_name(name).ok_or_else(undefined)?;
        let (joint, base) = match text.strip_prefix('#') {
            Some(rest) => (true, rest),
            None => (false, text.as_str()),
        };
        let ty = if joint { Ty::Joint } else { Ty::Trans };
        let slot = self.global_slot(ty, base).ok_or_else(undefined)?;
        let g = &self.globals;
        let v = if joint {
            g.joints.get(slot).and_then(|v| v.get(&idx)).copied()
        } else {
            g.trans.get(slot).and_then(|v| v.get(&idx)).copied()
        };
        let v = v.ok_or_else(undefined)?;
        Ok(if joint { LocVal::J(v) } else { LocVal::T(v) })
    }

    /// The global real `name` names (`"var"`, `"var[3]"`, `"@count"`); E0102 when it holds
    /// no value (the manual: "an error occurs").
    pub(super) fn named_real(&self, name: &[u8]) -> R<f32> {
        let undefined = || {
            Box::new(RuntimeError::Undefined(
                String::from_utf8_lossy(name).trim().to_owned(),
            ))
        };
        let (text, idx) = variable_name(name).ok_or_else(undefined)?;
        let slot = self.global_slot(Ty::Real, &text).ok_or_else(undefined)?;
        (self.globals.reals.get(slot))
            .and_then(|v| v.get(&idx))
            .copied()
            .ok_or_else(undefined)
    }

    /// The task whose stack holds the program `name` (a running program or one of its
    /// subroutines): 1 the robot task, 1001–1005 the PC tasks; −1 when none does.
    pub(super) fn which_task(&self, name: &[u8]) -> f32 {
        let name = String::from_utf8_lossy(name).trim().to_ascii_lowercase();
        let Some(prog) = self.code.defined(&name) else {
            return -1.0;
        };
        (0..self.tasks.len())
            .map(TaskSlot::at)
            .find(|&t| self.tasks[t].frames.iter().any(|f| f.prog == prog))
            .map_or(-1.0, |t| match self.tasks[t].id {
                TaskId::Robot => 1.0,
                TaskId::Pc(n) => 1000.0 + f32::from(n),
            })
    }
}
