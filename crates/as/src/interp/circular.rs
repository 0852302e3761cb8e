//! Circular motion: `C1MOVE via` keeps the intermediate point, the `C2MOVE end` that follows
//! issues one motion on the circle through where the previous motion ends, the via point and
//! the end (the system plans the arc). A `C2MOVE` without its `C1MOVE`, a `C1MOVE` followed by
//! another motion instruction or by the end of the program, and three points that define no
//! circle stop the program (E1098, E1097 and E1099, the manual's codes; fail closed: nothing
//! moves).

use fs020n_kin::CircularArc;

use crate::compile::TExpr;
use crate::error::RuntimeError;
use crate::flange;
use crate::system::{MotionKind, System, Target, Trans};

use super::arith::R;
use super::task::{Flow, TaskSlot};
use super::Interpreter;

fn unfinished(what: &str) -> Box<RuntimeError> {
    Box::new(RuntimeError::C2MoveMissing(what.into()))
}

impl Interpreter {
    /// `C1MOVE location` (`end` false) and `C2MOVE location` (`end` true).
    #[inline(always)]
    pub(super) fn circle(
        &mut self,
        i: TaskSlot,
        end: bool,
        t: &TExpr,
        sys: &mut dyn System,
    ) -> R<Flow> {
        self.require_robot(i.is_robot(), if end { "C2MOVE" } else { "C1MOVE" })?;
        let world = self.eval_t(i, t, sys)?;
        if !world.iter().all(|v| v.is_finite()) {
            return Err(Box::new(RuntimeError::IllegalValue(
                "a circle point that is not a finite transformation".into(),
            )));
        }
        let point = self.flange_of_world(&world);
        if !end {
            if self.circle_via.is_some() {
                return Err(unfinished(
                    "a C1MOVE follows a C1MOVE: each C1MOVE needs its C2MOVE next",
                ));
            }
            self.circle_via = Some(point);
            return Ok(Flow::Next);
        }
        let via = self.circle_via.take().ok_or_else(|| {
            Box::new(RuntimeError::C1MoveRequired(
                "C2MOVE without a C1MOVE before it: write C1MOVE via-point, then C2MOVE".into(),
            ))
        })?;
        let start = self.motion_end_flange(sys)?;
        if let Err(e) = CircularArc::through(
            &flange::pose_of(&start),
            &flange::pose_of(&via),
            &flange::pose_of(&point),
        ) {
            return Err(Box::new(RuntimeError::NoArc(e.to_string())));
        }
        self.motion_via(i, MotionKind::Circular, Target::Pose(point), Some(via), sys)
    }

    /// A motion instruction other than `C2MOVE` while a `C1MOVE` waits for its end point:
    /// E1097.
    pub(super) fn circle_interrupted(&self, kind: MotionKind) -> R<()> {
        if kind != MotionKind::Circular && self.circle_via.is_some() {
            return Err(unfinished(
                "a C1MOVE is followed by another motion: a C2MOVE must come next",
            ));
        }
        Ok(())
    }

    /// The end of the robot program while a `C1MOVE` waits for its end point: E1097.
    pub(super) fn circle_left_open(&self, i: TaskSlot) -> R<()> {
        if i.is_robot() && self.circle_via.is_some() {
            return Err(unfinished(
                "the program ends after a C1MOVE: a C2MOVE must follow it",
            ));
        }
        Ok(())
    }

    /// Where the flange will be when the motions issued so far end (the start of the next
    /// one): the latest motion's target, or where the robot stands.
    fn motion_end_flange(&self, sys: &dyn System) -> R<Trans> {
        let no_kinematics = || {
            Box::new(RuntimeError::IllegalValue(
                "C2MOVE: this controller has no kinematics".into(),
            ))
        };
        Ok(match self.dest {
            Some(Target::Pose(p)) => p,
            Some(Target::Joints(q)) => sys.forward(&q).ok_or_else(no_kinematics)?,
            None => sys.pose().ok_or_else(no_kinematics)?,
        })
    }
}
