//! The node's settings: defaults, ROS 2 parameter files (YAML), and validation.

use std::path::Path;
use std::time::Duration;

use fs020n_client::{StreamMode, StreamOptions};
use fs020n_proto::JOINT_COUNT;
use serde::Deserialize;

use crate::error::Ros2Error;

/// How long a reply waits for its reader by default before it is sent anyway.
pub const DEFAULT_READER_WAIT: Duration = Duration::from_secs(5);

/// How services are mapped onto DDS topics: this must match the ROS 2 middleware of the peers
/// (a FastDDS-based ROS 2 — the default of Humble and Jazzy — uses `Enhanced`; a ROS 2 with
/// `RMW_IMPLEMENTATION=rmw_cyclonedds_cpp` uses `Cyclone`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum ServiceMapping {
    /// Request identity in the DDS sample (FastDDS, Connext "extended").
    #[default]
    Enhanced,
    /// A request header in the payload (rmw_cyclonedds).
    Cyclone,
    /// The DDS-RPC "basic" mapping (Connext "basic").
    Basic,
}

impl ServiceMapping {
    /// Parses `enhanced`, `cyclone` (or `cyclonedds`) or `basic`.
    pub fn parse(text: &str) -> Result<ServiceMapping, Ros2Error> {
        match text.to_ascii_lowercase().as_str() {
            "enhanced" | "fastdds" | "fastrtps" => Ok(ServiceMapping::Enhanced),
            "cyclone" | "cyclonedds" => Ok(ServiceMapping::Cyclone),
            "basic" => Ok(ServiceMapping::Basic),
            other => Err(Ros2Error::Config(format!(
                "service mapping {other:?}: give enhanced (ROS 2 on FastDDS, the default), \
                 cyclone (RMW_IMPLEMENTATION=rmw_cyclonedds_cpp) or basic"
            ))),
        }
    }

    pub(crate) fn to_client(self) -> ros2_client::ServiceMapping {
        match self {
            ServiceMapping::Enhanced => ros2_client::ServiceMapping::Enhanced,
            ServiceMapping::Cyclone => ros2_client::ServiceMapping::Cyclone,
            ServiceMapping::Basic => ros2_client::ServiceMapping::Basic,
        }
    }
}

/// The DDS participant.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct DdsConfig {
    /// ROS domain (`ROS_DOMAIN_ID`), 0–232. Default 0.
    pub domain_id: u16,
    /// Use the loopback interface only (`ROS_LOCALHOST_ONLY=1` or
    /// `ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST`): discovery and data stay on 127.0.0.1.
    pub localhost_only: bool,
    /// Service mapping of the peers' middleware.
    pub service_mapping: ServiceMapping,
}

impl DdsConfig {
    /// Defaults overridden by the ROS 2 environment variables `ROS_DOMAIN_ID`,
    /// `ROS_LOCALHOST_ONLY` and `ROS_AUTOMATIC_DISCOVERY_RANGE`.
    pub fn from_env() -> Result<DdsConfig, Ros2Error> {
        let mut c = DdsConfig::default();
        if let Ok(v) = std::env::var("ROS_DOMAIN_ID") {
            if !v.trim().is_empty() {
                c.domain_id = parse_domain(v.trim())?;
            }
        }
        if std::env::var("ROS_LOCALHOST_ONLY").is_ok_and(|v| v.trim() == "1") {
            c.localhost_only = true;
        }
        if std::env::var("ROS_AUTOMATIC_DISCOVERY_RANGE")
            .is_ok_and(|v| v.trim().eq_ignore_ascii_case("localhost"))
        {
            c.localhost_only = true;
        }
        Ok(c)
    }
}

/// Parses a ROS domain id (0–232: the DDS port formula leaves the UDP range above).
pub fn parse_domain(text: &str) -> Result<u16, Ros2Error> {
    match text.parse::<u16>() {
        Ok(d) if d <= MAX_DOMAIN_ID => Ok(d),
        _ => Err(Ros2Error::Config(format!(
            "ROS domain id {text:?} must be a whole number from 0 to {MAX_DOMAIN_ID}"
        ))),
    }
}

/// Largest ROS domain id.
pub const MAX_DOMAIN_ID: u16 = 232;

/// How an accepted trajectory goal is executed and judged.
#[derive(Debug, Clone, PartialEq)]
pub struct ExecutionConfig {
    /// Command 7 (extrapolated samples, default) or command 6 waypoints, with the stream's
    /// period and per-cycle step bound (see `fs020n_client::StreamOptions`).
    pub stream: StreamOptions,
    /// Largest distance of the goal's first point (when it is at time 0) from the current
    /// joints, radians. Default 0.02 rad (1.15°).
    pub start_tolerance_rad: f64,
    /// Goal tolerance of a joint the goal gives none for, radians. Default 0.01 rad.
    pub goal_tolerance_rad: f64,
    /// Path tolerance of a joint the goal gives none for, radians; 0: not checked (default).
    pub path_tolerance_rad: f64,
    /// Time after the trajectory's end to come within the goal tolerances when the goal gives
    /// none. Default 2 s.
    pub goal_time_tolerance: Duration,
    /// Armed from the start: a goal may start the motion program (command 1, after the
    /// preflight) when it is not running, until the first fault (then `~/start` re-arms; see
    /// [`crate::arming`]). Default off: call `~/start` first. Either way, after the node's own
    /// stops (a cancel, a preemption) the next goal starts the program again.
    pub auto_start: bool,
    /// Longest wait for a goal whose header stamp lies in the future. Default 10 s.
    pub max_start_delay: Duration,
}

impl Default for ExecutionConfig {
    fn default() -> Self {
        ExecutionConfig {
            stream: StreamOptions {
                max_step_deg: 4.0,
                ..StreamOptions::default()
            },
            start_tolerance_rad: 0.02,
            goal_tolerance_rad: 0.01,
            path_tolerance_rad: 0.0,
            goal_time_tolerance: Duration::from_secs(2),
            auto_start: false,
            max_start_delay: Duration::from_secs(10),
        }
    }
}

/// Every setting of the node.
#[derive(Debug, Clone, PartialEq)]
pub struct NodeConfig {
    /// Node name. Default `fs020n`.
    pub node_name: String,
    /// Node namespace. Default `/`.
    pub namespace: String,
    /// JT1…JT6 as named in `/joint_states`, the URDF and trajectory goals. Default
    /// `joint_1` … `joint_6`.
    pub joint_names: [String; JOINT_COUNT],
    /// `/joint_states` rate, Hz (1–1000). Default 100.
    pub joint_state_rate_hz: f64,
    /// `/diagnostics` rate, Hz (0.1–100). Default 1.
    pub diagnostics_rate_hz: f64,
    /// Action feedback rate, Hz (1–1000). Default 20.
    pub feedback_rate_hz: f64,
    /// The action is `<action_namespace>/follow_joint_trajectory`. Default
    /// `/fs020n_controller` (the controller name in MoveIt's `moveit_controllers.yaml`).
    pub action_namespace: String,
    /// Monitor speed set when the node starts, percent (1–100); `None` leaves it. Default 100
    /// (command 7 tracks best at 100 %; the trajectory's own timing sets the speed).
    pub speed_percent: Option<f64>,
    /// Execution of goals.
    pub execution: ExecutionConfig,
    /// How long a finished goal's result is kept for late result requests, seconds (1 s to a
    /// day). Default 900 (15 min, as rcl_action).
    pub result_retention_s: f64,
    /// Longest wait of a service reply for its requester's reply reader, seconds (0 to 600; 0:
    /// never wait): the reader the request names (rmw_fastrtps), or a reader of the reply topic
    /// in the requester's participant; see [`crate::reply_gate`]. Default 5.
    pub reply_reader_wait_s: f64,
    /// Remaps of topic and service names (from, to), as `--ros-args -r` gives them; see
    /// [`NodeConfig::resolve`].
    pub remaps: Vec<(String, String)>,
    /// The DDS participant.
    pub dds: DdsConfig,
}

impl Default for NodeConfig {
    fn default() -> Self {
        NodeConfig {
            node_name: "fs020n".into(),
            namespace: "/".into(),
            joint_names: std::array::from_fn(|i| format!("joint_{}", i + 1)),
            joint_state_rate_hz: 100.0,
            diagnostics_rate_hz: 1.0,
            feedback_rate_hz: 20.0,
            action_namespace: "/fs020n_controller".into(),
            speed_percent: Some(100.0),
            execution: ExecutionConfig::default(),
            result_retention_s: crate::action::DEFAULT_RESULT_RETENTION.as_secs_f64(),
            reply_reader_wait_s: DEFAULT_READER_WAIT.as_secs_f64(),
            remaps: Vec::new(),
            dds: DdsConfig::default(),
        }
    }
}

/// The parameters a ROS 2 parameter file may set (`<node>: ros__parameters: {…}`); every key
/// is optional, unknown keys are refused.
#[derive(Debug, Clone, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Params {
    /// See [`NodeConfig::joint_names`].
    pub joint_names: Option<Vec<String>>,
    /// See [`NodeConfig::joint_state_rate_hz`].
    pub joint_state_rate_hz: Option<f64>,
    /// See [`NodeConfig::diagnostics_rate_hz`].
    pub diagnostics_rate_hz: Option<f64>,
    /// See [`NodeConfig::feedback_rate_hz`].
    pub feedback_rate_hz: Option<f64>,
    /// See [`NodeConfig::action_namespace`].
    pub action_namespace: Option<String>,
    /// See [`NodeConfig::speed_percent`]; 0 leaves the speed as it is.
    pub speed_percent: Option<f64>,
    /// `stream` (command 7) or `waypoints` (command 6).
    pub execution_mode: Option<String>,
    /// Stream period, seconds.
    pub stream_period_s: Option<f64>,
    /// Command-7 look-ahead, passes.
    pub lookahead_passes: Option<f64>,
    /// Largest per-cycle step of any joint, degrees.
    pub max_step_deg: Option<f64>,
    /// See [`ExecutionConfig::start_tolerance_rad`].
    pub start_tolerance_rad: Option<f64>,
    /// See [`ExecutionConfig::goal_tolerance_rad`].
    pub goal_tolerance_rad: Option<f64>,
    /// See [`ExecutionConfig::path_tolerance_rad`].
    pub path_tolerance_rad: Option<f64>,
    /// See [`ExecutionConfig::goal_time_tolerance`], seconds.
    pub goal_time_tolerance_s: Option<f64>,
    /// See [`ExecutionConfig::auto_start`].
    pub auto_start: Option<bool>,
    /// See [`NodeConfig::result_retention_s`].
    pub result_retention_s: Option<f64>,
    /// See [`NodeConfig::reply_reader_wait_s`].
    pub reply_reader_wait_s: Option<f64>,
    /// `enhanced`, `cyclone` or `basic`.
    pub service_mapping: Option<String>,
}

#[derive(Deserialize)]
struct NodeSection {
    #[serde(rename = "ros__parameters")]
    ros_parameters: Option<serde_norway::Value>,
}

impl NodeConfig {
    /// The fully qualified node name, e.g. `/fs020n`.
    pub fn fully_qualified_name(&self) -> String {
        if self.namespace == "/" {
            format!("/{}", self.node_name)
        } else {
            format!("{}/{}", self.namespace, self.node_name)
        }
    }

    /// The action's name: `<action_namespace>/follow_joint_trajectory`.
    pub fn action_name(&self) -> String {
        format!(
            "{}/follow_joint_trajectory",
            self.action_namespace.trim_end_matches('/')
        )
    }

    /// Reads the parameters of this node from a ROS 2 parameter file (YAML) and applies them.
    /// The file's top-level keys are node names (`fs020n`, `/fs020n`, the fully qualified
    /// name) or the wildcard `/**`, each holding `ros__parameters`; sections for other nodes
    /// are ignored, a wildcard applies first.
    pub fn apply_params_file(&mut self, path: &Path) -> Result<(), Ros2Error> {
        let text = std::fs::read_to_string(path).map_err(|e| Ros2Error::ParamsFile {
            path: path.display().to_string(),
            message: e.to_string(),
        })?;
        self.apply_params_yaml(&text).map_err(|e| match e {
            Ros2Error::ParamsFile { message, .. } => Ros2Error::ParamsFile {
                path: path.display().to_string(),
                message,
            },
            other => other,
        })
    }

    /// [`apply_params_file`](Self::apply_params_file) on YAML text.
    pub fn apply_params_yaml(&mut self, text: &str) -> Result<(), Ros2Error> {
        let bad = |message: String| Ros2Error::ParamsFile {
            path: "<yaml>".into(),
            message,
        };
        let doc: std::collections::BTreeMap<String, NodeSection> = serde_norway::from_str(text)
            .map_err(|e| {
                bad(format!(
                    "{e}; expected `{}: {{ros__parameters: {{joint_names: [...], ...}}}}`",
                    self.node_name
                ))
            })?;
        let names = [
            "/**".to_owned(),
            self.node_name.clone(),
            format!("/{}", self.node_name),
            self.fully_qualified_name(),
        ];
        let mut found = false;
        for (i, key) in names.iter().enumerate() {
            if i > 0 && names[..i].contains(key) {
                continue;
            }
            let Some(section) = doc.get(key) else {
                continue;
            };
            found = true;
            let Some(value) = &section.ros_parameters else {
                continue;
            };
            let params: Params = serde_norway::from_value(value.clone())
                .map_err(|e| bad(format!("{key}: ros__parameters: {e}")))?;
            self.apply_params(&params)?;
        }
        if !found {
            return Err(bad(format!(
                "no section for this node: give `{}:` (or `/**:`) with `ros__parameters:` under it",
                self.node_name
            )));
        }
        Ok(())
    }

    /// Applies parameters (then call [`validate`](Self::validate)).
    pub fn apply_params(&mut self, p: &Params) -> Result<(), Ros2Error> {
        if let Some(names) = &p.joint_names {
            let arr: [String; JOINT_COUNT] = names.clone().try_into().map_err(|v: Vec<_>| {
                Ros2Error::Config(format!(
                    "joint_names has {} names; give exactly {JOINT_COUNT} (JT1 first)",
                    v.len()
                ))
            })?;
            self.joint_names = arr;
        }
        macro_rules! set {
            ($field:ident, $target:expr) => {
                if let Some(v) = p.$field {
                    $target = v;
                }
            };
        }
        set!(joint_state_rate_hz, self.joint_state_rate_hz);
        set!(diagnostics_rate_hz, self.diagnostics_rate_hz);
        set!(feedback_rate_hz, self.feedback_rate_hz);
        set!(start_tolerance_rad, self.execution.start_tolerance_rad);
        set!(goal_tolerance_rad, self.execution.goal_tolerance_rad);
        set!(path_tolerance_rad, self.execution.path_tolerance_rad);
        set!(auto_start, self.execution.auto_start);
        set!(result_retention_s, self.result_retention_s);
        set!(reply_reader_wait_s, self.reply_reader_wait_s);
        set!(max_step_deg, self.execution.stream.max_step_deg);
        if let Some(ns) = &p.action_namespace {
            self.action_namespace = ns.clone();
        }
        if let Some(s) = p.speed_percent {
            self.speed_percent = (s != 0.0).then_some(s);
        }
        if let Some(mode) = &p.execution_mode {
            self.execution.stream.mode = match mode.to_ascii_lowercase().as_str() {
                "stream" => StreamMode::Extrapolated {
                    lookahead_passes: lookahead(&self.execution.stream).unwrap_or(2.0),
                },
                "waypoints" => StreamMode::Waypoints,
                other => {
                    return Err(Ros2Error::Config(format!(
                        "execution_mode {other:?}: give stream (command 7) or waypoints (command 6)"
                    )))
                }
            };
        }
        if let Some(l) = p.lookahead_passes {
            if let StreamMode::Extrapolated { lookahead_passes } = &mut self.execution.stream.mode {
                *lookahead_passes = l;
            }
        }
        if let Some(s) = p.stream_period_s {
            self.execution.stream.period = secs("stream_period_s", s)?;
            // Keep the underrun bound at its default ratio to the period, within 500 ms.
            self.execution.stream.max_gap = (self.execution.stream.period * 12)
                .clamp(Duration::from_millis(40), Duration::from_millis(500))
                .max(self.execution.stream.period * 2);
        }
        if let Some(s) = p.goal_time_tolerance_s {
            self.execution.goal_time_tolerance = secs("goal_time_tolerance_s", s)?;
        }
        if let Some(m) = &p.service_mapping {
            self.dds.service_mapping = ServiceMapping::parse(m)?;
        }
        Ok(())
    }

    /// Checks every value; the error names the setting and its range.
    pub fn validate(&self) -> Result<(), Ros2Error> {
        let bad = |m: String| Err(Ros2Error::Config(m));
        check_name_token("node name", &self.node_name)?;
        check_namespace("namespace", &self.namespace)?;
        check_namespace("action_namespace", &self.action_namespace)?;
        if self.action_namespace == "/" {
            return bad(
                "action_namespace must name the controller, e.g. /fs020n_controller".into(),
            );
        }
        for (i, n) in self.joint_names.iter().enumerate() {
            if n.is_empty() || n.chars().any(|c| c.is_whitespace() || c.is_control()) {
                return bad(format!(
                    "joint name {} ({n:?}) must be non-empty without blanks",
                    i + 1
                ));
            }
            if self.joint_names[..i].contains(n) {
                return bad(format!(
                    "joint name {n:?} is given twice; names must differ"
                ));
            }
        }
        for (name, v, lo, hi) in [
            ("joint_state_rate_hz", self.joint_state_rate_hz, 1.0, 1000.0),
            ("diagnostics_rate_hz", self.diagnostics_rate_hz, 0.1, 100.0),
            ("feedback_rate_hz", self.feedback_rate_hz, 1.0, 1000.0),
            ("result_retention_s", self.result_retention_s, 1.0, 86_400.0),
            ("reply_reader_wait_s", self.reply_reader_wait_s, 0.0, 600.0),
        ] {
            if !(v.is_finite() && (lo..=hi).contains(&v)) {
                return bad(format!("{name} {v} must be from {lo} to {hi}"));
            }
        }
        if let Some(s) = self.speed_percent {
            if !(s.is_finite() && (1.0..=100.0).contains(&s)) {
                return bad(format!(
                    "speed_percent {s} must be from 1 to 100 (0: leave it)"
                ));
            }
        }
        let e = &self.execution;
        for (name, v) in [
            ("start_tolerance_rad", e.start_tolerance_rad),
            ("goal_tolerance_rad", e.goal_tolerance_rad),
        ] {
            if !(v.is_finite() && v > 0.0 && v <= 1.0) {
                return bad(format!("{name} {v} must be above 0 and at most 1 rad"));
            }
        }
        if !(e.path_tolerance_rad.is_finite() && e.path_tolerance_rad >= 0.0) {
            return bad(format!(
                "path_tolerance_rad {} must be 0 (unchecked) or above",
                e.path_tolerance_rad
            ));
        }
        let s = &e.stream;
        let period = s.period.as_secs_f64();
        if !(0.001..=1.0).contains(&period) {
            return bad(format!("stream_period_s {period} must be from 0.001 to 1"));
        }
        if !(s.max_step_deg.is_finite() && s.max_step_deg > 0.0) {
            return bad(format!("max_step_deg {} must be above 0", s.max_step_deg));
        }
        if let Some(l) = lookahead(s) {
            if !(l.is_finite() && (0.0..=fs020n_client::MAX_LOOKAHEAD_PASSES).contains(&l)) {
                return bad(format!(
                    "lookahead_passes {l} must be from 0 to {}",
                    fs020n_client::MAX_LOOKAHEAD_PASSES
                ));
            }
        }
        if e.goal_time_tolerance > Duration::from_secs(3600) {
            return bad("goal_time_tolerance_s must be at most 3600".into());
        }
        if self.dds.domain_id > MAX_DOMAIN_ID {
            return bad(format!(
                "ROS domain id {} must be at most {MAX_DOMAIN_ID}",
                self.dds.domain_id
            ));
        }
        Ok(())
    }
}

fn lookahead(s: &StreamOptions) -> Option<f64> {
    match s.mode {
        StreamMode::Extrapolated { lookahead_passes } => Some(lookahead_passes),
        StreamMode::Waypoints => None,
    }
}

fn secs(name: &str, s: f64) -> Result<Duration, Ros2Error> {
    if (0.0..=86_400.0).contains(&s) {
        Ok(Duration::from_secs_f64(s))
    } else {
        Err(Ros2Error::Config(format!(
            "{name} {s} must be a number of seconds from 0 to 86400"
        )))
    }
}

/// A ROS name token: letters, digits and `_`, not starting with a digit, no `__`.
fn check_name_token(what: &str, s: &str) -> Result<(), Ros2Error> {
    let ok = !s.is_empty()
        && s.chars().all(|c| c.is_ascii_alphanumeric() || c == '_')
        && !s.starts_with(|c: char| c.is_ascii_digit())
        && !s.contains("__");
    if ok {
        Ok(())
    } else {
        Err(Ros2Error::Config(format!(
            "{what} {s:?} must be letters, digits and single underscores, not starting with a digit"
        )))
    }
}

/// An absolute ROS namespace: `/` or `/a/b` with name tokens.
fn check_namespace(what: &str, s: &str) -> Result<(), Ros2Error> {
    if s == "/" {
        return Ok(());
    }
    let Some(rest) = s.strip_prefix('/') else {
        return Err(Ros2Error::Config(format!(
            "{what} {s:?} must start with / (e.g. /fs020n_controller)"
        )));
    };
    for token in rest.split('/') {
        check_name_token(what, token)?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn defaults_are_valid_and_name_the_moveit_action() {
        let c = NodeConfig::default();
        c.validate().unwrap();
        assert_eq!(
            c.action_name(),
            "/fs020n_controller/follow_joint_trajectory"
        );
        assert_eq!(c.fully_qualified_name(), "/fs020n");
        assert_eq!(c.joint_names[5], "joint_6");
    }

    #[test]
    fn a_ros_parameter_file_sets_names_rates_and_the_action_namespace() {
        let mut c = NodeConfig::default();
        c.apply_params_yaml(
            "/**:\n  ros__parameters:\n    joint_state_rate_hz: 60.0\n\
             fs020n:\n  ros__parameters:\n    joint_names: [a1, a2, a3, a4, a5, a6]\n    \
             action_namespace: /arm_controller\n    execution_mode: waypoints\n    \
             service_mapping: cyclone\n    speed_percent: 0\n\
             other_node:\n  ros__parameters:\n    bogus: 1\n",
        )
        .unwrap();
        c.validate().unwrap();
        assert_eq!(c.joint_state_rate_hz, 60.0);
        assert_eq!(c.joint_names[0], "a1");
        assert_eq!(c.action_name(), "/arm_controller/follow_joint_trajectory");
        assert_eq!(c.execution.stream.mode, StreamMode::Waypoints);
        assert_eq!(c.dds.service_mapping, ServiceMapping::Cyclone);
        assert_eq!(c.speed_percent, None);
    }

    #[test]
    fn bad_parameters_are_refused_with_the_setting_named() {
        let mut c = NodeConfig::default();
        let e = c
            .apply_params_yaml("fs020n:\n  ros__parameters:\n    joint_rate: 5\n")
            .unwrap_err()
            .to_string();
        assert!(e.contains("joint_rate"), "{e}");
        let e = c
            .apply_params_yaml("fs020n:\n  ros__parameters:\n    joint_names: [a, b]\n")
            .unwrap_err()
            .to_string();
        assert!(e.contains("exactly 6"), "{e}");
        let e = c
            .apply_params_yaml("robot:\n  ros__parameters: {}\n")
            .unwrap_err()
            .to_string();
        assert!(e.contains("no section"), "{e}");
        let mut c = NodeConfig {
            joint_state_rate_hz: 0.0,
            ..NodeConfig::default()
        };
        assert!(c
            .validate()
            .unwrap_err()
            .to_string()
            .contains("joint_state_rate_hz"));
        c.joint_state_rate_hz = 100.0;
        c.joint_names[3] = "joint_1".into();
        assert!(c.validate().unwrap_err().to_string().contains("twice"));
        c.joint_names[3] = "joint_4".into();
        c.action_namespace = "fs020n_controller".into();
        assert!(c
            .validate()
            .unwrap_err()
            .to_string()
            .contains("start with /"));
    }

    #[test]
    fn the_reply_readers_wait_is_a_parameter_from_0_to_600_s() {
        let mut c = NodeConfig::default();
        assert_eq!(c.reply_reader_wait_s, 5.0);
        c.apply_params_yaml("fs020n:\n  ros__parameters:\n    reply_reader_wait_s: 0.0\n")
            .unwrap();
        c.validate().unwrap();
        assert_eq!(c.reply_reader_wait_s, 0.0);
        c.apply_params_yaml("fs020n:\n  ros__parameters:\n    reply_reader_wait_s: 601.0\n")
            .unwrap();
        let e = c.validate().unwrap_err().to_string();
        assert!(
            e.contains("reply_reader_wait_s") && e.contains("600"),
            "{e}"
        );
    }

    #[test]
    fn domains_above_232_are_refused() {
        assert_eq!(parse_domain("17").unwrap(), 17);
        assert!(parse_domain("233").is_err());
        assert!(parse_domain("-1").is_err());
    }
}
