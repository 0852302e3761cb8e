//! Errors of the ROS 2 node. Every message says what to do about it.

use fs020n_client::ClientError;

/// Why the node could not start or stopped.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum Ros2Error {
    /// A setting out of its range.
    #[error("invalid setting: {0}")]
    Config(String),
    /// A ROS 2 parameter file that cannot be read or holds bad values.
    #[error("parameter file {path}: {message}")]
    ParamsFile {
        /// The file.
        path: String,
        /// What is wrong.
        message: String,
    },
    /// The DDS participant, a topic, a service or the action could not be created.
    #[error(
        "DDS: {0}; check that no firewall blocks UDP ports 7400-7700 and that ROS_DOMAIN_ID is \
         0-232 (with --localhost-only only 127.0.0.1 is used)"
    )]
    Dds(String),
    /// The robot session failed.
    #[error("robot: {0}")]
    Robot(#[from] ClientError),
}
