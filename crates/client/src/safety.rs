//! Conditions that block motion, with what to do about each, and the checks made before any
//! request leaves the PC.

use std::fmt;

use fs020n_kin::{LimitError, RobotModel};
use fs020n_proto::{ErrorCode, JointsDeg, Status};
use serde::Serialize;

use crate::error::ClientError;

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
            Blocker::ProgramNotRunning => {
                "start the motion program (Robot::start, or `fs020n start`)".into()
            }
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

/// Checks a joint target: finite, inside the model's ranges.
pub(crate) fn check_target(model: &RobotModel, target: &JointsDeg) -> Result<(), ClientError> {
    if let Some(i) = target.iter().position(|v| !v.is_finite()) {
        return Err(ClientError::NonFinite {
            what: format!("JT{} target ({})", i + 1, target[i]),
        });
    }
    model
        .check_limits(target)
        .map_err(|e: LimitError| ClientError::Limit(e))
}

/// Checks a speed in percent: finite, 1–100.
pub(crate) fn check_speed(percent: f64) -> Result<(), ClientError> {
    if !(percent.is_finite() && (1.0..=100.0).contains(&percent)) {
        return Err(ClientError::Speed { percent });
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use fs020n_proto::Timer;

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
    fn speed_and_target_checks() {
        assert!(check_speed(1.0).is_ok() && check_speed(100.0).is_ok());
        for bad in [0.0, 0.5, 100.1, f64::NAN, f64::INFINITY, -3.0] {
            assert!(matches!(check_speed(bad), Err(ClientError::Speed { .. })));
        }
        let m = RobotModel::fs020n();
        assert!(check_target(&m, &m.home).is_ok());
        let mut t = m.home;
        t[0] = 161.0;
        assert!(matches!(
            check_target(&m, &t),
            Err(ClientError::Limit(LimitError { joint: 1, .. }))
        ));
        t[0] = f64::NAN;
        assert!(matches!(
            check_target(&m, &t),
            Err(ClientError::NonFinite { .. })
        ));
    }
}
