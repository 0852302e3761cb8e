//! Functions of transformations: `DISTANCE`, `DX`/`DY`/`DZ` and `FRAME`.

use fs020n_kin::Pose;
use nalgebra::{Matrix3, Vector3};

use crate::compile::{LocFn, TExpr};
use crate::error::RuntimeError;
use crate::system::System;

use super::arith::{check, R};
use super::task::TaskSlot;
use super::Interpreter;

/// Shorter than this (mm) is no direction: FRAME's points coincide or lie on a line.
const MIN_AXIS_MM: f64 = 1.0e-3;

fn position_mm(t: &[f32; 6]) -> Vector3<f64> {
    Vector3::new(f64::from(t[0]), f64::from(t[1]), f64::from(t[2]))
}

impl Interpreter {
    /// `DISTANCE(t1, t2)`: the distance between the two positions, mm; `DX`/`DY`/`DZ(t)`: a
    /// component of the position, mm.
    pub(super) fn eval_loc_fn(
        &mut self,
        i: TaskSlot,
        f: LocFn,
        args: &[TExpr],
        sys: &mut dyn System,
    ) -> R<f32> {
        let mut v = [[0f32; 6]; 2];
        for (k, a) in args.iter().enumerate().take(2) {
            v[k] = self.eval_t(i, a, sys)?;
        }
        let [a, b] = v;
        Ok(match f {
            LocFn::Distance => check(
                (position_mm(&a) - position_mm(&b)).norm() as f32,
                "DISTANCE",
            )?,
            LocFn::Dx => a[0],
            LocFn::Dy => a[1],
            LocFn::Dz => a[2],
        })
    }

    /// `FRAME(t1, t2, t3, t4)`: the frame with its origin at t4's position, its X axis from
    /// t1 toward t2, and t3 in its XY plane on the +Y side (Z = X × Y); the orientations of
    /// the four are not used. Points that coincide or lie on one line define no frame: an
    /// illegal value.
    pub(super) fn eval_frame(
        &mut self,
        i: TaskSlot,
        args: &[TExpr; 4],
        sys: &mut dyn System,
    ) -> R<[f32; 6]> {
        let mut p = [Vector3::zeros(); 4];
        for (k, a) in args.iter().enumerate() {
            p[k] = position_mm(&self.eval_t(i, a, sys)?);
        }
        let degenerate = || {
            Box::new(RuntimeError::IllegalValue(
                "FRAME: the first three points coincide or lie on one line".into(),
            ))
        };
        let x = p[1] - p[0];
        if x.norm() < MIN_AXIS_MM {
            return Err(degenerate());
        }
        let x = x.normalize();
        let v = p[2] - p[0];
        let y = v - x * v.dot(&x);
        if y.norm() < MIN_AXIS_MM {
            return Err(degenerate());
        }
        let y = y.normalize();
        let z = x.cross(&y);
        let r = Matrix3::from_columns(&[x, y, z]);
        let pose = Pose::from_parts_matrix(p[3] / 1000.0, &r).to_xyzoat();
        let out = [
            pose.x_mm, pose.y_mm, pose.z_mm, pose.o_deg, pose.a_deg, pose.t_deg,
        ]
        .map(|v| v as f32);
        for v in out {
            check(v, "FRAME")?;
        }
        Ok(out)
    }
}
