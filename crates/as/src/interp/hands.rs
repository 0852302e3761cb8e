//! Hands: `OPEN`/`CLOSE`/`RELAX` and their `I` forms on the hands' output signals
//! ([`crate::Config::hands`]).

use crate::ast::HandAction;
use crate::compile::RExpr;
use crate::error::RuntimeError;
use crate::system::System;

use super::arith::R;
use super::task::{Flow, TaskSlot, Wait};
use super::Interpreter;

impl Interpreter {
    /// `OPEN`/`CLOSE`/`RELAX [hand]`: with the next motion; the `I` forms once the current
    /// motion is done (the step waits for it, as `BREAK` does), then at once.
    #[inline(always)]
    pub(super) fn hand(
        &mut self,
        i: TaskSlot,
        action: HandAction,
        immediate: bool,
        hand: &Option<RExpr>,
        sys: &mut dyn System,
        pc: usize,
    ) -> R<Flow> {
        self.require_robot(i.is_robot(), "OPEN/CLOSE/RELAX")?;
        let n = match hand {
            Some(e) => self.eval_r(i, e, sys)?.trunc(),
            None => 1.0,
        };
        let hands = self.cfg.hands.len();
        if !(n >= 1.0 && (n as usize) <= hands) {
            return Err(Box::new(RuntimeError::IllegalValue(format!(
                "hand {n} (this controller has hands 1–{hands}: Config::hands)"
            ))));
        }
        let n = n as usize;
        if !immediate {
            self.hand_pending.retain(|(h, _)| *h != n);
            self.hand_pending.push((n, action));
            return Ok(Flow::Next);
        }
        if sys.motion_in_progress() {
            // Run this step again once the motion is done.
            self.set_pc(i, pc);
            return Ok(Flow::Wait(Box::new(Wait::MotionDone)));
        }
        self.set_hand(n, action);
        Ok(Flow::Shared)
    }

    /// Drives hand `n`'s signals.
    pub(super) fn set_hand(&mut self, n: usize, action: HandAction) {
        let Some(h) = self.cfg.hands.get(n.wrapping_sub(1)).copied() else {
            return;
        };
        let (open, close) = match action {
            HandAction::Open => (true, false),
            HandAction::Close => (false, true),
            HandAction::Relax => (false, false),
        };
        if h.open > 0 {
            self.write_signal(h.open, open);
        }
        if h.close > 0 {
            self.write_signal(h.close, close);
        }
    }

    /// The hand actions `OPEN`/`CLOSE`/`RELAX` left for the motion that starts now.
    pub(super) fn apply_pending_hands(&mut self) {
        for (n, action) in std::mem::take(&mut self.hand_pending) {
            self.set_hand(n, action);
        }
    }
}
