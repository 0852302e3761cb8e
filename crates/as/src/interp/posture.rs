//! Posture commands: `LEFTY`/`RIGHTY` (shoulder), `ABOVE`/`BELOW` (elbow), `UWRIST`/`DWRIST`
//! (wrist) choose the inverse-kinematics branch of the next joint motion to a transformation.

use crate::ast::Posture;
use crate::error::RuntimeError;
use crate::system::{Joints, System, Trans};

use super::arith::R;
use super::task::{Flow, TaskSlot, Wait};
use super::Interpreter;

impl Interpreter {
    /// A posture command: waits for the current motion to end (as the manuals say), then
    /// holds the choice for the next joint motion to a transformation.
    #[inline(always)]
    pub(super) fn set_posture(
        &mut self,
        i: TaskSlot,
        p: Posture,
        sys: &mut dyn System,
        pc: usize,
    ) -> R<Flow> {
        self.require_robot(i.is_robot(), "LEFTY/RIGHTY/ABOVE/BELOW/UWRIST/DWRIST")?;
        if sys.motion_in_progress() {
            self.set_pc(i, pc);
            return Ok(Flow::Wait(Box::new(Wait::MotionDone)));
        }
        let (k, v) = match p {
            Posture::Righty => (0, true),
            Posture::Lefty => (0, false),
            Posture::Above => (1, true),
            Posture::Below => (1, false),
            Posture::Uwrist => (2, true),
            Posture::Dwrist => (2, false),
        };
        self.posture[k] = Some(v);
        Ok(Flow::Next)
    }

    /// The solution for `flange` in the posture asked (nearest the current joints among
    /// those), used up by this motion; E1088 when no solution has that posture.
    pub(super) fn posture_solution(&mut self, flange: &Trans, sys: &mut dyn System) -> R<Joints> {
        let want = std::mem::take(&mut self.posture);
        let here = sys.joints();
        let dist = |q: &Joints| {
            q.iter()
                .zip(&here)
                .map(|(a, b)| (a - b).abs())
                .fold(0.0, f64::max)
        };
        sys.inverse_all(flange)
            .into_iter()
            .filter(|q| {
                let got = Self::posture_of(q, sys);
                want.iter().zip(got).all(|(w, g)| w.is_none_or(|w| w == g))
            })
            .min_by(|a, b| dist(a).total_cmp(&dist(b)))
            .ok_or_else(|| {
                Box::new(RuntimeError::System(
                    fs020n_proto::ErrorCode::DESTINATION_OUT_OF_RANGE,
                ))
            })
    }

    /// (front shoulder, elbow up, JT5 positive) of joint values. The wrist centre is the
    /// midpoint of the flange positions with JT5 at 0° and 180° (a spherical wrist turns the
    /// flange's axis about it); front: in front of the JT1 axis; elbow up: JT3 < 0 in front
    /// (JT3 > 0 behind), the convention of the FS020N's kinematics.
    fn posture_of(q: &Joints, sys: &dyn System) -> [bool; 3] {
        let mut a = *q;
        a[4] = 0.0;
        let mut b = *q;
        b[4] = 180.0;
        let front = match (sys.forward(&a), sys.forward(&b)) {
            (Some(fa), Some(fb)) => {
                let (wx, wy) = ((fa[0] + fb[0]) / 2.0, (fa[1] + fb[1]) / 2.0);
                let (s1, c1) = q[0].to_radians().sin_cos();
                c1 * wx + s1 * wy > 0.0
            }
            _ => true,
        };
        [front, (q[2] < 0.0) == front, q[4] > 0.0]
    }
}
