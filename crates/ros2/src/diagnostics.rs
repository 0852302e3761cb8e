//! The robot's state as a `diagnostic_msgs/DiagnosticStatus`: switches, error with its remedy,
//! program, link, and the last goal.

use std::time::Duration;

use fs020n_client::{blockers, Blocker, StatusSnapshot};

use crate::msg::{DiagnosticStatus, KeyValue};

/// A status older than this is reported STALE.
pub const STALE_AFTER: Duration = Duration::from_secs(1);

/// What the node adds to the robot's status.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct NodeState {
    /// Why the session ended, if it did.
    pub link_error: Option<String>,
    /// The goal being executed, or the last one and how it ended.
    pub last_goal: Option<String>,
    /// The last event of the servo of `~/commands` (opened, ended and why).
    pub last_command: Option<String>,
    /// The last command of `~/commands` refused, and why.
    pub last_command_refused: Option<String>,
    /// The monitor speed this node last set, percent.
    pub speed_percent: Option<f64>,
}

fn kv(key: &str, value: impl Into<String>) -> KeyValue {
    KeyValue {
        key: key.into(),
        value: value.into(),
    }
}

fn on_off(b: bool) -> &'static str {
    if b {
        "ON"
    } else {
        "OFF"
    }
}

/// The diagnostic status of the robot `name`d (e.g. `fs020n: /fs020n`) from its latest status.
pub fn robot_status(
    name: &str,
    hardware_id: &str,
    snapshot: Option<&StatusSnapshot>,
    node: &NodeState,
) -> DiagnosticStatus {
    let mut d = DiagnosticStatus {
        name: name.into(),
        hardware_id: hardware_id.into(),
        ..Default::default()
    };
    if let Some(e) = &node.link_error {
        d.level = DiagnosticStatus::ERROR;
        d.message = format!("no session with the robot: {e}");
        d.values.push(kv("link", "lost"));
        d.values.push(kv(
            "remedy",
            "restart the node (it never reconnects or resumes by itself)",
        ));
        push_node(&mut d, node);
        return d;
    }
    let Some(s) = snapshot else {
        d.level = DiagnosticStatus::STALE;
        d.message = "no status from the robot yet".into();
        push_node(&mut d, node);
        return d;
    };
    let st = &s.status;
    let list = blockers(st, true);
    let (level, message) = if !st.error.is_none() {
        (
            DiagnosticStatus::ERROR,
            list.first().map(Blocker::to_string).unwrap_or_default(),
        )
    } else if list.is_empty() {
        (
            DiagnosticStatus::OK,
            "ready: program running, no error".to_owned(),
        )
    } else {
        (
            DiagnosticStatus::WARN,
            format!(
                "not ready to move: {}",
                list.iter()
                    .map(Blocker::condition)
                    .collect::<Vec<_>>()
                    .join("; ")
            ),
        )
    };
    d.level = if s.age() > STALE_AFTER {
        DiagnosticStatus::STALE
    } else {
        level
    };
    d.message = if d.level == DiagnosticStatus::STALE {
        format!("status {:.1} s old; {message}", s.age().as_secs_f64())
    } else {
        message
    };
    d.values.push(kv("link", "connected"));
    d.values.push(kv(
        "teach_repeat",
        if st.repeat { "REPEAT" } else { "TEACH" },
    ));
    d.values
        .push(kv("run_hold", if st.run { "RUN" } else { "HOLD" }));
    d.values.push(kv("teach_lock", on_off(st.teach_lock)));
    d.values.push(kv("motor_power", on_off(st.power)));
    d.values.push(kv(
        "program",
        if st.task_running {
            "running"
        } else {
            "not running"
        },
    ));
    d.values.push(kv(
        "error",
        if st.error.is_none() {
            "none".to_owned()
        } else {
            match st.error.message() {
                Some(m) => format!("{} ({m})", st.error),
                None => st.error.to_string(),
            }
        },
    ));
    let remedies: Vec<String> = list.iter().map(Blocker::remedy).collect();
    d.values.push(kv(
        "remedy",
        if remedies.is_empty() {
            "none needed".to_owned()
        } else {
            remedies.join("; ")
        },
    ));
    d.values.push(kv(
        "timer_s",
        st.timer
            .seconds()
            .map_or("overflow".to_owned(), |t| format!("{t:.3}")),
    ));
    d.values.push(kv(
        "joints_deg",
        st.joints
            .iter()
            .map(|v| format!("{v:.3}"))
            .collect::<Vec<_>>()
            .join(" "),
    ));
    d.values.push(kv(
        "round_trip_ms",
        format!("{:.2}", s.rtt.as_secs_f64() * 1e3),
    ));
    push_node(&mut d, node);
    d
}

fn push_node(d: &mut DiagnosticStatus, node: &NodeState) {
    if let Some(s) = node.speed_percent {
        d.values.push(kv("speed_percent", format!("{s}")));
    }
    d.values.push(kv(
        "last_goal",
        node.last_goal.clone().unwrap_or_else(|| "none".into()),
    ));
    d.values.push(kv(
        "last_command",
        node.last_command.clone().unwrap_or_else(|| "none".into()),
    ));
    d.values.push(kv(
        "last_command_refused",
        node.last_command_refused
            .clone()
            .unwrap_or_else(|| "none".into()),
    ));
}

#[cfg(test)]
mod tests {
    use super::*;
    use fs020n_proto::{ErrorCode, JointsDeg, Status, Timer};
    use tokio::time::Instant;

    fn snapshot(status: Status) -> StatusSnapshot {
        StatusSnapshot {
            status,
            received_at: Instant::now(),
            rtt: Duration::from_millis(2),
            seq: 1,
        }
    }

    fn ready() -> Status {
        Status {
            version: 1040,
            error: ErrorCode::NONE,
            run: true,
            repeat: true,
            teach_lock: false,
            power: true,
            task_running: true,
            timer: Timer::Seconds(1.5),
            joints: JointsDeg::ZERO,
        }
    }

    fn value<'a>(d: &'a DiagnosticStatus, key: &str) -> &'a str {
        &d.values.iter().find(|kv| kv.key == key).expect(key).value
    }

    #[tokio::test]
    async fn a_ready_robot_is_ok() {
        let d = robot_status(
            "fs020n",
            "x",
            Some(&snapshot(ready())),
            &NodeState::default(),
        );
        assert_eq!(d.level, DiagnosticStatus::OK);
        assert_eq!(value(&d, "program"), "running");
        assert_eq!(value(&d, "remedy"), "none needed");
    }

    #[tokio::test]
    async fn an_estop_is_an_error_with_its_remedy() {
        let mut s = ready();
        s.error = ErrorCode::EMERGENCY_STOP;
        s.power = false;
        let d = robot_status("fs020n", "x", Some(&snapshot(s)), &NodeState::default());
        assert_eq!(d.level, DiagnosticStatus::ERROR);
        assert!(value(&d, "error").contains("E3808"), "{d:?}");
        assert!(
            value(&d, "remedy").contains(fs020n_client::ESTOP_REMEDY),
            "{d:?}"
        );
        assert_eq!(value(&d, "motor_power"), "OFF");
    }

    #[tokio::test]
    async fn teach_is_a_warning_naming_the_switch() {
        let mut s = ready();
        s.repeat = false;
        let d = robot_status("fs020n", "x", Some(&snapshot(s)), &NodeState::default());
        assert_eq!(d.level, DiagnosticStatus::WARN);
        assert!(d.message.contains("TEACH"), "{}", d.message);
        assert!(value(&d, "remedy").contains("REPEAT"));
    }

    #[tokio::test]
    async fn a_lost_link_is_an_error() {
        let node = NodeState {
            link_error: Some("the controller closed the connection".into()),
            ..Default::default()
        };
        let d = robot_status("fs020n", "x", None, &node);
        assert_eq!(d.level, DiagnosticStatus::ERROR);
        assert!(d.message.contains("closed"));
    }
}
