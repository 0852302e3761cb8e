//! Motion statements: location assignments, `HERE`, `DECOMPOSE`, `JMOVE`/`LMOVE`/`HMOVE`, `HOME`,
//! `DELAY`, `BREAK`, the motion parameters, and the motion request handed to the system.

use crate::ast::SpeedUnit;
use crate::compile::{JExpr, LRef, Loc, RExpr, TExpr, Ty};
use crate::error::RuntimeError;
use crate::system::{Issued, MotionKind, MotionRequest, Speed, System, Target, Trans};
use crate::value::MAX_INDEX;

use super::arith::R;
use super::task::{Flow, LocVal, TaskSlot, Wait};
use super::Interpreter;

impl Interpreter {
    /// `#p = …`: a joint-displacement assignment.
    #[inline(always)]
    pub(super) fn assign_joints(
        &mut self,
        i: TaskSlot,
        l: &LRef,
        e: &JExpr,
        sys: &mut dyn System,
    ) -> R<Flow> {
        let v = self.eval_j(i, e, sys)?;
        self.write_loc_var(i, l, Ty::Joint, v, sys)?;
        Ok(Flow::Next)
    }

    /// `p = …`: a transformation assignment.
    #[inline(always)]
    pub(super) fn assign_trans(
        &mut self,
        i: TaskSlot,
        l: &LRef,
        e: &TExpr,
        sys: &mut dyn System,
    ) -> R<Flow> {
        let v = self.eval_t(i, e, sys)?;
        self.write_loc_var(i, l, Ty::Trans, v, sys)?;
        Ok(Flow::Next)
    }

    /// `DECOMPOSE x[i] = location`: its six values into a real array.
    #[inline(always)]
    pub(super) fn decompose(
        &mut self,
        i: TaskSlot,
        target: &LRef,
        l: &Loc,
        sys: &mut dyn System,
    ) -> R<Flow> {
        let v = match self.eval_loc(i, l, sys)? {
            LocVal::J(v) | LocVal::T(v) => v,
        };
        let n = target.idx.len().min(3);
        let idx = self.indices(i, target, sys)?;
        let dims = n.max(1);
        for (k, x) in v.iter().enumerate() {
            let mut at = idx;
            at[0] = idx[0] + k as i32;
            if at[0] > MAX_INDEX {
                return Err(Box::new(RuntimeError::IndexRange(format!(
                    "DECOMPOSE beyond index {MAX_INDEX}"
                ))));
            }
            self.write_r_at(i, target.var, &at[..dims], *x)?;
        }
        Ok(Flow::Next)
    }

    /// `HERE p`: the current pose.
    #[inline(always)]
    pub(super) fn here_trans(&mut self, i: TaskSlot, l: &LRef, sys: &mut dyn System) -> R<Flow> {
        let p = self.here_world(sys)?;
        self.write_loc_var(i, l, Ty::Trans, p, sys)?;
        Ok(Flow::Next)
    }

    /// `JMOVE`/`LMOVE location`.
    #[inline(always)]
    pub(super) fn move_to(
        &mut self,
        i: TaskSlot,
        linear: &bool,
        l: &Loc,
        sys: &mut dyn System,
        robot: bool,
    ) -> R<Flow> {
        self.require_robot(robot, "JMOVE/LMOVE")?;
        let target = self.target_of(i, l, sys)?;
        let kind = if *linear {
            MotionKind::Linear
        } else {
            MotionKind::Joint
        };
        self.motion(i, kind, target, 0.0, sys)
    }

    /// `HMOVE location`: the wrist centre on a straight line, the wrist joints interpolated.
    #[inline(always)]
    pub(super) fn hmove(&mut self, i: TaskSlot, l: &Loc, sys: &mut dyn System) -> R<Flow> {
        self.require_robot(i.is_robot(), "HMOVE")?;
        let target = self.target_of(i, l, sys)?;
        self.motion(i, MotionKind::Hybrid, target, 0.0, sys)
    }

    /// The system's target for a location (a transformation is the tool in the world: the
    /// system gets the flange in the robot's frame).
    pub(super) fn target_of(&mut self, i: TaskSlot, l: &Loc, sys: &mut dyn System) -> R<Target> {
        Ok(match self.eval_loc(i, l, sys)? {
            LocVal::J(v) => Target::Joints(v.map(f64::from)),
            LocVal::T(v) => Target::Pose(self.flange_of_world(&v)),
        })
    }

    /// `HOME`.
    #[inline(always)]
    pub(super) fn home(&mut self, i: TaskSlot, sys: &mut dyn System, robot: bool) -> R<Flow> {
        self.require_robot(robot, "HOME")?;
        let home = sys.home();
        self.motion(i, MotionKind::Joint, Target::Joints(home), 0.0, sys)
    }

    /// `DELAY t`: a motion that stands still.
    #[inline(always)]
    pub(super) fn delay(
        &mut self,
        i: TaskSlot,
        e: &RExpr,
        sys: &mut dyn System,
        robot: bool,
    ) -> R<Flow> {
        self.require_robot(robot, "DELAY")?;
        let d = self.eval_r(i, e, sys)?;
        if !(d.is_finite() && d >= 0.0) {
            return Err(Box::new(RuntimeError::IllegalValue(format!("DELAY {d}"))));
        }
        let here = Target::Joints(sys.joints());
        self.motion(i, MotionKind::Delay, here, f64::from(d), sys)
    }

    /// `BREAK`: waits until the motion is done.
    #[inline(always)]
    pub(super) fn break_motion(&mut self, sys: &mut dyn System, robot: bool) -> R<Flow> {
        self.require_robot(robot, "BREAK")?;
        Ok(if sys.motion_in_progress() {
            Flow::Wait(Box::new(Wait::MotionDone))
        } else {
            Flow::Next
        })
    }

    /// `DRIVE joint, degrees[, speed]`: a joint motion from where the arm is, one joint turned
    /// by `degrees`, at `speed` percent for this motion (the program's speed when omitted).
    #[inline(always)]
    pub(super) fn drive(
        &mut self,
        i: TaskSlot,
        args: &(RExpr, RExpr, Option<RExpr>),
        sys: &mut dyn System,
    ) -> R<Flow> {
        self.require_robot(i.is_robot(), "DRIVE")?;
        let (joint, degrees, speed) = args;
        let joint = self.eval_r(i, joint, sys)?;
        if !(1.0..=6.0).contains(&joint) || joint.fract() != 0.0 {
            return Err(Box::new(RuntimeError::IllegalValue(format!(
                "DRIVE joint {joint} (1 to 6)"
            ))));
        }
        let degrees = f64::from(self.eval_r(i, degrees, sys)?);
        if !degrees.is_finite() {
            return Err(Box::new(RuntimeError::IllegalValue(format!(
                "DRIVE by {degrees} degrees"
            ))));
        }
        self.one_motion_speed(i, speed.as_ref(), sys)?;
        let mut target = sys.joints();
        target[joint as usize - 1] += degrees;
        self.motion(i, MotionKind::Joint, Target::Joints(target), 0.0, sys)
    }

    /// The speed (percent, 0.01–100) a motion instruction gives for itself (`DRIVE`'s, `DRAW`'s
    /// last argument): used by the next motion only, as `SPEED p` without `ALWAYS`.
    pub(super) fn one_motion_speed(
        &mut self,
        i: TaskSlot,
        speed: Option<&RExpr>,
        sys: &mut dyn System,
    ) -> R<()> {
        if let Some(e) = speed {
            let v = f64::from(self.eval_r(i, e, sys)?);
            if !(v.is_finite() && v > 0.0) {
                return Err(Box::new(RuntimeError::IllegalValue(format!(
                    "motion speed {v} %"
                ))));
            }
            self.tasks[i].motion.speed_once = Some(Speed::Percent(v.clamp(0.01, 100.0)));
        }
        Ok(())
    }

    /// `SPEED v [unit] [ALWAYS]`.
    #[inline(always)]
    pub(super) fn speed(
        &mut self,
        i: TaskSlot,
        e: &RExpr,
        unit: &SpeedUnit,
        always: &bool,
        sys: &mut dyn System,
    ) -> R<Flow> {
        let v = self.eval_r(i, e, sys)?;
        let v = f64::from(v);
        let speed = match unit {
            SpeedUnit::Percent => Speed::Percent(v.clamp(0.01, 100.0)),
            other => {
                if !(v.is_finite() && v > 0.0) {
                    return Err(Box::new(RuntimeError::IllegalValue(format!("SPEED {v}"))));
                }
                match other {
                    SpeedUnit::MmPerS => Speed::MmPerS(v),
                    SpeedUnit::MmPerMin => Speed::MmPerS(v / 60.0),
                    _ => Speed::Seconds(v),
                }
            }
        };
        let m = &mut self.tasks[i].motion;
        if *always {
            m.speed = speed;
            m.speed_once = None;
        } else {
            m.speed_once = Some(speed);
        }
        Ok(Flow::Next)
    }

    /// `ACCURACY d [FINE] [ALWAYS]`.
    #[inline(always)]
    pub(super) fn accuracy(
        &mut self,
        i: TaskSlot,
        e: &RExpr,
        fine: &bool,
        always: &bool,
        sys: &mut dyn System,
    ) -> R<Flow> {
        let v = f64::from(self.eval_r(i, e, sys)?);
        if !(v.is_finite() && v >= 0.0) {
            return Err(Box::new(RuntimeError::IllegalValue(format!(
                "ACCURACY {v}"
            ))));
        }
        let m = &mut self.tasks[i].motion;
        if *always {
            m.accuracy = (v, *fine);
            m.accuracy_once = None;
        } else {
            m.accuracy_once = Some((v, *fine));
        }
        Ok(Flow::Next)
    }

    /// `ACCEL`/`DECEL p [ALWAYS]`.
    #[inline(always)]
    pub(super) fn accel_decel(
        &mut self,
        i: TaskSlot,
        decel: &bool,
        e: &RExpr,
        always: &bool,
        sys: &mut dyn System,
    ) -> R<Flow> {
        let v = f64::from(self.eval_r(i, e, sys)?).clamp(0.01, 100.0);
        let m = &mut self.tasks[i].motion;
        match (decel, always) {
            (false, true) => {
                m.accel = v;
                m.accel_once = None;
            }
            (false, false) => m.accel_once = Some(v),
            (true, true) => {
                m.decel = v;
                m.decel_once = None;
            }
            (true, false) => m.decel_once = Some(v),
        }
        Ok(Flow::Next)
    }

    /// Issues a motion with the task's motion parameters (the one-shot ones are used up).
    pub(super) fn motion(
        &mut self,
        i: TaskSlot,
        kind: MotionKind,
        target: Target,
        delay_s: f64,
        sys: &mut dyn System,
    ) -> R<Flow> {
        self.issue(i, kind, target, delay_s, None, sys)
    }

    /// [`Self::motion`] through an intermediate point (a circular motion's).
    pub(super) fn motion_via(
        &mut self,
        i: TaskSlot,
        kind: MotionKind,
        target: Target,
        via: Option<Trans>,
        sys: &mut dyn System,
    ) -> R<Flow> {
        self.issue(i, kind, target, 0.0, via, sys)
    }

    fn issue(
        &mut self,
        i: TaskSlot,
        kind: MotionKind,
        target: Target,
        delay_s: f64,
        via: Option<Trans>,
        sys: &mut dyn System,
    ) -> R<Flow> {
        self.circle_interrupted(kind)?;
        let target = match (kind, target) {
            (MotionKind::Joint, Target::Pose(p)) if self.posture.iter().any(Option::is_some) => {
                Target::Joints(self.posture_solution(&p, sys)?)
            }
            (_, t) => t,
        };
        let cp = self.switch_on("cp");
        let abs_speed = self.switch_on("abs.speed");
        let m = &mut self.tasks[i].motion;
        let speed = m.speed_once.take().unwrap_or(m.speed);
        let (accuracy_mm, fine) = m.accuracy_once.take().unwrap_or(m.accuracy);
        let accel_percent = m.accel_once.take().unwrap_or(m.accel);
        let decel_percent = m.decel_once.take().unwrap_or(m.decel);
        let req = MotionRequest {
            kind,
            target,
            speed,
            delay_s,
            via,
            accuracy_mm,
            fine,
            accel_percent,
            decel_percent,
            cp,
            abs_speed,
        };
        let issued = sys.issue_motion(&req);
        if issued.is_ok() && kind != MotionKind::Delay {
            self.dest = Some(target);
        }
        if issued.is_ok() && !self.hand_pending.is_empty() {
            // OPEN/CLOSE/RELAX act with the motion that follows them.
            self.apply_pending_hands();
        }
        match issued {
            Ok(Issued::Started) => Ok(Flow::Next),
            Ok(Issued::Planned) => Ok(Flow::Wait(Box::new(Wait::MotionPlanned))),
            Err(code) => Err(Box::new(RuntimeError::System(code))),
        }
    }
}
