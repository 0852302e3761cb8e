//! What every part of the node shares: the settings, the robot model, the session's source,
//! the state `/diagnostics` reports, the log, and the one owner of motion.

use std::sync::{Arc, Mutex, MutexGuard};

use fs020n_client::Robot;
use fs020n_kin::RobotModel;
use ros2_client::action_msgs::GoalId;
use ros2_client::log::LogLevel;
use ros2_client::RosoutRaw;

use crate::config::NodeConfig;
use crate::diagnostics::NodeState;
use crate::motion_owner::MotionOwner;
use crate::source::RobotSource;

/// Locks `m`, going on after a panic elsewhere (the data are plain state).
pub(crate) fn lock<T>(m: &Mutex<T>) -> MutexGuard<'_, T> {
    m.lock().unwrap_or_else(|p| p.into_inner())
}

/// What every part of the node shares.
pub(crate) struct Shared {
    pub(crate) config: NodeConfig,
    pub(crate) model: RobotModel,
    pub(crate) source: Arc<dyn RobotSource>,
    pub(crate) state: Mutex<NodeState>,
    pub(crate) logger: ros2_client::NodeLoggingHandle,
    /// What moves the arm, and when a move may start the motion program (the re-arm policy).
    pub(crate) motion: Mutex<MotionOwner<GoalId>>,
}

impl Shared {
    /// Logs on `/rosout`.
    pub(crate) fn log(&self, level: LogLevel, msg: &str) {
        self.logger.rosout_raw(
            ros2_client::builtin_interfaces::Time::now(),
            level,
            &self.config.node_name,
            msg,
            file!(),
            "",
            line!(),
        );
    }

    /// The session to act on now, or why there is none (with the remedy).
    pub(crate) fn robot(&self) -> Result<Arc<Robot>, String> {
        match self.source.robot() {
            Some(r) if r.is_connected() => Ok(r),
            Some(r) => Err(format!(
                "the robot session has ended ({}); restart the node",
                r.link_error().map_or("closed".into(), |e| e.to_string())
            )),
            None => Err("no robot session at the moment; try again when it is connected".into()),
        }
    }
}
