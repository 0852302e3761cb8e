//! The safety fence of the hub: limits tighter than the controller's, applied to every motion
//! and speed request before it is forwarded. Loaded from a TOML file (docs/HUB.md):
//!
//! ```toml
//! # Every table is optional.
//! speed_cap_percent = 30          # command 3 above this is refused; command-7 velocities
//!                                 # are capped at this share of each joint's maximum speed
//!
//! [joints]                        # JT1..JT6, degrees; inside the model's ranges
//! min_deg = [-90, -30, -150, -180, -120, -360]
//! max_deg = [ 90,  80,  -10,  180,  -10,  360]
//!
//! [workspace]                     # a box for the flange position, base frame, millimetres
//! min_mm = [ 300, -800,  200]
//! max_mm = [1500,  800, 1800]
//! ```
//!
//! Checks ([`Fence::check`]):
//! - command 3: the speed at most `speed_cap_percent`;
//! - command 6: the target inside the fence's joint ranges, and the flange inside the workspace
//!   box all along the joint-interpolated path from the current joints to the target (a JMOVE
//!   moves every joint in proportion, so the path is the straight line in joint space; it is
//!   checked at every degree of the largest joint travel);
//! - command 7: the client library's own check ([`fs020n_client::check_stream_sample`]) against
//!   the model tightened by the fence (ranges, and speeds times the cap) over every time the
//!   controller can extrapolate the sample to, and the flange inside the box over that window.

use std::path::Path;

use fs020n_client::{check_stream_sample, extrapolation_window, SampleError};
use fs020n_kin::{JointsDeg, RobotModel, JOINT_COUNT};
use fs020n_proto::{Command, StreamSample};
use serde::{Deserialize, Serialize};

/// Joint ranges of the fence, degrees.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct JointFence {
    /// Lower limits JT1..JT6.
    pub min_deg: [f64; JOINT_COUNT],
    /// Upper limits JT1..JT6.
    pub max_deg: [f64; JOINT_COUNT],
}

/// A box the flange must stay in, base frame, millimetres.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct WorkspaceBox {
    /// Lower corner X, Y, Z.
    pub min_mm: [f64; 3],
    /// Upper corner X, Y, Z.
    pub max_mm: [f64; 3],
}

impl WorkspaceBox {
    /// `true` when the point (mm) is inside (borders included).
    pub fn contains(&self, p_mm: [f64; 3]) -> bool {
        (0..3).all(|i| p_mm[i] >= self.min_mm[i] && p_mm[i] <= self.max_mm[i])
    }
}

/// The fence file's content.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FenceSpec {
    /// Highest monitor speed a client may set, percent (1–100).
    pub speed_cap_percent: Option<f64>,
    /// Joint ranges tighter than the controller's.
    pub joints: Option<JointFence>,
    /// A box for the flange position.
    pub workspace: Option<WorkspaceBox>,
}

/// A fence file that cannot be used.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum FenceError {
    /// The file cannot be read.
    #[error("cannot read the fence file {path}: {message}")]
    Io {
        /// The path.
        path: String,
        /// The error.
        message: String,
    },
    /// Not TOML of the fence format.
    #[error("fence file: {0} (expected speed_cap_percent, [joints] min_deg/max_deg, [workspace] min_mm/max_mm; see docs/HUB.md)")]
    Parse(String),
    /// A value that makes no sense.
    #[error("fence file: {0}")]
    Invalid(String),
}

/// Why the fence refused a request. The message says what to change.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum FenceViolation {
    /// Command 3 above the cap.
    #[error("speed {percent} % is above the fence's cap of {cap} %; ask for at most {cap} %")]
    SpeedAboveCap {
        /// Asked for.
        percent: f64,
        /// The cap.
        cap: f64,
    },
    /// A joint target outside the fence's ranges.
    #[error("JT{joint} target {value_deg:.3} deg is outside the fence's range [{min_deg}, {max_deg}]; choose a target inside it")]
    JointRange {
        /// 1-based joint.
        joint: usize,
        /// The target value.
        value_deg: f64,
        /// Fence lower limit.
        min_deg: f64,
        /// Fence upper limit.
        max_deg: f64,
    },
    /// The flange would leave the workspace box.
    #[error("the flange would leave the fence's workspace box at X {x:.1} Y {y:.1} Z {z:.1} mm ({at}); keep the motion inside [{min_mm:?}, {max_mm:?}] mm")]
    Workspace {
        /// Where, mm.
        x: f64,
        /// Where, mm.
        y: f64,
        /// Where, mm.
        z: f64,
        /// At which point of the motion ("target", "12 % of the way", "extrapolated at dt = 0.3 s").
        at: String,
        /// The box.
        min_mm: [f64; 3],
        /// The box.
        max_mm: [f64; 3],
    },
    /// A command-7 sample that fails the client's check against the fenced model.
    #[error("command-7 sample outside the fence: {0}")]
    Sample(SampleError),
}

/// The fence: its spec and the robot model tightened by it.
#[derive(Debug, Clone, PartialEq)]
pub struct Fence {
    spec: FenceSpec,
    model: RobotModel,
}

impl Fence {
    /// A fence for `model`: checks the spec (ranges inside the model's and not empty, a cap
    /// from 1 to 100 %, a box with min < max) and tightens a copy of the model.
    pub fn new(spec: FenceSpec, model: &RobotModel) -> Result<Fence, FenceError> {
        let bad = |m: String| Err(FenceError::Invalid(m));
        let mut fenced = model.clone();
        if let Some(cap) = spec.speed_cap_percent {
            if !(cap.is_finite() && (1.0..=100.0).contains(&cap)) {
                return bad(format!(
                    "speed_cap_percent = {cap}: give a cap from 1 to 100"
                ));
            }
            for j in &mut fenced.joints {
                j.max_speed_deg_s *= cap / 100.0;
            }
        }
        if let Some(jf) = &spec.joints {
            for i in 0..JOINT_COUNT {
                let (lo, hi) = (jf.min_deg[i], jf.max_deg[i]);
                let m = model.joints[i];
                if !(lo.is_finite() && hi.is_finite() && lo < hi) {
                    return bad(format!(
                        "joints: JT{} range [{lo}, {hi}] is empty or not finite; give min_deg < max_deg",
                        i + 1
                    ));
                }
                if lo < m.min_deg || hi > m.max_deg {
                    return bad(format!(
                        "joints: JT{} range [{lo}, {hi}] is wider than the robot's [{}, {}]; a fence may only tighten it",
                        i + 1,
                        m.min_deg,
                        m.max_deg
                    ));
                }
                fenced.joints[i].min_deg = lo;
                fenced.joints[i].max_deg = hi;
            }
        }
        if let Some(b) = &spec.workspace {
            for (i, axis) in ["X", "Y", "Z"].iter().enumerate() {
                let (lo, hi) = (b.min_mm[i], b.max_mm[i]);
                if !(lo.is_finite() && hi.is_finite() && lo < hi) {
                    return bad(format!(
                        "workspace: {axis} range [{lo}, {hi}] mm is empty or not finite; give min_mm < max_mm"
                    ));
                }
            }
        }
        Ok(Fence {
            spec,
            model: fenced,
        })
    }

    /// Parses a fence file's text.
    pub fn from_toml_str(text: &str, model: &RobotModel) -> Result<Fence, FenceError> {
        let spec: FenceSpec =
            toml::from_str(text).map_err(|e| FenceError::Parse(e.message().trim().to_owned()))?;
        Fence::new(spec, model)
    }

    /// Reads a fence file.
    pub fn from_file(path: &Path, model: &RobotModel) -> Result<Fence, FenceError> {
        let text = std::fs::read_to_string(path).map_err(|e| FenceError::Io {
            path: path.display().to_string(),
            message: e.to_string(),
        })?;
        Fence::from_toml_str(&text, model).map_err(|e| match e {
            FenceError::Parse(m) => FenceError::Parse(format!("{}: {m}", path.display())),
            FenceError::Invalid(m) => FenceError::Invalid(format!("{}: {m}", path.display())),
            other => other,
        })
    }

    /// The spec.
    pub fn spec(&self) -> &FenceSpec {
        &self.spec
    }

    /// The robot model tightened by the fence (ranges; speeds times the cap).
    pub fn model(&self) -> &RobotModel {
        &self.model
    }

    /// The speed cap, percent.
    pub fn speed_cap(&self) -> Option<f64> {
        self.spec.speed_cap_percent
    }

    fn flange_mm(&self, q: &JointsDeg) -> [f64; 3] {
        let p = self.model.forward(&q.to_rad()).position_m();
        [p[0] * 1e3, p[1] * 1e3, p[2] * 1e3]
    }

    fn in_box(&self, q: &JointsDeg, at: impl FnOnce() -> String) -> Result<(), FenceViolation> {
        let Some(b) = &self.spec.workspace else {
            return Ok(());
        };
        let p = self.flange_mm(q);
        if b.contains(p) {
            Ok(())
        } else {
            Err(FenceViolation::Workspace {
                x: p[0],
                y: p[1],
                z: p[2],
                at: at(),
                min_mm: b.min_mm,
                max_mm: b.max_mm,
            })
        }
    }

    fn in_ranges(&self, target: &JointsDeg) -> Result<(), FenceViolation> {
        match self.model.check_limits(target) {
            Ok(()) => Ok(()),
            Err(e) => Err(FenceViolation::JointRange {
                joint: e.joint,
                value_deg: e.value_deg,
                min_deg: e.min_deg,
                max_deg: e.max_deg,
            }),
        }
    }

    /// Checks a command the hub is about to forward; `current` = the joints of the latest
    /// status (where a joint move starts). Commands other than 3, 6 and 7 pass.
    pub fn check(&self, command: &Command, current: &JointsDeg) -> Result<(), FenceViolation> {
        match command {
            Command::SetSpeed { percent } => match self.spec.speed_cap_percent {
                Some(cap) if percent.is_nan() || *percent > cap => {
                    Err(FenceViolation::SpeedAboveCap {
                        percent: *percent,
                        cap,
                    })
                }
                _ => Ok(()),
            },
            Command::JointMove { target } => self.check_joint_move(current, target),
            Command::StreamedMove(sample) => self.check_sample(sample),
            _ => Ok(()),
        }
    }

    fn check_joint_move(&self, from: &JointsDeg, to: &JointsDeg) -> Result<(), FenceViolation> {
        self.in_ranges(to)?;
        self.in_box(to, || "target".into())?;
        if self.spec.workspace.is_none() || !from.is_finite() {
            return Ok(());
        }
        // At least 16 samples, from the start.
        self.in_box_along(from, to, 16, 0, |s| {
            format!("{:.0} % of the way to the target", s * 100.0)
        })
    }

    /// Checks the straight joint-space piece from `from` to `to` against the workspace box,
    /// one sample per degree of the largest joint travel (at least `min_samples`, at most
    /// 2000), the samples `first..n` of `n` (0 includes `from`; `to` itself is not sampled).
    /// `at(s)` names the sample at fraction `s` of the way.
    fn in_box_along(
        &self,
        from: &JointsDeg,
        to: &JointsDeg,
        min_samples: usize,
        first: usize,
        at: impl Fn(f64) -> String,
    ) -> Result<(), FenceViolation> {
        let travel = (0..JOINT_COUNT)
            .map(|i| (to[i] - from[i]).abs())
            .fold(0.0, f64::max);
        let n = (travel.ceil() as usize).clamp(min_samples, 2000);
        for k in first..n {
            let s = k as f64 / n as f64;
            let mut q = [0.0; JOINT_COUNT];
            for (i, v) in q.iter_mut().enumerate() {
                *v = from[i] + s * (to[i] - from[i]);
            }
            self.in_box(&JointsDeg(q), || at(s))?;
        }
        Ok(())
    }

    /// Checks a path (joint positions in time order, degrees): every position within the
    /// fence's ranges and workspace box, and the straight joint-space pieces between them
    /// (from `current` to the first position too, when given) inside the box, sampled at least
    /// every degree of the largest joint travel.
    pub fn check_path(
        &self,
        current: Option<&JointsDeg>,
        path: &[JointsDeg],
    ) -> Result<(), FenceViolation> {
        let mut previous = current.filter(|q| q.is_finite()).copied();
        for (k, q) in path.iter().enumerate() {
            self.in_ranges(q)?;
            self.in_box(q, || format!("path point {k}"))?;
            if let (Some(from), Some(_)) = (previous, &self.spec.workspace) {
                // Between the points only: both ends are checked as points.
                self.in_box_along(&from, q, 1, 1, |_| format!("on the way to path point {k}"))?;
            }
            previous = Some(*q);
        }
        Ok(())
    }

    fn check_sample(&self, sample: &StreamSample) -> Result<(), FenceViolation> {
        check_stream_sample(&self.model, sample).map_err(FenceViolation::Sample)?;
        if self.spec.workspace.is_none() {
            return Ok(());
        }
        let (lo, hi) = extrapolation_window(sample.lookahead_passes);
        const N: usize = 32;
        for k in 0..=N {
            let dt = lo + (hi - lo) * k as f64 / N as f64;
            let mut q = [0.0; JOINT_COUNT];
            for (i, v) in q.iter_mut().enumerate() {
                *v = sample.position[i]
                    + sample.velocity[i] * dt
                    + 0.5 * sample.acceleration[i] * dt * dt;
            }
            self.in_box(&JointsDeg(q), || format!("extrapolated at dt = {dt:.2} s"))?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const FENCE: &str = r#"
speed_cap_percent = 30
[joints]
min_deg = [-90, -30, -150, -180, -120, -360]
max_deg = [ 90,  80,  -10,  180,  -10,  360]
[workspace]
min_mm = [ 300, -800,  250]
max_mm = [1500,  800, 1800]
"#;

    fn fence() -> Fence {
        Fence::from_toml_str(FENCE, &RobotModel::fs020n()).unwrap()
    }

    fn home() -> JointsDeg {
        RobotModel::fs020n().home
    }

    #[test]
    fn speed_cap() {
        let f = fence();
        assert!(f
            .check(&Command::SetSpeed { percent: 30.0 }, &home())
            .is_ok());
        assert!(matches!(
            f.check(&Command::SetSpeed { percent: 31.0 }, &home()),
            Err(FenceViolation::SpeedAboveCap { .. })
        ));
        assert!(f
            .check(&Command::SetSpeed { percent: f64::NAN }, &home())
            .is_err());
        assert_eq!(f.model().joints[0].max_speed_deg_s, 190.0 * 0.3);
    }

    #[test]
    fn a_path_is_checked_point_by_point_and_between_points() {
        let f = fence();
        let a = JointsDeg::new([0.0, 10.0, -80.0, 0.0, -90.0, 0.0]);
        let b = JointsDeg::new([20.0, 10.0, -80.0, 0.0, -90.0, 0.0]);
        assert_eq!(f.check_path(Some(&home()), &[a, b]), Ok(()));
        // A point out of the fence's JT1 range, in the middle of the path.
        let out = JointsDeg::new([95.0, 10.0, -80.0, 0.0, -90.0, 0.0]);
        assert!(matches!(
            f.check_path(Some(&home()), &[a, out, b]),
            Err(FenceViolation::JointRange { joint: 1, .. })
        ));
        // A point below the box floor.
        let low = JointsDeg::new([0.0, 80.0, -150.0, 0.0, -90.0, 0.0]);
        assert!(f.flange_mm(&low)[2] < 250.0);
        let e = f.check_path(None, &[a, low]).unwrap_err();
        assert!(matches!(&e, FenceViolation::Workspace { .. }), "{e}");
        // From the current position (not itself checked: the arm is there) to the first
        // point: the piece is checked, and it starts below the floor.
        let e = f.check_path(Some(&low), &[a]).unwrap_err();
        assert!(
            matches!(&e, FenceViolation::Workspace { at, .. } if at == "on the way to path point 0"),
            "{e}"
        );
        assert_eq!(f.check_path(Some(&low), &[]), Ok(()));
    }

    #[test]
    fn joint_ranges_and_the_box_along_the_path() {
        let f = fence();
        let ok = JointsDeg::new([20.0, 10.0, -80.0, 0.0, -90.0, 0.0]);
        assert_eq!(f.check(&Command::JointMove { target: ok }, &home()), Ok(()));
        let out = JointsDeg::new([100.0, 0.0, -90.0, 0.0, -90.0, 0.0]);
        let e = f
            .check(&Command::JointMove { target: out }, &home())
            .unwrap_err();
        assert!(
            matches!(e, FenceViolation::JointRange { joint: 1, .. }),
            "{e}"
        );
        // Inside the ranges but the flange below the box floor (Z 250): upper arm leaning far
        // forward, forearm folded back down.
        let low = JointsDeg::new([0.0, 80.0, -150.0, 0.0, -90.0, 0.0]);
        let z = f.flange_mm(&low)[2];
        assert!(z < 250.0, "{z}");
        let e = f
            .check(&Command::JointMove { target: low }, &home())
            .unwrap_err();
        assert!(
            matches!(&e, FenceViolation::Workspace { at, .. } if at == "target"),
            "{e}"
        );
        // Both ends inside, the path outside: JT1 swings from +90 to -90 through the front.
        let spec = FenceSpec {
            workspace: Some(WorkspaceBox {
                min_mm: [-2000.0, -2000.0, -100.0],
                max_mm: [2000.0, 2000.0, 3000.0],
            }),
            ..FenceSpec::default()
        };
        let mut narrow = spec.clone();
        // Exclude the region in front of the robot (X > 700).
        narrow.workspace = Some(WorkspaceBox {
            min_mm: [-2000.0, -2000.0, -100.0],
            max_mm: [700.0, 2000.0, 3000.0],
        });
        let f = Fence::new(narrow, &RobotModel::fs020n()).unwrap();
        let left = JointsDeg::new([90.0, 0.0, -90.0, 0.0, -90.0, 0.0]);
        let right = JointsDeg::new([-90.0, 0.0, -90.0, 0.0, -90.0, 0.0]);
        assert!(f.flange_mm(&left)[0] < 700.0 && f.flange_mm(&right)[0] < 700.0);
        let e = f
            .check(&Command::JointMove { target: right }, &left)
            .unwrap_err();
        assert!(
            matches!(&e, FenceViolation::Workspace { at, .. } if at.contains("of the way")),
            "{e}"
        );
        assert!(Fence::new(spec, &RobotModel::fs020n())
            .unwrap()
            .check(&Command::JointMove { target: right }, &left)
            .is_ok());
    }

    #[test]
    fn stream_samples_use_the_client_check_on_the_fenced_model() {
        let f = fence();
        let mut s = StreamSample {
            t0_s: 1.0,
            lookahead_passes: 2.0,
            position: JointsDeg::new([0.0, 0.0, -90.0, 0.0, -90.0, 0.0]),
            velocity: JointsDeg::ZERO,
            acceleration: JointsDeg::ZERO,
        };
        assert_eq!(f.check(&Command::StreamedMove(s), &home()), Ok(()));
        // 60 deg/s is under the robot's 190 but above the cap (30 % -> 57).
        s.velocity[0] = 60.0;
        assert!(matches!(
            f.check(&Command::StreamedMove(s), &home()),
            Err(FenceViolation::Sample(SampleError::TooFast {
                joint: 1,
                ..
            }))
        ));
        // Extrapolates out of the fence's JT1 range: 85 + 20 * 0.7 = 99 > 90.
        s.velocity[0] = 20.0;
        s.position[0] = 85.0;
        assert!(matches!(
            f.check(&Command::StreamedMove(s), &home()),
            Err(FenceViolation::Sample(
                SampleError::ExtrapolatedOutOfRange { joint: 1, .. }
            ))
        ));
    }

    #[test]
    fn bad_files_are_refused_with_the_reason() {
        let m = RobotModel::fs020n();
        let e = Fence::from_toml_str("speed_cap_percent = 0", &m).unwrap_err();
        assert!(e.to_string().contains("from 1 to 100"), "{e}");
        let e = Fence::from_toml_str(
            "[joints]\nmin_deg = [-170,0,-90,0,-90,0]\nmax_deg = [10,1,-80,1,-80,1]",
            &m,
        )
        .unwrap_err();
        assert!(e.to_string().contains("wider than the robot's"), "{e}");
        let e = Fence::from_toml_str("[workspace]\nmin_mm = [0,0,0]\nmax_mm = [0,1,1]", &m)
            .unwrap_err();
        assert!(e.to_string().contains("min_mm < max_mm"), "{e}");
        let e = Fence::from_toml_str("speed = 3", &m).unwrap_err();
        assert!(matches!(e, FenceError::Parse(_)), "{e}");
        assert_eq!(
            Fence::from_toml_str("", &m).unwrap().spec(),
            &FenceSpec::default()
        );
    }
}
