//! `WEIGHT` (AS-E p.6-120, p.5-85): the payload the arm carries — mass, centre of gravity in the
//! tool frame, inertia. The emulated arm's motion does not depend on it (the controller uses it
//! to choose accelerations); it is kept for the terminal's `WEIGHT` and for observers.

use serde::Serialize;

use crate::compile::RExpr;
use crate::error::RuntimeError;
use crate::system::System;

use super::arith::R;
use super::task::{Flow, TaskSlot};
use super::Interpreter;

/// The payload `WEIGHT` set.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Payload {
    /// Tool and workpiece, kg (0 to the rated payload).
    pub mass_kg: f32,
    /// Centre of gravity in the tool frame, mm.
    pub cog_mm: [f32; 3],
    /// Moments of inertia about axes parallel to the null tool's through the centre of
    /// gravity, kg·m².
    pub inertia_kg_m2: [f32; 3],
}

impl Default for Payload {
    /// The rated payload at the flange (what a program's `WEIGHT` without values sets; the
    /// controller's initial value is its own setting: **M**).
    fn default() -> Self {
        Payload {
            mass_kg: fs020n_kin::RATED_PAYLOAD_KG as f32,
            cog_mm: [0.0; 3],
            inertia_kg_m2: [0.0; 3],
        }
    }
}

impl Interpreter {
    /// The payload `WEIGHT` set last (the rated payload until then).
    pub fn payload(&self) -> Payload {
        self.payload
    }

    /// `WEIGHT [mass, x, y, z[, ix, iy, iz]]`: values left out are 0; none: the rated
    /// payload. A mass outside 0 … the rated payload, or a negative inertia, is E0106.
    pub(super) fn weight(
        &mut self,
        i: TaskSlot,
        values: &[RExpr],
        sys: &mut dyn System,
    ) -> R<Flow> {
        if values.is_empty() {
            self.payload = Payload::default();
            return Ok(Flow::Next);
        }
        let mut v = [0f32; 7];
        for (slot, e) in v.iter_mut().zip(values) {
            *slot = self.eval_r(i, e, sys)?;
        }
        let rated = fs020n_kin::RATED_PAYLOAD_KG as f32;
        if !(0.0..=rated).contains(&v[0]) {
            return Err(Box::new(RuntimeError::IllegalValue(format!(
                "WEIGHT {} kg (from 0 to the rated payload, {rated} kg)",
                v[0]
            ))));
        }
        if v[4..].iter().any(|x| *x < 0.0) {
            return Err(Box::new(RuntimeError::IllegalValue(
                "WEIGHT: a moment of inertia is not negative".into(),
            )));
        }
        self.payload = Payload {
            mass_kg: v[0],
            cog_mm: [v[1], v[2], v[3]],
            inertia_kg_m2: [v[4], v[5], v[6]],
        };
        Ok(Flow::Next)
    }
}
