//! The checks made before a request leaves the PC, as [`ClientError`]s (the conditions
//! themselves live in [`crate::safety`], which depends on nothing else of the crate).

use fs020n_kin::RobotModel;
use fs020n_proto::JointsDeg;

use crate::error::ClientError;

/// Checks a joint target: finite, inside the model's ranges.
pub(crate) fn check_target(model: &RobotModel, target: &JointsDeg) -> Result<(), ClientError> {
    if let Some(i) = target.iter().position(|v| !v.is_finite()) {
        return Err(ClientError::NonFinite {
            what: format!("JT{} target ({})", i + 1, target[i]),
        });
    }
    Ok(model.check_limits(target)?)
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
    use fs020n_kin::LimitError;

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
