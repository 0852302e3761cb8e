//! Client configuration.

use std::path::PathBuf;
use std::time::Duration;

use fs020n_kin::RobotModel;
use fs020n_proto::{RECEIVE_TIMEOUT, SEND_TIMEOUT};

use crate::error::ClientError;

/// File format of a [`Recording`] (`docs/RECORDING.md`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum RecordFormat {
    /// Comma-separated values with a header line:
    /// `t_s,session,dir,kind,rtt_ms,text`.
    #[default]
    Csv,
    /// One JSON object per line: `{"t_s":…,"session":…,"dir":…,"kind":…,"rtt_ms":…,"text":…}`.
    JsonLines,
    /// MCAP (zstd-compressed chunks) with ROS 2 `sensor_msgs/msg/JointState` topics and JSON
    /// status, exchange and event topics ([`record_format`](crate::record_format)): opens in
    /// Foxglove, PlotJuggler and `ros2 bag`. Needs the `mcap` feature (on by default).
    Mcap,
}

impl RecordFormat {
    /// The format a file name asks for: `.mcap` → MCAP, `.jsonl` / `.ndjson` → JSON lines,
    /// `.csv` → CSV; `None` for anything else.
    ///
    /// ```
    /// use fs020n_client::RecordFormat;
    /// assert_eq!(RecordFormat::from_path("run.MCAP".as_ref()), Some(RecordFormat::Mcap));
    /// assert_eq!(RecordFormat::from_path("run.jsonl".as_ref()), Some(RecordFormat::JsonLines));
    /// assert_eq!(RecordFormat::from_path("run.txt".as_ref()), None);
    /// ```
    pub fn from_path(path: &std::path::Path) -> Option<RecordFormat> {
        let ext = path.extension()?.to_str()?.to_ascii_lowercase();
        match ext.as_str() {
            "mcap" => Some(RecordFormat::Mcap),
            "jsonl" | "ndjson" => Some(RecordFormat::JsonLines),
            "csv" => Some(RecordFormat::Csv),
            _ => None,
        }
    }
}

/// Record every request and reply to a file (`docs/RECORDING.md`). The file is written by a
/// thread of its own: a slow disk never delays a request or a reply deadline.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Recording {
    /// The file (created or truncated).
    pub path: PathBuf,
    /// Its format.
    pub format: RecordFormat,
}

impl Recording {
    /// A recording in the format the file name asks for ([`RecordFormat::from_path`]), CSV
    /// when the extension says nothing.
    pub fn new(path: impl Into<PathBuf>) -> Recording {
        let path = path.into();
        let format = RecordFormat::from_path(&path).unwrap_or_default();
        Recording { path, format }
    }
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
