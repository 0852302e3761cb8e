//! Client configuration.

use std::path::PathBuf;
use std::time::Duration;

use fs020n_kin::RobotModel;
use fs020n_proto::session::{RECEIVE_TIMEOUT, SEND_TIMEOUT};

use crate::error::ClientError;

/// File format of a [`Recording`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum RecordFormat {
    /// Comma-separated values with a header line:
    /// `t_s,session,dir,kind,rtt_ms,text`.
    #[default]
    Csv,
    /// One JSON object per line: `{"t_s":…,"session":…,"dir":…,"kind":…,"rtt_ms":…,"text":…}`.
    JsonLines,
}

/// Record every request and reply to a file (see `docs/CLIENT.md`, "Recording").
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Recording {
    /// The file (created or truncated).
    pub path: PathBuf,
    /// Its format.
    pub format: RecordFormat,
}

/// Settings of a [`Robot`](crate::Robot). `ClientConfig::default()` suits a real FS020N.
#[derive(Debug, Clone)]
pub struct ClientConfig {
    /// Overall time to keep retrying `connect` (the server listens in 3 s windows with short
    /// gaps, and refuses while another client holds the session). Default 10 s.
    pub connect_timeout: Duration,
    /// Pause between connection attempts. Default 50 ms.
    pub connect_retry_interval: Duration,
    /// Deadline for each reply, from the moment the request is written. Must stay below the
    /// server's 2 s send timeout. Default 1 s.
    pub reply_timeout: Duration,
    /// Deadline for writing a request. Default 1 s.
    pub write_timeout: Duration,
    /// Period of the keep-alive status polls (`0 0 0`) while no other request is made. Must be
    /// well below the server's 5 s receive timeout. Default 100 ms (10 Hz).
    pub keepalive_period: Duration,
    /// A reply slower than this counts as late in [`Stats`](crate::Stats). Default 100 ms.
    pub late_reply_after: Duration,
    /// How long [`Robot::start`](crate::Robot::start) waits for reply field 7 to become −1.
    /// Default 2 s.
    pub start_timeout: Duration,
    /// How long [`Robot::close`](crate::Robot::close) waits for the server to close the
    /// connection after 255. Default 2 s.
    pub close_timeout: Duration,
    /// Monitor speed assumed for move timeouts until [`Robot::set_speed`](crate::Robot::set_speed)
    /// is called (the controller's power-on default is 10 %). Default 10 %.
    pub assumed_speed_percent: f64,
    /// The robot model: joint ranges for the checks, speeds for move timeouts, kinematics for
    /// pose moves. Default: the embedded FS020N model.
    pub model: RobotModel,
    /// Record every request and reply. Default: off.
    pub record: Option<Recording>,
}

impl Default for ClientConfig {
    fn default() -> Self {
        ClientConfig {
            connect_timeout: Duration::from_secs(10),
            connect_retry_interval: Duration::from_millis(50),
            reply_timeout: Duration::from_secs(1),
            write_timeout: Duration::from_secs(1),
            keepalive_period: Duration::from_millis(100),
            late_reply_after: Duration::from_millis(100),
            start_timeout: Duration::from_secs(2),
            close_timeout: Duration::from_secs(2),
            assumed_speed_percent: 10.0,
            model: RobotModel::fs020n(),
            record: None,
        }
    }
}

impl ClientConfig {
    /// Checks the values against the protocol's timing rules.
    pub fn validate(&self) -> Result<(), ClientError> {
        let bad = |m: String| Err(ClientError::Config(m));
        if self.reply_timeout.is_zero() || self.reply_timeout >= SEND_TIMEOUT {
            return bad(format!(
                "reply_timeout {:?} must be above 0 and below the server's {:?} send timeout",
                self.reply_timeout, SEND_TIMEOUT
            ));
        }
        if self.write_timeout.is_zero() {
            return bad("write_timeout must be above 0".into());
        }
        if self.keepalive_period.is_zero() || self.keepalive_period * 2 > RECEIVE_TIMEOUT {
            return bad(format!(
                "keepalive_period {:?} must be above 0 and at most half the server's {:?} receive timeout",
                self.keepalive_period, RECEIVE_TIMEOUT
            ));
        }
        if self.connect_retry_interval.is_zero() {
            return bad("connect_retry_interval must be above 0".into());
        }
        if !(self.assumed_speed_percent.is_finite()
            && (1.0..=100.0).contains(&self.assumed_speed_percent))
        {
            return bad(format!(
                "assumed_speed_percent {} must be from 1 to 100",
                self.assumed_speed_percent
            ));
        }
        Ok(())
    }
}
