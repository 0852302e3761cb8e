//! The ROS 2 message, service and action types the node speaks, as plain serde structs laid
//! out field for field like the ROS 2 IDL (so that their CDR encoding is the one every ROS 2
//! middleware uses). Only the types this node needs; each names its ROS 2 type.
//!
//! Units are ROS's: radians, seconds, `builtin_interfaces` time stamps.

use serde::{Deserialize, Serialize};

/// `builtin_interfaces/msg/Time`: seconds and nanoseconds since the Unix epoch.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
pub struct Time {
    /// Seconds.
    pub sec: i32,
    /// Nanoseconds, 0–999 999 999.
    pub nanosec: u32,
}

impl Time {
    /// Zero: "now" in a goal's header.
    pub const ZERO: Time = Time { sec: 0, nanosec: 0 };

    /// The system clock now.
    pub fn now() -> Time {
        Time::from_system(std::time::SystemTime::now())
    }

    /// A system-clock instant (saturating at the ends of the 32-bit second range).
    pub fn from_system(t: std::time::SystemTime) -> Time {
        match t.duration_since(std::time::UNIX_EPOCH) {
            Ok(d) => Time {
                sec: i32::try_from(d.as_secs()).unwrap_or(i32::MAX),
                nanosec: d.subsec_nanos(),
            },
            Err(_) => Time::ZERO,
        }
    }

    /// Seconds since the epoch as a float.
    pub fn as_secs_f64(&self) -> f64 {
        f64::from(self.sec) + f64::from(self.nanosec) * 1e-9
    }

    /// `true` for the zero stamp.
    pub fn is_zero(&self) -> bool {
        *self == Time::ZERO
    }
}

/// `builtin_interfaces/msg/Duration`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
pub struct Duration {
    /// Seconds (may be negative).
    pub sec: i32,
    /// Nanoseconds added to `sec`, 0–999 999 999.
    pub nanosec: u32,
}

impl Duration {
    /// Seconds as a float (`sec + nanosec·10⁻⁹`; a `nanosec` above 10⁹ counts as given).
    pub fn as_secs_f64(&self) -> f64 {
        f64::from(self.sec) + f64::from(self.nanosec) * 1e-9
    }

    /// From seconds (negative and non-finite values give zero; saturating).
    pub fn from_secs_f64(s: f64) -> Duration {
        if !(s.is_finite() && s > 0.0) {
            return Duration::default();
        }
        let whole = s.floor();
        let sec = if whole >= f64::from(i32::MAX) {
            i32::MAX
        } else {
            whole as i32
        };
        let nanosec = (((s - whole) * 1e9).round() as u32).min(999_999_999);
        Duration { sec, nanosec }
    }
}

/// `std_msgs/msg/Header`.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct Header {
    /// Time stamp.
    pub stamp: Time,
    /// Frame.
    pub frame_id: String,
}

/// `std_msgs/msg/String`.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct StringMsg {
    /// The text.
    pub data: String,
}

/// `std_msgs/msg/MultiArrayDimension`.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct MultiArrayDimension {
    /// The dimension's label.
    pub label: String,
    /// Its size.
    pub size: u32,
    /// Its stride.
    pub stride: u32,
}

/// `std_msgs/msg/MultiArrayLayout`.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct MultiArrayLayout {
    /// The dimensions (empty for a plain vector).
    pub dim: Vec<MultiArrayDimension>,
    /// Padding before the data.
    pub data_offset: u32,
}

/// `std_msgs/msg/Float64MultiArray`: the forward position command (`~/commands`).
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct Float64MultiArray {
    /// The layout (ignored: `data` is one position per joint).
    pub layout: MultiArrayLayout,
    /// The values.
    pub data: Vec<f64>,
}

/// `sensor_msgs/msg/JointState`.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct JointState {
    /// Stamp of the controller reply the positions come from.
    pub header: Header,
    /// Joint names.
    pub name: Vec<String>,
    /// Positions, radians.
    pub position: Vec<f64>,
    /// Velocities, rad/s (empty: unknown).
    pub velocity: Vec<f64>,
    /// Efforts (empty: unknown).
    pub effort: Vec<f64>,
}

/// `trajectory_msgs/msg/JointTrajectoryPoint`.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct JointTrajectoryPoint {
    /// Positions, radians.
    pub positions: Vec<f64>,
    /// Velocities, rad/s (may be empty).
    pub velocities: Vec<f64>,
    /// Accelerations, rad/s² (may be empty).
    pub accelerations: Vec<f64>,
    /// Efforts (ignored).
    pub effort: Vec<f64>,
    /// Time of this point from the trajectory's start.
    pub time_from_start: Duration,
}

/// `trajectory_msgs/msg/JointTrajectory`.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct JointTrajectory {
    /// `stamp` is when the trajectory starts (zero: now).
    pub header: Header,
    /// The joints of every point, in the points' order.
    pub joint_names: Vec<String>,
    /// The points.
    pub points: Vec<JointTrajectoryPoint>,
}

/// `geometry_msgs/msg/Vector3`.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct Vector3 {
    /// X.
    pub x: f64,
    /// Y.
    pub y: f64,
    /// Z.
    pub z: f64,
}

/// `geometry_msgs/msg/Quaternion`.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct Quaternion {
    /// X.
    pub x: f64,
    /// Y.
    pub y: f64,
    /// Z.
    pub z: f64,
    /// W.
    pub w: f64,
}

/// `geometry_msgs/msg/Transform`.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct Transform {
    /// Translation.
    pub translation: Vector3,
    /// Rotation.
    pub rotation: Quaternion,
}

/// `geometry_msgs/msg/Twist`.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct Twist {
    /// Linear part.
    pub linear: Vector3,
    /// Angular part.
    pub angular: Vector3,
}

/// `trajectory_msgs/msg/MultiDOFJointTrajectoryPoint` (the FS020N has no multi-DOF joints: a
/// goal must leave these empty).
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct MultiDofJointTrajectoryPoint {
    /// Transforms.
    pub transforms: Vec<Transform>,
    /// Velocities.
    pub velocities: Vec<Twist>,
    /// Accelerations.
    pub accelerations: Vec<Twist>,
    /// Time from start.
    pub time_from_start: Duration,
}

/// `trajectory_msgs/msg/MultiDOFJointTrajectory`.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct MultiDofJointTrajectory {
    /// Header.
    pub header: Header,
    /// Joint names.
    pub joint_names: Vec<String>,
    /// Points.
    pub points: Vec<MultiDofJointTrajectoryPoint>,
}

/// `control_msgs/msg/JointTolerance`: per-joint tolerances; 0 means "the server's default",
/// −1 means "no limit".
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct JointTolerance {
    /// Joint name.
    pub name: String,
    /// Position tolerance, radians.
    pub position: f64,
    /// Velocity tolerance, rad/s (not enforced: the protocol reports no velocities).
    pub velocity: f64,
    /// Acceleration tolerance, rad/s² (not enforced).
    pub acceleration: f64,
}

/// `control_msgs/msg/JointComponentTolerance` (for multi-DOF joints; must be empty here).
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct JointComponentTolerance {
    /// Joint name.
    pub joint_name: String,
    /// Component (1 X, 2 Y, 3 Z, 4 translation, 5 rotation).
    pub component: u16,
    /// Position tolerance.
    pub position: f64,
    /// Velocity tolerance.
    pub velocity: f64,
    /// Acceleration tolerance.
    pub acceleration: f64,
}

/// `control_msgs/action/FollowJointTrajectory` goal.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct FollowJointTrajectoryGoal {
    /// The trajectory of the six joints.
    pub trajectory: JointTrajectory,
    /// Multi-DOF trajectory (must be empty).
    pub multi_dof_trajectory: MultiDofJointTrajectory,
    /// Tolerances while moving.
    pub path_tolerance: Vec<JointTolerance>,
    /// Component tolerances while moving (must be empty).
    pub component_path_tolerance: Vec<JointComponentTolerance>,
    /// Tolerances at the end.
    pub goal_tolerance: Vec<JointTolerance>,
    /// Component tolerances at the end (must be empty).
    pub component_goal_tolerance: Vec<JointComponentTolerance>,
    /// Extra time after the trajectory's end to come within the goal tolerances.
    pub goal_time_tolerance: Duration,
}

/// `control_msgs/action/FollowJointTrajectory` result.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct FollowJointTrajectoryResult {
    /// One of the `error_code` constants of [`error_code`].
    pub error_code: i32,
    /// What happened, and what to do about it.
    pub error_string: String,
}

/// The `error_code` constants of `FollowJointTrajectory`'s result.
pub mod error_code {
    /// Success.
    pub const SUCCESSFUL: i32 = 0;
    /// The goal is invalid (refused before moving).
    pub const INVALID_GOAL: i32 = -1;
    /// The goal names other joints than the robot's.
    pub const INVALID_JOINTS: i32 = -2;
    /// The goal's header stamp is too old.
    pub const OLD_HEADER_TIMESTAMP: i32 = -3;
    /// A path tolerance was violated, or the robot stopped while moving (fault, E-stop, link).
    pub const PATH_TOLERANCE_VIOLATED: i32 = -4;
    /// The robot did not end within the goal tolerances in time.
    pub const GOAL_TOLERANCE_VIOLATED: i32 = -5;
}

/// `control_msgs/action/FollowJointTrajectory` feedback.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct FollowJointTrajectoryFeedback {
    /// Stamp.
    pub header: Header,
    /// The joints, in the goal's order.
    pub joint_names: Vec<String>,
    /// Where the trajectory is now.
    pub desired: JointTrajectoryPoint,
    /// Where the robot is (its latest reply).
    pub actual: JointTrajectoryPoint,
    /// `desired − actual`.
    pub error: JointTrajectoryPoint,
    /// Multi-DOF joint names (empty).
    pub multi_dof_joint_names: Vec<String>,
    /// Empty.
    pub multi_dof_desired: MultiDofJointTrajectoryPoint,
    /// Empty.
    pub multi_dof_actual: MultiDofJointTrajectoryPoint,
    /// Empty.
    pub multi_dof_error: MultiDofJointTrajectoryPoint,
}

/// `diagnostic_msgs/msg/KeyValue`.
#[derive(Debug, Clone, PartialEq, Eq, Default, Serialize, Deserialize)]
pub struct KeyValue {
    /// Key.
    pub key: String,
    /// Value.
    pub value: String,
}

/// `diagnostic_msgs/msg/DiagnosticStatus`.
#[derive(Debug, Clone, PartialEq, Eq, Default, Serialize, Deserialize)]
pub struct DiagnosticStatus {
    /// [`DiagnosticStatus::OK`], `WARN`, `ERROR` or `STALE`.
    pub level: u8,
    /// Name of what is reported.
    pub name: String,
    /// Summary.
    pub message: String,
    /// Hardware identifier.
    pub hardware_id: String,
    /// Details.
    pub values: Vec<KeyValue>,
}

impl DiagnosticStatus {
    /// Level OK.
    pub const OK: u8 = 0;
    /// Level WARN.
    pub const WARN: u8 = 1;
    /// Level ERROR.
    pub const ERROR: u8 = 2;
    /// Level STALE.
    pub const STALE: u8 = 3;
}

/// `diagnostic_msgs/msg/DiagnosticArray`.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct DiagnosticArray {
    /// Header.
    pub header: Header,
    /// Statuses.
    pub status: Vec<DiagnosticStatus>,
}

/// `std_srvs/srv/Trigger` request (an empty ROS 2 structure carries one placeholder byte).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
pub struct TriggerRequest {
    /// The placeholder the ROS 2 IDL gives every empty structure.
    pub structure_needs_at_least_one_member: u8,
}

/// `std_srvs/srv/Trigger` response.
#[derive(Debug, Clone, PartialEq, Eq, Default, Serialize, Deserialize)]
pub struct TriggerResponse {
    /// Done.
    pub success: bool,
    /// What happened (with a remedy when it failed).
    pub message: String,
}

/// `fs020n_msgs/srv/SetSpeed` request: the monitor speed, percent (1–100). The interface
/// definition ships in `crates/ros2/interfaces/fs020n_msgs/srv/SetSpeed.srv`.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct SetSpeedRequest {
    /// Percent, 1–100.
    pub percent: f64,
}

/// `fs020n_msgs/srv/SetSpeed` response.
#[derive(Debug, Clone, PartialEq, Eq, Default, Serialize, Deserialize)]
pub struct SetSpeedResponse {
    /// Done.
    pub success: bool,
    /// What happened (with a remedy when it failed).
    pub message: String,
}

/// `geometry_msgs/TransformStamped`: `child_frame_id` in `header.frame_id`.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct TransformStamped {
    /// Stamp and parent frame.
    pub header: Header,
    /// Child frame.
    pub child_frame_id: String,
    /// The child frame in the parent's.
    pub transform: Transform,
}

/// `tf2_msgs/TFMessage` (`/tf`, `/tf_static`).
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct TfMessage {
    /// The transforms.
    pub transforms: Vec<TransformStamped>,
}

macro_rules! messages {
    ($($t:ty),* $(,)?) => { $(impl ros2_client::Message for $t {})* };
}

messages!(
    Time,
    Duration,
    Header,
    StringMsg,
    JointState,
    JointTrajectoryPoint,
    JointTrajectory,
    FollowJointTrajectoryGoal,
    FollowJointTrajectoryResult,
    FollowJointTrajectoryFeedback,
    DiagnosticArray,
    TriggerRequest,
    TriggerResponse,
    SetSpeedRequest,
    SetSpeedResponse,
    TfMessage,
);

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn durations_round_trip_through_seconds() {
        let d = Duration::from_secs_f64(1.25);
        assert_eq!(
            d,
            Duration {
                sec: 1,
                nanosec: 250_000_000
            }
        );
        assert!((d.as_secs_f64() - 1.25).abs() < 1e-12);
        assert_eq!(Duration::from_secs_f64(-3.0), Duration::default());
        assert_eq!(Duration::from_secs_f64(f64::NAN), Duration::default());
        assert_eq!(Duration::from_secs_f64(1e12).sec, i32::MAX);
    }

    #[test]
    fn time_now_is_after_2020() {
        assert!(Time::now().sec > 1_577_836_800);
        assert!(!Time::now().is_zero());
    }
}
