//! `XMOVE location TILL signal`: a straight line that the signal condition cuts short. The
//! program waits at the instruction until the motion ends or, once the motion has started,
//! the signal is in the state asked (a negative number: OFF) — then the motion stops at once
//! (as an `ONI` stops it) and the program goes on from where the robot stands.

use crate::compile::{Loc, Op, RExpr};
use crate::error::RuntimeError;
use crate::system::{MotionKind, System};

use super::arith::{signal_number, R};
use super::task::{Flow, TaskSlot, Wait};
use super::Interpreter;

impl Interpreter {
    /// `XMOVE location TILL signal`: issues the line, then waits ([`Wait::Till`]).
    #[inline(always)]
    pub(super) fn xmove(
        &mut self,
        i: TaskSlot,
        l: &Loc,
        till: &RExpr,
        sys: &mut dyn System,
        pc: usize,
    ) -> R<Flow> {
        self.require_robot(i.is_robot(), "XMOVE")?;
        // The signal number is checked before anything moves.
        self.till_met(i, till, sys)?;
        let target = self.target_of(i, l, sys)?;
        self.motion(i, MotionKind::Linear, target, 0.0, sys)?;
        if !sys.motion_planned() && self.till_met(i, till, sys)? {
            // Started with the signal already there: stopped before it moves.
            sys.cut_motion();
            return Ok(Flow::Next);
        }
        // Polled at this step until the motion ends or the signal cuts it.
        self.set_pc(i, pc);
        Ok(Flow::Wait(Box::new(Wait::Till)))
    }

    /// A poll of [`Wait::Till`]: `None` when the task goes on (past the `XMOVE`).
    pub(super) fn poll_till(&mut self, i: TaskSlot, sys: &mut dyn System) -> R<Option<Wait>> {
        if sys.motion_planned() {
            // The line has not started yet: the signal is watched from its start.
            return Ok(Some(Wait::Till));
        }
        let till = match self.current_op(i) {
            Some(Op::Xmove(_, till)) => till.clone(),
            _ => return Ok(None),
        };
        if self.till_met(i, &till, sys)? {
            sys.cut_motion();
            self.advance_pc(i);
            return Ok(None);
        }
        if !sys.motion_in_progress() {
            self.advance_pc(i);
            return Ok(None);
        }
        Ok(Some(Wait::Till))
    }

    /// Whether the `TILL` signal is in the state asked (E0106 for an illegal number).
    fn till_met(&mut self, i: TaskSlot, till: &RExpr, sys: &mut dyn System) -> R<bool> {
        let s = signal_number(self.eval_r(i, till, sys)?);
        if s == 0 || !Self::signal_number_ok(s, false) {
            return Err(Box::new(RuntimeError::IllegalValue(format!(
                "XMOVE … TILL {s}: not a signal number"
            ))));
        }
        Ok(self.signal(s.abs()) == (s > 0))
    }
}
