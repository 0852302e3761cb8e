//! # fs020n-ros2
//!
//! A ROS 2 node for the Kawasaki FS020N in pure Rust on DDS (`ros2-client` / RustDDS): no ROS
//! installation is needed to build or run it, and MoveIt 2 drives the arm through it like
//! through a `joint_trajectory_controller`.
//!
//! * `/joint_states` (`sensor_msgs/msg/JointState`, `joint_1`…`joint_6`, radians) at 100 Hz;
//! * `/robot_description` (`std_msgs/msg/String`, transient local): a URDF generated from the
//!   robot model ([`urdf`]);
//! * the action `/fs020n_controller/follow_joint_trajectory`
//!   (`control_msgs/action/FollowJointTrajectory`): every goal is checked with the client
//!   library's checks before anything moves ([`goal`]), then streamed with command 7 (or
//!   command 6 waypoints) with feedback, path and goal tolerances, cancel (the robot brakes)
//!   and an error code when the robot faults ([`execute`]);
//! * `~/joint_trajectory` (a streamed trajectory replacing the running one), `~/commands`
//!   (forward positions for MoveIt Servo and teleoperation, sent through the client's servo and
//!   its watchdog: [`forward`]), `/tf` and
//!   `/tf_static` ([`tf`]), `--ros-args` ([`RosArgs`]);
//! * `~/start`, `~/stop`, `~/cancel` (`std_srvs/srv/Trigger`) and `~/set_speed`
//!   (`fs020n_msgs/srv/SetSpeed`);
//! * `/diagnostics` (`diagnostic_msgs/msg/DiagnosticArray`): switches, error with its remedy,
//!   program ([`diagnostics`]);
//! * settings from a ROS 2 parameter file ([`NodeConfig`]);
//! * MoveIt's robot files: URDF with collision shapes ([`urdf`]), SRDF with the self-collision
//!   matrix ([`srdf`]) and a configuration package ([`moveit`]).
//!
//! The node runs on a shared robot session ([`RobotSource`]), so that a host owning the
//! session (the CLI, a hub serving other faces too) can run it next to its other work:
//! [`run`]. Usage and the MoveIt configuration: `docs/ROS2.md`.
#![forbid(unsafe_code)]
#![warn(missing_docs)]

pub mod action;
mod action_loop;
pub mod arming;
pub mod config;
pub mod diagnostics;
mod error;
pub mod execute;
pub mod forward;
pub mod goal;
mod loops;
pub mod motion_owner;
pub mod moveit;
mod moves;
pub mod msg;
mod node;
mod replies;
pub mod reply_gate;
pub mod ros_args;
mod services;
mod shared;
mod source;
pub mod srdf;
pub mod tf;
pub mod urdf;

pub use config::{DdsConfig, ExecutionConfig, NodeConfig, Params, ServiceMapping};
pub use error::Ros2Error;
pub use node::run;
pub use ros_args::RosArgs;
pub use source::{Action, Permit, RobotSource};

#[cfg(test)]
mod tests {
    /// A host can `tokio::spawn` the node.
    #[allow(dead_code)]
    fn the_node_future_is_send(source: std::sync::Arc<dyn super::RobotSource>) {
        fn send<T: Send>(_: T) {}
        send(super::run(
            super::NodeConfig::default(),
            fs020n_kin::RobotModel::fs020n(),
            source,
            std::future::pending::<()>(),
        ));
    }
}

/// The README's examples, compiled as doctests.
#[cfg(doctest)]
#[doc = include_str!("../README.md")]
struct ReadmeDoctests;
