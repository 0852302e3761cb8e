//! Conditions that block motion, with what to do about each, and the checks made before any
//! request leaves the PC.

use std::fmt;

use fs020n_kin::RobotModel;
use fs020n_proto::{ErrorCode, Status, StreamSample, JOINT_COUNT};
use serde::Serialize;

/// One condition of the controller that blocks motion (read from a status reply), with its
/// remedy ([`Blocker::remedy`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize)]
#[serde(tag = "kind", content = "code", rename_all = "snake_case")]
pub enum Blocker {
    /// The controller reports an error (reply field 2). It stays until reset at the pendant;
    /// the protocol has no reset command.
    ControllerError(ErrorCode),
    /// TEACH/REPEAT is on TEACH.
    Teach,
    /// TEACH LOCK is ON (the pendant has control).
    TeachLock,
    /// RUN/HOLD is on HOLD.
    Hold,
    /// Motor power is OFF.
    PowerOff,
    /// The motion program (`ros_move`, task 1) is not running, so 6 and 7 would do nothing.
    ProgramNotRunning,
}

/// Remedy of an emergency stop (E3808).
pub const ESTOP_REMEDY: &str =
    "release the emergency stop, reset the error and turn motor power on";

impl Blocker {
    /// What is wrong, e.g. `"TEACH/REPEAT is on TEACH"`.
    pub fn condition(&self) -> String {
        match self {
            Blocker::ControllerError(code) => match code.message() {
                Some(m) => format!("the controller is in error {code} ({m})"),
                None => format!("the controller is in error {code}"),
            },
            Blocker::Teach => "TEACH/REPEAT is on TEACH".into(),
            Blocker::TeachLock => "TEACH LOCK is ON".into(),
            Blocker::Hold => "RUN/HOLD is on HOLD".into(),
            Blocker::PowerOff => "motor power is OFF".into(),
            Blocker::ProgramNotRunning => "the motion program is not running".into(),
        }
    }

    /// What the user must do, e.g. `"switch TEACH/REPEAT to REPEAT"`.
    ///
    /// ```
    /// use fs020n_client::Blocker;
    /// use fs020n_proto::ErrorCode;
    /// assert_eq!(
    ///     Blocker::ControllerError(ErrorCode::DESTINATION_OUT_OF_RANGE).remedy(),
    ///     "reset error E1088 (Destination is out of motion range) at the pendant"
    /// );
    /// assert_eq!(
    ///     Blocker::ControllerError(ErrorCode::EMERGENCY_STOP).remedy(),
    ///     "release the emergency stop, reset the error and turn motor power on"
    /// );
    /// ```
    pub fn remedy(&self) -> String {
        match self {
            Blocker::ControllerError(code) if *code == ErrorCode::EMERGENCY_STOP => {
                ESTOP_REMEDY.into()
            }
            Blocker::ControllerError(code) => match code.message() {
                Some(m) => format!("reset error {code} ({m}) at the pendant"),
                None => format!("reset error {code} at the pendant"),
            },
            Blocker::Teach => "switch TEACH/REPEAT to REPEAT".into(),
            Blocker::TeachLock => "turn TEACH LOCK off".into(),
            Blocker::Hold => "switch RUN/HOLD to RUN".into(),
            Blocker::PowerOff => "turn motor power on".into(),
            Blocker::ProgramNotRunning => "start the motion program first (Robot::start)".into(),
        }
    }
}

impl fmt::Display for Blocker {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}: {}", self.condition(), self.remedy())
    }
}

/// Formats a list of blockers as `"a: fix a; b: fix b"`.
pub(crate) fn list(blockers: &[Blocker]) -> String {
    blockers
        .iter()
        .map(ToString::to_string)
        .collect::<Vec<_>>()
        .join("; ")
}

/// Every condition in `status` that blocks starting the program (`need_program == false`) or
/// sending a motion (`need_program == true`), in the order a user should fix them.
///
/// ```
/// use fs020n_client::{blockers, Blocker};
/// use fs020n_proto::Status;
/// let s = Status::decode(" 1040 0 0 0 -1 0 0     1.000     0.000     0.000   -90.000     0.000   -90.000     0.000 ").unwrap();
/// assert_eq!(
///     blockers(&s, false),
///     vec![Blocker::Teach, Blocker::TeachLock, Blocker::Hold, Blocker::PowerOff]
/// );
/// ```
pub fn blockers(status: &Status, need_program: bool) -> Vec<Blocker> {
    let mut v = Vec::new();
    if !status.error.is_none() {
        v.push(Blocker::ControllerError(status.error));
    }
    if !status.repeat {
        v.push(Blocker::Teach);
    }
    if status.teach_lock {
        v.push(Blocker::TeachLock);
    }
    if !status.run {
        v.push(Blocker::Hold);
    }
    if !status.power {
        v.push(Blocker::PowerOff);
    }
    if need_program && !status.task_running && v.is_empty() {
        v.push(Blocker::ProgramNotRunning);
    }
    v
}

/// Upper bound of the controller's average pass duration `step` (spec §2.4) assumed when
/// checking where a command-7 sample can send the robot, seconds. A pass of the motion program
/// takes about 10 ms; this bound is ten times that. (At a low monitor speed a pass can wait for
/// the previous 0.1 s LMOVE, which is one more reason to stream at 100 %.)
pub const EXTRAPOLATION_STEP_BOUND_S: f64 = 0.1;

/// Largest look-ahead accepted for command 7, in passes of the motion program.
pub const MAX_LOOKAHEAD_PASSES: f64 = 50.0;

/// The interval of `dt` the controller can use with a command-7 sample of this look-ahead:
/// `dt = clamp(tm − t0, −0.5, 0.5) + lookahead · step` with `0 ≤ step ≤`
/// [`EXTRAPOLATION_STEP_BOUND_S`], so `[−0.5, 0.5 + lookahead · 0.1]` seconds.
///
/// ```
/// let (lo, hi) = fs020n_client::extrapolation_window(2.0);
/// assert_eq!((lo, hi), (-0.5, 0.7));
/// ```
pub fn extrapolation_window(lookahead_passes: f64) -> (f64, f64) {
    let clamp = StreamSample::TIME_CLAMP_S;
    (
        -clamp,
        clamp + lookahead_passes.max(0.0) * EXTRAPOLATION_STEP_BOUND_S,
    )
}

/// Why a command-7 sample is refused. The controller moves to
/// `position + velocity·dt + ½·acceleration·dt²` for any `dt` in
/// [`extrapolation_window`]: every such target, and the velocity and acceleration themselves,
/// are checked against the robot model before the sample is sent.
#[derive(Debug, Clone, Copy, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum SampleError {
    /// The time stamp, the look-ahead or a joint value is NaN or infinite.
    #[error("the {field}{} is not a finite number", .joint.map(|j| format!(" of JT{j}")).unwrap_or_default())]
    NonFinite {
        /// "time stamp", "look-ahead", "position", "velocity" or "acceleration".
        field: &'static str,
        /// 1-based joint, for joint values.
        joint: Option<usize>,
    },
    /// The look-ahead is outside 0–[`MAX_LOOKAHEAD_PASSES`] passes.
    #[error("look-ahead {passes} passes is outside 0 to {max}; give a look-ahead in that range")]
    Lookahead {
        /// The look-ahead, passes.
        passes: f64,
        /// The largest accepted.
        max: f64,
    },
    /// A velocity above the joint's maximum speed.
    #[error("JT{joint} velocity {velocity_deg_s:.3} deg/s is above its maximum {max_deg_s} deg/s; slow the motion down")]
    TooFast {
        /// 1-based joint.
        joint: usize,
        /// The velocity, deg/s.
        velocity_deg_s: f64,
        /// The model's maximum speed, deg/s.
        max_deg_s: f64,
    },
    /// An acceleration above the joint's maximum acceleration.
    #[error("JT{joint} acceleration {acceleration_deg_s2:.3} deg/s² is above its maximum {max_deg_s2} deg/s²; give a smoother motion")]
    AccelerationTooHigh {
        /// 1-based joint.
        joint: usize,
        /// The acceleration, deg/s².
        acceleration_deg_s2: f64,
        /// The model's maximum acceleration, deg/s².
        max_deg_s2: f64,
    },
    /// The controller's extrapolation can leave the joint range.
    #[error("the controller would extrapolate JT{joint} to {value_deg:.3} deg (dt = {dt_s:.3} s), outside its range [{min_deg}, {max_deg}]; keep position, velocity and acceleration such that every target within dt from {dt_min_s} to {dt_max_s} s stays inside the range")]
    ExtrapolatedOutOfRange {
        /// 1-based joint.
        joint: usize,
        /// The extrapolated value, degrees.
        value_deg: f64,
        /// The `dt` at which it is reached, seconds.
        dt_s: f64,
        /// Start of the `dt` window checked, seconds.
        dt_min_s: f64,
        /// End of the `dt` window checked, seconds.
        dt_max_s: f64,
        /// Lower limit, degrees.
        min_deg: f64,
        /// Upper limit, degrees.
        max_deg: f64,
    },
}

/// Checks a command-7 sample against the model: finite values, look-ahead 0–50, every
/// velocity at most the joint's maximum speed, every acceleration at most its maximum
/// acceleration, and every target the controller can extrapolate to (over the whole
/// [`extrapolation_window`]: both ends, `dt = 0` and the parabola's vertex when inside) inside
/// the joint ranges. The time stamp only has to be finite: the controller clamps its error to
/// ±0.5 s, which the window covers.
pub fn check_stream_sample(model: &RobotModel, sample: &StreamSample) -> Result<(), SampleError> {
    let nf = |field, joint| Err(SampleError::NonFinite { field, joint });
    if !sample.t0_s.is_finite() {
        return nf("time stamp", None);
    }
    let l = sample.lookahead_passes;
    if !l.is_finite() {
        return nf("look-ahead", None);
    }
    if !(0.0..=MAX_LOOKAHEAD_PASSES).contains(&l) {
        return Err(SampleError::Lookahead {
            passes: l,
            max: MAX_LOOKAHEAD_PASSES,
        });
    }
    for j in 0..JOINT_COUNT {
        for (field, v) in [
            ("position", sample.position[j]),
            ("velocity", sample.velocity[j]),
            ("acceleration", sample.acceleration[j]),
        ] {
            if !v.is_finite() {
                return nf(field, Some(j + 1));
            }
        }
    }
    let (dt_min, dt_max) = extrapolation_window(l);
    for (j, spec) in model.joints.iter().enumerate() {
        let (p, v, a) = (
            sample.position[j],
            sample.velocity[j],
            sample.acceleration[j],
        );
        if v.abs() > spec.max_speed_deg_s {
            return Err(SampleError::TooFast {
                joint: j + 1,
                velocity_deg_s: v,
                max_deg_s: spec.max_speed_deg_s,
            });
        }
        if a.abs() > spec.max_accel_deg_s2 {
            return Err(SampleError::AccelerationTooHigh {
                joint: j + 1,
                acceleration_deg_s2: a,
                max_deg_s2: spec.max_accel_deg_s2,
            });
        }
        // A parabola in dt: its extremes over the window are at the ends or at the vertex.
        let mut candidates = [dt_min, dt_max, 0.0, 0.0];
        let mut n = 3;
        if a != 0.0 {
            let vertex = -v / a;
            if vertex > dt_min && vertex < dt_max {
                candidates[n] = vertex;
                n += 1;
            }
        }
        let mut worst: Option<(f64, f64, f64)> = None; // (excess, value, dt)
        for &dt in &candidates[..n] {
            let value = p + v * dt + 0.5 * a * dt * dt;
            let excess = if value.is_nan() {
                f64::INFINITY
            } else {
                (spec.min_deg - value).max(value - spec.max_deg)
            };
            if excess > 0.0 && worst.is_none_or(|w| excess > w.0) {
                worst = Some((excess, value, dt));
            }
        }
        if let Some((_, value_deg, dt_s)) = worst {
            return Err(SampleError::ExtrapolatedOutOfRange {
                joint: j + 1,
                value_deg,
                dt_s,
                dt_min_s: dt_min,
                dt_max_s: dt_max,
                min_deg: spec.min_deg,
                max_deg: spec.max_deg,
            });
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use fs020n_proto::{JointsDeg, Timer};

    fn ready() -> Status {
        Status {
            version: 1040,
            error: ErrorCode::NONE,
            run: true,
            repeat: true,
            teach_lock: false,
            power: true,
            task_running: true,
            timer: Timer::Seconds(1.0),
            joints: JointsDeg::ZERO,
        }
    }

    #[test]
    fn ready_status_has_no_blockers() {
        assert!(blockers(&ready(), true).is_empty());
        let mut s = ready();
        s.task_running = false;
        assert!(blockers(&s, false).is_empty());
        assert_eq!(blockers(&s, true), vec![Blocker::ProgramNotRunning]);
    }

    #[test]
    fn estop_lists_error_and_power() {
        let mut s = ready();
        s.error = ErrorCode::EMERGENCY_STOP;
        s.power = false;
        s.task_running = false;
        let b = blockers(&s, true);
        assert_eq!(
            b,
            vec![
                Blocker::ControllerError(ErrorCode::EMERGENCY_STOP),
                Blocker::PowerOff
            ]
        );
        let text = list(&b);
        assert!(text.contains("E3808"), "{text}");
        assert!(text.contains(ESTOP_REMEDY), "{text}");
    }

    #[test]
    fn program_not_running_remedy_names_the_api() {
        let r = Blocker::ProgramNotRunning.remedy();
        assert!(!r.contains("fs020n"), "{r}");
        assert!(r.contains("Robot::start"), "{r}");
    }

    fn sample(p: f64, v: f64, a: f64) -> StreamSample {
        let m = RobotModel::fs020n();
        let (mut position, mut velocity, mut acceleration) =
            (m.home, JointsDeg::ZERO, JointsDeg::ZERO);
        position[0] = p;
        velocity[0] = v;
        acceleration[0] = a;
        StreamSample {
            t0_s: 1.0,
            lookahead_passes: 2.0,
            position,
            velocity,
            acceleration,
        }
    }

    #[test]
    fn stream_samples_are_checked_over_the_whole_extrapolation_window() {
        let m = RobotModel::fs020n();
        assert_eq!(check_stream_sample(&m, &sample(0.0, 0.0, 0.0)), Ok(()));
        assert_eq!(check_stream_sample(&m, &sample(150.0, 10.0, 0.0)), Ok(()));
        // The far end: 150 + 20 * 0.7 = 164.
        assert!(matches!(
            check_stream_sample(&m, &sample(150.0, 20.0, 0.0)),
            Err(SampleError::ExtrapolatedOutOfRange { joint: 1, value_deg, dt_s, .. })
                if (value_deg - 164.0).abs() < 1e-9 && (dt_s - 0.7).abs() < 1e-12
        ));
        // The near end, dt = -0.5: -150 + 30 * -0.5 = -165.
        assert!(matches!(
            check_stream_sample(&m, &sample(-150.0, 30.0, 0.0)),
            Err(SampleError::ExtrapolatedOutOfRange { joint: 1, dt_s, .. }) if dt_s == -0.5
        ));
        // Only the vertex leaves the range: 156 + 30 t - 50 t² peaks at t = 0.3 with 160.5;
        // both ends are inside (128.5 and 152.5).
        match check_stream_sample(&m, &sample(156.0, 30.0, -100.0)) {
            Err(SampleError::ExtrapolatedOutOfRange {
                joint: 1,
                value_deg,
                dt_s,
                ..
            }) => {
                assert!((value_deg - 160.5).abs() < 1e-9, "{value_deg}");
                assert!((dt_s - 0.3).abs() < 1e-12, "{dt_s}");
            }
            other => panic!("{other:?}"),
        }
        // Velocity and acceleration against the model.
        assert!(matches!(
            check_stream_sample(&m, &sample(0.0, -190.5, 0.0)),
            Err(SampleError::TooFast { joint: 1, .. })
        ));
        assert!(matches!(
            check_stream_sample(&m, &sample(0.0, 0.0, 236.0)),
            Err(SampleError::AccelerationTooHigh { joint: 1, .. })
        ));
        assert_eq!(check_stream_sample(&m, &sample(0.0, 0.0, 235.0)), Ok(()));
        // Look-ahead widens the window: 2 passes -> 0.7 s, 10 passes -> 1.5 s.
        let mut s = sample(150.0, 10.0, 0.0);
        assert_eq!(check_stream_sample(&m, &s), Ok(()));
        s.lookahead_passes = 10.0;
        assert!(matches!(
            check_stream_sample(&m, &s),
            Err(SampleError::ExtrapolatedOutOfRange { dt_s, .. }) if (dt_s - 1.5).abs() < 1e-12
        ));
        for bad in [-1.0, 51.0, f64::NAN] {
            s.lookahead_passes = bad;
            assert!(check_stream_sample(&m, &s).is_err(), "{bad}");
        }
        let mut s = sample(0.0, 0.0, 0.0);
        s.t0_s = f64::INFINITY;
        assert!(matches!(
            check_stream_sample(&m, &s),
            Err(SampleError::NonFinite {
                field: "time stamp",
                ..
            })
        ));
        s.t0_s = 0.0;
        s.acceleration[3] = f64::NAN;
        assert!(matches!(
            check_stream_sample(&m, &s),
            Err(SampleError::NonFinite {
                field: "acceleration",
                joint: Some(4)
            })
        ));
    }
}
