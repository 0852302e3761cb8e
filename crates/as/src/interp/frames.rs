//! Frames and the motions defined by them: `TOOL`, `BASE`, conversions between what the
//! program sees (the tool in the world: BASE · flange · TOOL) and what the system moves (the
//! flange in the robot's base frame), `POINT` between joint points and transformations,
//! `APPRO`/`LAPPRO`, `DEPART`/`LDEPART`, `DRAW`/`TDRAW`, `ALIGN`.

use fs020n_kin::Pose;

use crate::compile::{JExpr, RExpr, TExpr};
use crate::error::RuntimeError;
use crate::system::{MotionKind, System, Target, Trans};

use super::arith::R;
use super::expr::xyzoat;
use super::task::{Flow, TaskSlot, Wait};
use super::Interpreter;

pub(super) fn pose_of(t: &[f32; 6]) -> Pose {
    Pose::from_xyzoat(xyzoat(t))
}

pub(super) fn trans_of(p: &Pose) -> [f32; 6] {
    let r = p.to_xyzoat();
    [r.x_mm, r.y_mm, r.z_mm, r.o_deg, r.a_deg, r.t_deg].map(|v| v as f32)
}

fn no_kinematics(what: &str) -> Box<RuntimeError> {
    Box::new(RuntimeError::IllegalValue(format!(
        "{what}: this controller has no kinematics"
    )))
}

impl Interpreter {
    /// The program's transformation (tool in the world) of a system flange pose.
    pub(super) fn world_of_flange(&self, flange: &Trans) -> [f32; 6] {
        let f = flange.map(|v| v as f32);
        if self.tool.is_none() && self.base.is_none() {
            return f;
        }
        let mut p = pose_of(&f);
        if let Some(b) = &self.base {
            p = pose_of(b) * p;
        }
        if let Some(t) = &self.tool {
            p = p * pose_of(t);
        }
        trans_of(&p)
    }

    /// The system's flange pose for a program transformation (tool in the world).
    pub(super) fn flange_of_world(&self, world: &[f32; 6]) -> Trans {
        if self.tool.is_none() && self.base.is_none() {
            return world.map(f64::from);
        }
        let mut p = pose_of(world);
        if let Some(b) = &self.base {
            p = pose_of(b).inverse() * p;
        }
        if let Some(t) = &self.tool {
            p = p * pose_of(t).inverse();
        }
        trans_of(&p).map(f64::from)
    }

    /// `HERE` as a transformation: the tool in the world.
    pub(super) fn here_world(&self, sys: &dyn System) -> R<[f32; 6]> {
        let p = sys.pose().ok_or_else(|| no_kinematics("HERE"))?;
        Ok(self.world_of_flange(&p))
    }

    /// A joint point's transformation (TOOL and BASE applied).
    pub(super) fn forward_of(
        &mut self,
        i: TaskSlot,
        j: &JExpr,
        sys: &mut dyn System,
    ) -> R<[f32; 6]> {
        let q = self.eval_j(i, j, sys)?.map(f64::from);
        let p = sys.forward(&q).ok_or_else(|| no_kinematics("POINT"))?;
        Ok(self.world_of_flange(&p))
    }

    /// A transformation's joint values, the solution nearest the current joints (E1088
    /// "destination out of motion range" when none is within the joint limits).
    pub(super) fn inverse_of(
        &mut self,
        i: TaskSlot,
        t: &TExpr,
        sys: &mut dyn System,
    ) -> R<[f32; 6]> {
        let w = self.eval_t(i, t, sys)?;
        let flange = self.flange_of_world(&w);
        match sys.inverse(&flange, &sys.joints()) {
            Some(q) => Ok(q.map(|v| v as f32)),
            None => Err(Box::new(RuntimeError::System(
                fs020n_proto::ErrorCode::DESTINATION_OUT_OF_RANGE,
            ))),
        }
    }

    /// `DEST`: the latest motion's target as a transformation (where the robot stands when no
    /// motion was issued yet).
    pub(super) fn dest_world(&self, sys: &dyn System) -> R<[f32; 6]> {
        let flange = match self.dest {
            Some(Target::Pose(p)) => p,
            Some(Target::Joints(q)) => sys.forward(&q).ok_or_else(|| no_kinematics("DEST"))?,
            None => sys.pose().ok_or_else(|| no_kinematics("DEST"))?,
        };
        Ok(self.world_of_flange(&flange))
    }

    /// `#DEST`: the latest motion's target as joint values.
    pub(super) fn dest_joints(&self, sys: &dyn System) -> R<[f32; 6]> {
        let q = match self.dest {
            Some(Target::Joints(q)) => q,
            Some(Target::Pose(p)) => sys.inverse(&p, &sys.joints()).ok_or_else(|| {
                Box::new(RuntimeError::System(
                    fs020n_proto::ErrorCode::DESTINATION_OUT_OF_RANGE,
                ))
            })?,
            None => sys.joints(),
        };
        Ok(q.map(|v| v as f32))
    }

    /// `TOOL t`/`BASE t` (NULL: `None`): waits for the current motion to end, then sets the
    /// frame for the motions and `HERE`s that follow.
    #[inline(always)]
    pub(super) fn set_frame(
        &mut self,
        i: TaskSlot,
        base: bool,
        value: &Option<TExpr>,
        sys: &mut dyn System,
        pc: usize,
    ) -> R<Flow> {
        self.require_robot(i.is_robot(), if base { "BASE" } else { "TOOL" })?;
        if sys.motion_in_progress() {
            // Run this step again once the motion is done.
            self.set_pc(i, pc);
            return Ok(Flow::Wait(Box::new(Wait::MotionDone)));
        }
        let v = match value {
            Some(t) => Some(self.eval_t(i, t, sys)?),
            None => None,
        };
        if base {
            self.base = v;
        } else {
            self.tool = v;
        }
        Ok(Flow::Next)
    }

    /// `APPRO`/`LAPPRO location, d`: to `d` mm short of the location along its Z axis.
    #[inline(always)]
    pub(super) fn appro(
        &mut self,
        i: TaskSlot,
        linear: bool,
        t: &TExpr,
        d: &RExpr,
        sys: &mut dyn System,
    ) -> R<Flow> {
        self.require_robot(i.is_robot(), "APPRO")?;
        let target = self.eval_t(i, t, sys)?;
        let d = self.eval_r(i, d, sys)?;
        let p = pose_of(&target) * pose_of(&[0.0, 0.0, -d, 0.0, 0.0, 0.0]);
        self.move_world(i, linear, &trans_of(&p), sys)
    }

    /// `DEPART`/`LDEPART d`: `d` mm back along the tool's Z axis from where the robot is.
    #[inline(always)]
    pub(super) fn depart(
        &mut self,
        i: TaskSlot,
        linear: bool,
        d: &RExpr,
        sys: &mut dyn System,
    ) -> R<Flow> {
        self.require_robot(i.is_robot(), "DEPART")?;
        let d = self.eval_r(i, d, sys)?;
        let here = self.here_world(sys)?;
        let p = pose_of(&here) * pose_of(&[0.0, 0.0, -d, 0.0, 0.0, 0.0]);
        self.move_world(i, linear, &trans_of(&p), sys)
    }

    /// `DRAW dx, dy, dz, o, a, t` (base axes) / `TDRAW` (tool axes): a straight line by the
    /// offset, turning the tool by the rotation (O, A, T as a transformation's Z-Y-Z angles)
    /// about the base axes (`DRAW`, about the tool point) or the tool's (`TDRAW`).
    #[inline(always)]
    pub(super) fn draw(
        &mut self,
        i: TaskSlot,
        tool: bool,
        values: &[Option<RExpr>; 7],
        sys: &mut dyn System,
    ) -> R<Flow> {
        self.require_robot(i.is_robot(), if tool { "TDRAW" } else { "DRAW" })?;
        let mut d = [0f32; 6];
        for (k, e) in values[..6].iter().enumerate() {
            if let Some(e) = e {
                d[k] = self.eval_r(i, e, sys)?;
            }
        }
        self.one_motion_speed(i, values[6].as_ref(), sys)?;
        let here = self.here_world(sys)?;
        let target = if tool {
            trans_of(&(pose_of(&here) * pose_of(&d)))
        } else if d[3..].iter().all(|v| *v == 0.0) {
            let mut t = here;
            for k in 0..3 {
                t[k] += d[k];
            }
            t
        } else {
            // The tool's orientation alone, turned about the base axes, at the new position.
            let at = |x: &[f32]| pose_of(&[x[0], x[1], x[2], 0.0, 0.0, 0.0]);
            let orientation = at(&here).inverse() * pose_of(&here);
            let moved = [here[0] + d[0], here[1] + d[1], here[2] + d[2]];
            let turn = pose_of(&[0.0, 0.0, 0.0, d[3], d[4], d[5]]);
            trans_of(&(at(&moved) * turn * orientation))
        };
        self.move_world(i, true, &target, sys)
    }

    /// `ALIGN`: turns the tool about its tip so that its Z axis is parallel to the nearest axis
    /// of the world frame (the smallest rotation), joint-interpolated.
    #[inline(always)]
    pub(super) fn align(&mut self, i: TaskSlot, sys: &mut dyn System) -> R<Flow> {
        self.require_robot(i.is_robot(), "ALIGN")?;
        let here = self.here_world(sys)?;
        let target = trans_of(&pose_of(&here).aligned());
        self.move_world(i, false, &target, sys)
    }

    /// A joint or linear motion to a program transformation.
    fn move_world(
        &mut self,
        i: TaskSlot,
        linear: bool,
        world: &[f32; 6],
        sys: &mut dyn System,
    ) -> R<Flow> {
        if !world.iter().all(|v| v.is_finite()) {
            return Err(Box::new(RuntimeError::IllegalValue(
                "a target that is not a finite transformation".into(),
            )));
        }
        let kind = if linear {
            MotionKind::Linear
        } else {
            MotionKind::Joint
        };
        let target = Target::Pose(self.flange_of_world(world));
        self.motion(i, kind, target, 0.0, sys)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_pose_survives_the_round_trip_through_pose() {
        let t = [100.0, -20.0, 300.0, 10.0, 90.0, -30.0];
        let back = trans_of(&pose_of(&t));
        for k in 0..6 {
            assert!((back[k] - t[k]).abs() < 1e-3, "{back:?}");
        }
    }
}
