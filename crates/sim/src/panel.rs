//! The controller's panel and pendant switches.

use serde::{Deserialize, Serialize};

/// Switches of the controller panel and teach pendant.
///
/// The default describes a robot ready to run: motor power ON, RUN, REPEAT, TEACH LOCK OFF,
/// emergency stop released.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(default)]
pub struct Panel {
    /// Motor power ON.
    pub power: bool,
    /// RUN/HOLD switch on RUN (false = HOLD).
    pub run: bool,
    /// TEACH/REPEAT switch on REPEAT (false = TEACH).
    pub repeat: bool,
    /// TEACH LOCK ON (the pendant has control).
    pub teach_lock: bool,
    /// Emergency stop pressed.
    pub estop: bool,
}

impl Default for Panel {
    fn default() -> Self {
        Panel {
            power: true,
            run: true,
            repeat: true,
            teach_lock: false,
            estop: false,
        }
    }
}
