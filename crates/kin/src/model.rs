//! The robot model: joint ranges, speeds, accelerations, geometry, home pose and controller
//! defaults, loaded from a TOML file and validated.

use std::ops::Range;
use std::path::{Path, PathBuf};
use std::sync::OnceLock;

use fs020n_proto::{JointsDeg, JOINT_COUNT};
use serde::{Deserialize, Serialize};
use toml::Spanned;

/// The FS020N model file embedded in the crate (`crates/kin/models/fs020n.toml`), with comments
/// saying where each number comes from.
pub const FS020N_TOML: &str = include_str!("../models/fs020n.toml");

/// The FS020N's rated payload, kg (the "20" of its name; spec fs020n-model.md): the most
/// `WEIGHT` accepts, and the payload a program's `WEIGHT` without values sets.
pub const RATED_PAYLOAD_KG: f64 = 20.0;

/// Limits and dynamics of one joint.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct JointSpec {
    /// Lower software limit, degrees.
    pub min_deg: f64,
    /// Upper software limit, degrees (strictly greater than `min_deg`).
    pub max_deg: f64,
    /// Maximum joint speed at 100 % speed, degrees per second (> 0).
    pub max_speed_deg_s: f64,
    /// Maximum joint acceleration (and deceleration), degrees per second squared (> 0).
    pub max_accel_deg_s2: f64,
}

impl JointSpec {
    /// `true` when `value_deg` lies in `[min_deg, max_deg]` (NaN is never inside).
    pub fn contains(&self, value_deg: f64) -> bool {
        value_deg >= self.min_deg && value_deg <= self.max_deg
    }
}

/// Link lengths of the 6R arm with a spherical wrist, metres. See `docs/KINEMATICS.md` for the
/// frames.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Geometry {
    /// Height of the JT2 axis above the mounting face (base frame origin), metres (> 0).
    pub base_height_m: f64,
    /// Forward offset of the JT2 axis from the JT1 axis, metres (≥ 0).
    pub shoulder_offset_m: f64,
    /// Upper arm length, JT2 axis to JT3 axis, metres (> 0).
    pub upper_arm_m: f64,
    /// Forearm length, JT3 axis to the wrist centre, metres (> 0).
    pub forearm_m: f64,
    /// Wrist centre to tool flange, metres (≥ 0).
    pub flange_m: f64,
}

/// Controller settings an emulator starts with.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ControllerDefaults {
    /// Monitor speed at power-on, percent, in (0, 100] (Kawasaki: 10 %).
    pub monitor_speed_percent: f64,
    /// ACCURACY (blending distance) used by the server program, millimetres (≥ 0; 10 mm).
    pub accuracy_mm: f64,
}

/// The complete robot model. Build it with [`RobotModel::fs020n`], [`RobotModel::from_toml_str`]
/// or [`RobotModel::from_file`]; all three return a validated model.
///
/// The fields are public so that a test or a tool can tweak a copy; call
/// [`RobotModel::validate`] after changing them by hand.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct RobotModel {
    /// Human-readable name.
    pub name: String,
    /// Home pose, degrees (serialized as `home_deg`).
    #[serde(rename = "home_deg")]
    pub home: JointsDeg,
    /// JT1..JT6 limits and dynamics.
    pub joints: [JointSpec; JOINT_COUNT],
    /// Link lengths.
    pub geometry: Geometry,
    /// Controller defaults.
    pub controller: ControllerDefaults,
}

/// A position in a model file, 1-based line and column.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct FilePosition {
    /// Line, starting at 1.
    pub line: usize,
    /// Column (in characters), starting at 1.
    pub column: usize,
}

impl FilePosition {
    /// The position of byte offset `offset` in `source`.
    pub fn from_offset(source: &str, offset: usize) -> Self {
        let mut offset = offset.min(source.len());
        while !source.is_char_boundary(offset) {
            offset -= 1;
        }
        let before = &source[..offset];
        let line = before.matches('\n').count() + 1;
        let line_start = before.rfind('\n').map_or(0, |i| i + 1);
        let column = before[line_start..].chars().count() + 1;
        Self { line, column }
    }

    fn from_span(source: &str, span: Option<Range<usize>>) -> Option<Self> {
        span.map(|s| Self::from_offset(source, s.start))
    }
}

impl std::fmt::Display for FilePosition {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}:{}", self.line, self.column)
    }
}

/// Formats an optional position as a `"line:column: "` prefix.
struct At(Option<FilePosition>);

impl std::fmt::Display for At {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self.0 {
            Some(p) => write!(f, "{p}: "),
            None => Ok(()),
        }
    }
}

/// Why a model file was rejected. Every variant that comes from a file carries the position
/// (`line:column`) of the offending value when it is known.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum ModelError {
    /// TOML syntax error, missing key, unknown key or wrong value type.
    #[error("{}{message}", At(*.at))]
    Parse {
        /// Where the parser stopped.
        at: Option<FilePosition>,
        /// The parser's message (names the missing or unknown key).
        message: String,
    },
    /// `joints` does not hold exactly six tables.
    #[error("{}expected {expected} [[joints]] tables (JT1..JT6), found {found}", At(*.at))]
    JointCount {
        /// Position of the `joints` array.
        at: Option<FilePosition>,
        /// Number found.
        found: usize,
        /// Number required (6).
        expected: usize,
    },
    /// A joint range with `min_deg >= max_deg`.
    #[error("{}JT{joint}: min_deg ({min_deg}) must be less than max_deg ({max_deg})", At(*.at))]
    EmptyRange {
        /// Position of `min_deg`.
        at: Option<FilePosition>,
        /// 1-based joint number.
        joint: usize,
        /// The lower limit given.
        min_deg: f64,
        /// The upper limit given.
        max_deg: f64,
    },
    /// A value that must be positive (speeds, accelerations, lengths) is not.
    #[error("{}{key} must be positive and finite, got {value}", At(*.at))]
    NotPositive {
        /// Position of the value.
        at: Option<FilePosition>,
        /// Key path, e.g. `joints[3].max_speed_deg_s` (1-based joint numbers) or
        /// `geometry.forearm_m`.
        key: String,
        /// The value given.
        value: f64,
    },
    /// Any other out-of-domain value (NaN limit, negative offset, monitor speed above 100 %,
    /// home pose outside the joint ranges).
    #[error("{}{key} = {value}: {reason}", At(*.at))]
    Invalid {
        /// Position of the value.
        at: Option<FilePosition>,
        /// Key path.
        key: String,
        /// The value given.
        value: f64,
        /// What is wrong.
        reason: String,
    },
    /// The file could not be read.
    #[error("cannot read model file {}: {source}", path.display())]
    Io {
        /// The path given.
        path: PathBuf,
        /// The I/O error.
        source: std::io::Error,
    },
    /// An error in a model file read from disk (the inner error has the position).
    #[error("{}:{source}", path.display())]
    InFile {
        /// The path given.
        path: PathBuf,
        /// The error found in its content.
        source: Box<ModelError>,
    },
}

impl ModelError {
    /// The file position of the error, when known.
    pub fn position(&self) -> Option<FilePosition> {
        match self {
            Self::Parse { at, .. }
            | Self::JointCount { at, .. }
            | Self::EmptyRange { at, .. }
            | Self::NotPositive { at, .. }
            | Self::Invalid { at, .. } => *at,
            Self::Io { .. } => None,
            Self::InFile { source, .. } => source.position(),
        }
    }
}

/// A joint value outside its range, as reported by [`RobotModel::check_limits`].
#[derive(Debug, Clone, Copy, PartialEq, thiserror::Error)]
#[error("JT{joint} = {value_deg:.3} deg is outside its range [{min_deg}, {max_deg}]")]
pub struct LimitError {
    /// 1-based joint number (JT1..JT6).
    pub joint: usize,
    /// The offending value, degrees (may be NaN or infinite).
    pub value_deg: f64,
    /// Lower limit, degrees.
    pub min_deg: f64,
    /// Upper limit, degrees.
    pub max_deg: f64,
}

// ---- file representation with spans ----------------------------------------------------------

type S<T> = Spanned<T>;

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct FileJoint {
    min_deg: S<f64>,
    max_deg: S<f64>,
    max_speed_deg_s: S<f64>,
    max_accel_deg_s2: S<f64>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct FileGeometry {
    base_height_m: S<f64>,
    shoulder_offset_m: S<f64>,
    upper_arm_m: S<f64>,
    forearm_m: S<f64>,
    flange_m: S<f64>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct FileController {
    monitor_speed_percent: S<f64>,
    accuracy_mm: S<f64>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct FileModel {
    name: String,
    home_deg: S<Vec<S<f64>>>,
    joints: S<Vec<S<FileJoint>>>,
    geometry: FileGeometry,
    controller: FileController,
}

/// Validation context: turns spans into positions (or none when there is no source text).
struct Ctx<'a> {
    source: Option<&'a str>,
}

impl Ctx<'_> {
    fn at<T>(&self, v: &S<T>) -> Option<FilePosition> {
        self.source
            .and_then(|s| FilePosition::from_span(s, Some(v.span())))
    }

    fn positive(&self, key: impl Into<String>, v: &S<f64>) -> Result<f64, ModelError> {
        let value = *v.get_ref();
        if value.is_finite() && value > 0.0 {
            Ok(value)
        } else {
            Err(ModelError::NotPositive {
                at: self.at(v),
                key: key.into(),
                value,
            })
        }
    }

    fn non_negative(&self, key: impl Into<String>, v: &S<f64>) -> Result<f64, ModelError> {
        let value = *v.get_ref();
        if value.is_finite() && value >= 0.0 {
            Ok(value)
        } else {
            Err(ModelError::Invalid {
                at: self.at(v),
                key: key.into(),
                value,
                reason: "must be zero or positive and finite".into(),
            })
        }
    }

    fn finite(&self, key: impl Into<String>, v: &S<f64>) -> Result<f64, ModelError> {
        let value = *v.get_ref();
        if value.is_finite() {
            Ok(value)
        } else {
            Err(ModelError::Invalid {
                at: self.at(v),
                key: key.into(),
                value,
                reason: "must be finite".into(),
            })
        }
    }
}

impl FileModel {
    fn into_model(self, ctx: &Ctx<'_>) -> Result<RobotModel, ModelError> {
        let joints_len = self.joints.get_ref().len();
        if joints_len != JOINT_COUNT {
            return Err(ModelError::JointCount {
                at: ctx.at(&self.joints),
                found: joints_len,
                expected: JOINT_COUNT,
            });
        }
        let mut joints = [JointSpec {
            min_deg: 0.0,
            max_deg: 0.0,
            max_speed_deg_s: 0.0,
            max_accel_deg_s2: 0.0,
        }; JOINT_COUNT];
        for (i, fj) in self.joints.get_ref().iter().enumerate() {
            let n = i + 1;
            let fj = fj.get_ref();
            let min_deg = ctx.finite(format!("joints[{n}].min_deg"), &fj.min_deg)?;
            let max_deg = ctx.finite(format!("joints[{n}].max_deg"), &fj.max_deg)?;
            if min_deg >= max_deg {
                return Err(ModelError::EmptyRange {
                    at: ctx.at(&fj.min_deg),
                    joint: n,
                    min_deg,
                    max_deg,
                });
            }
            joints[i] = JointSpec {
                min_deg,
                max_deg,
                max_speed_deg_s: ctx
                    .positive(format!("joints[{n}].max_speed_deg_s"), &fj.max_speed_deg_s)?,
                max_accel_deg_s2: ctx.positive(
                    format!("joints[{n}].max_accel_deg_s2"),
                    &fj.max_accel_deg_s2,
                )?,
            };
        }

        let g = &self.geometry;
        let geometry = Geometry {
            base_height_m: ctx.positive("geometry.base_height_m", &g.base_height_m)?,
            shoulder_offset_m: ctx
                .non_negative("geometry.shoulder_offset_m", &g.shoulder_offset_m)?,
            upper_arm_m: ctx.positive("geometry.upper_arm_m", &g.upper_arm_m)?,
            forearm_m: ctx.positive("geometry.forearm_m", &g.forearm_m)?,
            flange_m: ctx.non_negative("geometry.flange_m", &g.flange_m)?,
        };

        let c = &self.controller;
        let monitor_speed_percent =
            ctx.positive("controller.monitor_speed_percent", &c.monitor_speed_percent)?;
        if monitor_speed_percent > 100.0 {
            return Err(ModelError::Invalid {
                at: ctx.at(&c.monitor_speed_percent),
                key: "controller.monitor_speed_percent".into(),
                value: monitor_speed_percent,
                reason: "must be in (0, 100]".into(),
            });
        }
        let controller = ControllerDefaults {
            monitor_speed_percent,
            accuracy_mm: ctx.non_negative("controller.accuracy_mm", &c.accuracy_mm)?,
        };

        let home_len = self.home_deg.get_ref().len();
        if home_len != JOINT_COUNT {
            return Err(ModelError::Invalid {
                at: ctx.at(&self.home_deg),
                key: "home_deg".into(),
                value: home_len as f64,
                reason: format!("expected {JOINT_COUNT} joint values, found {home_len}"),
            });
        }
        let mut home = JointsDeg::ZERO;
        for (i, v) in self.home_deg.get_ref().iter().enumerate() {
            let value = ctx.finite(format!("home_deg[{}]", i + 1), v)?;
            let spec = &joints[i];
            if !spec.contains(value) {
                return Err(ModelError::Invalid {
                    at: ctx.at(v),
                    key: format!("home_deg[{}]", i + 1),
                    value,
                    reason: format!(
                        "outside the JT{} range [{}, {}]",
                        i + 1,
                        spec.min_deg,
                        spec.max_deg
                    ),
                });
            }
            home[i] = value;
        }

        Ok(RobotModel {
            name: self.name,
            home,
            joints,
            geometry,
            controller,
        })
    }
}

impl<'de> Deserialize<'de> for RobotModel {
    /// Deserializes and validates a model. Only the `toml` deserializer is supported (the model
    /// file format keeps value positions for error messages).
    fn deserialize<D: serde::Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
        let file = FileModel::deserialize(deserializer)?;
        file.into_model(&Ctx { source: None })
            .map_err(serde::de::Error::custom)
    }
}

impl RobotModel {
    /// The embedded Kawasaki FS020N model (see [`FS020N_TOML`]). Parsed once, then cloned.
    pub fn fs020n() -> Self {
        static MODEL: OnceLock<RobotModel> = OnceLock::new();
        MODEL
            .get_or_init(|| {
                // The embedded file is checked by a unit test; it cannot fail at run time.
                #[allow(clippy::expect_used)]
                Self::from_toml_str(FS020N_TOML).expect("embedded FS020N model file is valid")
            })
            .clone()
    }

    /// Parses and validates a model file held in a string. Errors carry the `line:column` of
    /// the offending value.
    pub fn from_toml_str(source: &str) -> Result<Self, ModelError> {
        let file: FileModel = toml::from_str(source).map_err(|e| ModelError::Parse {
            at: FilePosition::from_span(source, e.span()),
            message: e.message().trim().to_string(),
        })?;
        file.into_model(&Ctx {
            source: Some(source),
        })
    }

    /// Reads, parses and validates a model file.
    pub fn from_file(path: &Path) -> Result<Self, ModelError> {
        let source = std::fs::read_to_string(path).map_err(|source| ModelError::Io {
            path: path.to_path_buf(),
            source,
        })?;
        Self::from_toml_str(&source).map_err(|e| ModelError::InFile {
            path: path.to_path_buf(),
            source: Box::new(e),
        })
    }

    /// Serializes the model to TOML (without the comments of the embedded file). The output
    /// loads back with [`RobotModel::from_toml_str`] to an equal model.
    pub fn to_toml_string(&self) -> String {
        // Serializing plain numbers, strings and tables cannot fail.
        toml::to_string_pretty(self).unwrap_or_default()
    }

    /// Validates a model built or modified in code (the loaders call the same checks).
    pub fn validate(&self) -> Result<(), ModelError> {
        Self::from_toml_str(&self.to_toml_string()).map(|_| ())
    }

    /// The name of the model.
    pub fn name(&self) -> &str {
        &self.name
    }

    /// Checks every joint against its range. The error names the first joint outside
    /// (1-based) with its value and range. NaN is outside every range.
    pub fn check_limits(&self, joints: &JointsDeg) -> Result<(), LimitError> {
        for (i, spec) in self.joints.iter().enumerate() {
            let v = joints[i];
            if !spec.contains(v) {
                return Err(LimitError {
                    joint: i + 1,
                    value_deg: v,
                    min_deg: spec.min_deg,
                    max_deg: spec.max_deg,
                });
            }
        }
        Ok(())
    }

    /// `true` when every joint is inside its range.
    pub fn within_limits(&self, joints: &JointsDeg) -> bool {
        self.check_limits(joints).is_ok()
    }

    /// Maximum joint speeds at 100 %, deg/s.
    pub fn max_speeds_deg_s(&self) -> JointsDeg {
        JointsDeg(self.joints.map(|j| j.max_speed_deg_s))
    }

    /// Maximum joint accelerations, deg/s².
    pub fn max_accels_deg_s2(&self) -> JointsDeg {
        JointsDeg(self.joints.map(|j| j.max_accel_deg_s2))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn embedded_model_loads_with_spec_numbers() {
        let m = RobotModel::fs020n();
        assert_eq!(m.name, "Kawasaki FS020N");
        assert_eq!(m.joints[2].min_deg, -155.0);
        assert_eq!(m.joints[2].max_deg, 120.0);
        assert_eq!(m.joints[5].max_speed_deg_s, 610.0);
        assert_eq!(m.joints[3].max_accel_deg_s2, 934.0);
        assert_eq!(m.geometry.flange_m, 0.0965);
        assert_eq!(m.home, JointsDeg::new([0.0, 0.0, -90.0, 0.0, -90.0, 0.0]));
        assert_eq!(m.controller.monitor_speed_percent, 10.0);
        assert_eq!(m.controller.accuracy_mm, 10.0);
        assert!(m.validate().is_ok());
    }

    #[test]
    fn toml_round_trip() {
        let m = RobotModel::fs020n();
        let text = m.to_toml_string();
        let back = RobotModel::from_toml_str(&text).unwrap();
        assert_eq!(m, back);
    }

    #[test]
    fn file_position_from_offset() {
        let s = "ab\ncdé\nfg";
        assert_eq!(
            FilePosition::from_offset(s, 0),
            FilePosition { line: 1, column: 1 }
        );
        assert_eq!(
            FilePosition::from_offset(s, 4),
            FilePosition { line: 2, column: 2 }
        );
        // offset inside the two-byte 'é' snaps back to its start
        assert_eq!(
            FilePosition::from_offset(s, 6),
            FilePosition { line: 2, column: 3 }
        );
        assert_eq!(
            FilePosition::from_offset(s, 8),
            FilePosition { line: 3, column: 1 }
        );
    }

    #[test]
    fn limit_error_display() {
        let m = RobotModel::fs020n();
        let mut j = m.home;
        j[2] = 130.0;
        let e = m.check_limits(&j).unwrap_err();
        assert_eq!(e.joint, 3);
        assert_eq!(
            e.to_string(),
            "JT3 = 130.000 deg is outside its range [-155, 120]"
        );
        assert!(!m.within_limits(&j));
        j[2] = f64::NAN;
        assert!(!m.within_limits(&j));
        assert!(m.within_limits(&m.home));
    }
}
