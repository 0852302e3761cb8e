//! Block-teaching steps (`JOINT SPEED9 ACCU1 TIMER0 TOOL1 WORK0 … OX= WX= #[…]`): the step's
//! tool, speed and accuracy from the settings tables ([`crate::BlockSettings`]), its motion
//! through the same path as `JMOVE`/`LMOVE`, then at the pose the `OX` outputs (`SIGNAL`'s
//! checks), the `WX` wait (`SWAIT`'s poll) and the timer. `OX.PREOUT` (ON by default) sets the
//! outputs when the motion starts; `AFTER.WAIT.TMR` (OFF by default) starts the timer after the
//! `WX` wait rather than at the pose.

use std::time::Duration;

use crate::ast::{BlockSpeed, BlockStep, BlockTarget};
use crate::compile::BlockPart;
use crate::error::RuntimeError;
use crate::system::{MotionKind, Speed, System, Target};

use super::arith::{ns, Ns, R};
use super::task::{Flow, TaskSlot, Wait};
use super::Interpreter;

impl Interpreter {
    /// One part of a block-teaching step.
    #[inline(always)]
    pub(super) fn block_step(
        &mut self,
        i: TaskSlot,
        part: BlockPart,
        step: &BlockStep,
        sys: &mut dyn System,
        pc: usize,
        now: Ns,
    ) -> R<Flow> {
        match part {
            BlockPart::Move => self.block_move(i, step, sys, pc),
            BlockPart::Arrive => self.block_arrive(i, step, sys, pc, now),
            BlockPart::Inputs => self.block_inputs(i, step, pc, now),
        }
    }

    /// The step's settings and motion; its outputs too when `OX.PREOUT` is ON.
    fn block_move(
        &mut self,
        i: TaskSlot,
        step: &BlockStep,
        sys: &mut dyn System,
        pc: usize,
    ) -> R<Flow> {
        self.require_robot(i.is_robot(), "a block-teaching step")?;
        // Every signal is checked before anything moves.
        for &s in &step.outputs {
            if !Self::signal_number_ok(s, true) {
                return Err(Box::new(RuntimeError::IllegalValue(format!(
                    "OX={s} (outputs 1–999, internal 2001–2960)"
                ))));
            }
        }
        for &s in &step.inputs {
            if !Self::signal_number_ok(s, false) {
                return Err(Box::new(RuntimeError::IllegalValue(format!(
                    "WX signal {s} (inputs 1–999 as 1001–1999, internal 2001–2960)"
                ))));
            }
        }
        let settings = &self.cfg.block;
        let tool = settings
            .tools
            .get(usize::from(step.tool))
            .copied()
            .flatten()
            .map(|t| t.map(|v| v as f32));
        let speed = match step.speed {
            BlockSpeed::Number(n) => {
                let p = settings.speed_percent.get(usize::from(n)).copied();
                match p {
                    Some(p) if p.is_finite() && p > 0.0 => Speed::Percent(p.clamp(0.01, 100.0)),
                    _ => {
                        return Err(Box::new(RuntimeError::IllegalValue(format!(
                            "SPEED{n}: the block speed table gives {p:?} %"
                        ))))
                    }
                }
            }
            BlockSpeed::MmPerS(v) => Speed::MmPerS(v),
        };
        let accuracy_mm = match settings
            .accuracy_mm
            .get(usize::from(step.accuracy))
            .copied()
        {
            Some(a) if a.is_finite() && a >= 0.0 => a,
            a => {
                return Err(Box::new(RuntimeError::IllegalValue(format!(
                    "ACCU{}: the block accuracy table gives {a:?} mm",
                    step.accuracy
                ))))
            }
        };
        if tool != self.tool {
            // As `TOOL`: the frame changes once the current motion is done.
            if sys.motion_in_progress() {
                self.set_pc(i, pc);
                return Ok(Flow::Wait(Box::new(Wait::MotionDone)));
            }
            self.tool = tool;
        }
        let (kind, target) = match step.target {
            BlockTarget::Joints(q) => (Self::block_kind(step), Target::Joints(q)),
            BlockTarget::Pose(p) => (
                Self::block_kind(step),
                Target::Pose(self.flange_of_world(&p.map(|v| v as f32))),
            ),
        };
        let m = &mut self.tasks[i].motion;
        m.speed_once = Some(speed);
        m.accuracy_once = Some((accuracy_mm, false));
        let flow = self.motion(i, kind, target, 0.0, sys)?;
        if self.switch_on("ox.preout") {
            self.block_outputs(step);
        }
        Ok(flow)
    }

    fn block_kind(step: &BlockStep) -> MotionKind {
        if step.linear {
            MotionKind::Linear
        } else {
            MotionKind::Joint
        }
    }

    /// At the pose: the outputs when `OX.PREOUT` is OFF, and the timer unless it follows the
    /// `WX` wait. Nothing to do at the pose: the next step follows at once, as after `JMOVE`.
    fn block_arrive(
        &mut self,
        i: TaskSlot,
        step: &BlockStep,
        sys: &mut dyn System,
        pc: usize,
        now: Ns,
    ) -> R<Flow> {
        let preout = self.switch_on("ox.preout");
        let timer_here = step.inputs.is_empty() || !self.switch_on("after.wait.tmr");
        let timer = if timer_here {
            self.block_timer(step)?
        } else {
            0
        };
        let at_pose = (!preout && !step.outputs.is_empty()) || timer > 0 || !step.inputs.is_empty();
        if !at_pose {
            return Ok(Flow::Next);
        }
        if sys.motion_in_progress() {
            // This part runs again once the robot stands at the pose.
            self.set_pc(i, pc);
            return Ok(Flow::Wait(Box::new(Wait::MotionDone)));
        }
        if !preout {
            self.block_outputs(step);
        }
        Ok(Self::block_delay(timer, now))
    }

    /// The `WX` wait (polled as `SWAIT`), then the timer when `AFTER.WAIT.TMR` is ON.
    fn block_inputs(&mut self, i: TaskSlot, step: &BlockStep, pc: usize, now: Ns) -> R<Flow> {
        let all = step.inputs.iter().all(|&s| self.signal(s.abs()) == (s > 0));
        if !all {
            self.set_pc(i, pc);
            return Ok(Flow::Wait(Box::new(Wait::Cond)));
        }
        let timer = if self.switch_on("after.wait.tmr") {
            self.block_timer(step)?
        } else {
            0
        };
        Ok(Self::block_delay(timer, now))
    }

    /// The step's timer from the table, in [`Ns`].
    fn block_timer(&self, step: &BlockStep) -> R<Ns> {
        match self.cfg.block.timer_s.get(usize::from(step.timer)).copied() {
            Some(t) if t.is_finite() && t >= 0.0 => Ok(ns(Duration::from_secs_f64(t.min(1.0e7)))),
            t => Err(Box::new(RuntimeError::IllegalValue(format!(
                "TIMER{}: the block timer table gives {t:?} s",
                step.timer
            )))),
        }
    }

    fn block_delay(timer: Ns, now: Ns) -> Flow {
        if timer == 0 {
            Flow::Next
        } else {
            Flow::Wait(Box::new(Wait::Until(now.saturating_add(timer))))
        }
    }

    /// Sets the step's `OX` outputs (checked when the step started).
    fn block_outputs(&mut self, step: &BlockStep) {
        for &s in &step.outputs {
            self.write_signal(s.abs(), s > 0);
        }
    }
}
