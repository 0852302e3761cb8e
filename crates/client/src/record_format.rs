//! What an MCAP recording contains: topics, schemas and message types, shared by the writer
//! (this crate, [`RecordFormat::Mcap`](crate::RecordFormat::Mcap)) and readers (`fs020n-record`).
//!
//! | topic | schema (encoding) | message | time stamp |
//! |---|---|---|---|
//! | [`TOPIC_JOINT_STATES`] | `sensor_msgs/msg/JointState` (`ros2msg`, CDR) | measured joints, radians | PC receive time of the reply |
//! | [`TOPIC_COMMANDED`] | `sensor_msgs/msg/JointState` (`ros2msg`, CDR) | command 6 target / command 7 sample position (and velocity), radians | PC send time of the request |
//! | [`TOPIC_STATUS`] | `fs020n/Status` (`jsonschema`, JSON) | [`StatusMessage`]: switches, error, program, timer | PC receive time |
//! | [`TOPIC_EXCHANGE`] | `fs020n/Exchange` (`jsonschema`, JSON) | [`ExchangeMessage`]: request, reply, round trip | PC receive time (send time without a reply) |
//! | [`TOPIC_EVENT`] | `fs020n/Event` (`jsonschema`, JSON) | [`EventMessage`]: start, connect, end | when it happened |
//!
//! Log time and publish time of every message are nanoseconds since the UNIX epoch, on the PC's
//! clock. A metadata record named [`METADATA_NAME`] holds the start time, the client version and
//! the late-reply threshold.

use serde::{Deserialize, Serialize};
use thiserror::Error;

/// Measured joints (`sensor_msgs/msg/JointState`, CDR).
pub const TOPIC_JOINT_STATES: &str = "/joint_states";
/// Commanded joints (`sensor_msgs/msg/JointState`, CDR): the target of command 6, the position
/// (and velocity) of a command-7 sample.
pub const TOPIC_COMMANDED: &str = "/fs020n/commanded";
/// Status fields of every reply ([`StatusMessage`], JSON).
pub const TOPIC_STATUS: &str = "/fs020n/status";
/// Every request with its reply and round trip ([`ExchangeMessage`], JSON).
pub const TOPIC_EXCHANGE: &str = "/fs020n/exchange";
/// Start of the recording, connections and session ends ([`EventMessage`], JSON).
pub const TOPIC_EVENT: &str = "/fs020n/event";
/// Name of the metadata record ([`RecordingInfo`] as string pairs).
pub const METADATA_NAME: &str = "fs020n";

/// Joint names in `JointState` messages (the ROS convention for a six-axis arm's URDF).
pub const JOINT_NAMES: [&str; 6] = [
    "joint_1", "joint_2", "joint_3", "joint_4", "joint_5", "joint_6",
];

/// Schema name of the joint topics.
pub const JOINT_STATE_SCHEMA: &str = "sensor_msgs/msg/JointState";

/// The `ros2msg` schema of `sensor_msgs/msg/JointState` with its dependencies, in the layout
/// rosbag2 writes (each dependency after a line of `=` and `MSG: package/Name`).
pub const JOINT_STATE_MSG_DEF: &str = "\
std_msgs/Header header

string[] name
float64[] position
float64[] velocity
float64[] effort

================================================================================
MSG: std_msgs/Header
builtin_interfaces/Time stamp
string frame_id

================================================================================
MSG: builtin_interfaces/Time
int32 sec
uint32 nanosec
";

/// Schema name of [`TOPIC_STATUS`].
pub const STATUS_SCHEMA: &str = "fs020n/Status";
/// Schema name of [`TOPIC_EXCHANGE`].
pub const EXCHANGE_SCHEMA: &str = "fs020n/Exchange";
/// Schema name of [`TOPIC_EVENT`].
pub const EVENT_SCHEMA: &str = "fs020n/Event";

/// JSON Schema of [`StatusMessage`].
pub const STATUS_JSON_SCHEMA: &str = r#"{
  "title": "fs020n/Status",
  "description": "The status fields of one reply of the controller (protocol 1040)",
  "type": "object",
  "properties": {
    "session": {"type": "integer", "description": "Session number in this recording (1 = first connection)"},
    "error_code": {"type": "integer", "description": "Reply field 2: the AS error number (0 = none, -31088 = E1088)"},
    "error": {"type": "string", "description": "The error as the pendant shows it (E1088), empty without one"},
    "run": {"type": "boolean", "description": "RUN/HOLD switch on RUN"},
    "repeat": {"type": "boolean", "description": "TEACH/REPEAT switch on REPEAT"},
    "teach_lock": {"type": "boolean", "description": "TEACH LOCK on"},
    "power": {"type": "boolean", "description": "Motor power on"},
    "program_running": {"type": "boolean", "description": "Reply field 7: the motion program runs"},
    "timer_s": {"type": ["number", "null"], "description": "Reply field 8: controller TIMER(1), seconds since the connection was accepted (null on overflow)"}
  },
  "required": ["session", "error_code", "error", "run", "repeat", "teach_lock", "power", "program_running", "timer_s"]
}"#;

/// JSON Schema of [`ExchangeMessage`].
pub const EXCHANGE_JSON_SCHEMA: &str = r#"{
  "title": "fs020n/Exchange",
  "description": "One request of the PC and the controller's reply (protocol 1040)",
  "type": "object",
  "properties": {
    "session": {"type": "integer"},
    "kind": {"type": "string", "description": "poll, keepalive, command, motion, raw or close"},
    "request": {"type": "string", "description": "The request bytes as sent"},
    "reply": {"type": ["string", "null"], "description": "The reply bytes as received (null: no reply, the link was lost)"},
    "sent": {"type": "object", "description": "PC time the request was written", "properties": {"sec": {"type": "integer"}, "nsec": {"type": "integer"}}},
    "rtt_ms": {"type": ["number", "null"], "description": "Round trip, milliseconds"}
  },
  "required": ["session", "kind", "request", "reply", "sent", "rtt_ms"]
}"#;

/// JSON Schema of [`EventMessage`].
pub const EVENT_JSON_SCHEMA: &str = r#"{
  "title": "fs020n/Event",
  "description": "Start of a recording, a connection, the end of a session",
  "type": "object",
  "properties": {
    "session": {"type": "integer", "description": "0 for the start of the recording"},
    "event": {"type": "string", "description": "start, connect or end"},
    "text": {"type": "string", "description": "start: the recording info as JSON; connect: the address; end: the cause"}
  },
  "required": ["session", "event", "text"]
}"#;

/// A time as ROS and Foxglove write it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
pub struct Stamp {
    /// Seconds since the UNIX epoch.
    pub sec: u64,
    /// Nanoseconds within the second.
    pub nsec: u32,
}

impl Stamp {
    /// From nanoseconds since the UNIX epoch.
    pub fn from_nanos(ns: u64) -> Stamp {
        Stamp {
            sec: ns / 1_000_000_000,
            nsec: (ns % 1_000_000_000) as u32,
        }
    }

    /// Nanoseconds since the UNIX epoch.
    pub fn nanos(self) -> u64 {
        self.sec
            .saturating_mul(1_000_000_000)
            .saturating_add(u64::from(self.nsec))
    }
}

/// A message of [`TOPIC_STATUS`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct StatusMessage {
    /// Session number in this recording (1 = the first connection).
    pub session: u64,
    /// Reply field 2: the AS error number (0 = none).
    pub error_code: i32,
    /// The error as the pendant shows it (`E1088`), empty without one.
    pub error: String,
    /// RUN/HOLD on RUN.
    pub run: bool,
    /// TEACH/REPEAT on REPEAT.
    pub repeat: bool,
    /// TEACH LOCK on.
    pub teach_lock: bool,
    /// Motor power on.
    pub power: bool,
    /// Reply field 7: the motion program runs.
    pub program_running: bool,
    /// Reply field 8: TIMER(1), seconds (`None` on overflow).
    pub timer_s: Option<f64>,
}

impl StatusMessage {
    /// The status fields of a decoded reply.
    pub fn new(session: u64, s: &fs020n_proto::Status) -> StatusMessage {
        StatusMessage {
            session,
            error_code: s.error.raw(),
            error: if s.error.is_none() {
                String::new()
            } else {
                s.error.to_string()
            },
            run: s.run,
            repeat: s.repeat,
            teach_lock: s.teach_lock,
            power: s.power,
            program_running: s.task_running,
            timer_s: s.timer.seconds(),
        }
    }
}

/// A message of [`TOPIC_EXCHANGE`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ExchangeMessage {
    /// Session number.
    pub session: u64,
    /// `poll`, `keepalive`, `command`, `motion`, `raw` or `close`.
    pub kind: String,
    /// The request bytes as sent.
    pub request: String,
    /// The reply bytes as received; `None` when no reply came (the link was lost).
    pub reply: Option<String>,
    /// PC time the request was written.
    pub sent: Stamp,
    /// Round trip, milliseconds.
    pub rtt_ms: Option<f64>,
}

/// A message of [`TOPIC_EVENT`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct EventMessage {
    /// Session number (0 for `start`).
    pub session: u64,
    /// `start`, `connect` or `end`.
    pub event: String,
    /// `start`: [`RecordingInfo`] as JSON; `connect`: the address; `end`: the cause.
    pub text: String,
}

/// What a recording says about itself: the `start` event (every format) and the MCAP metadata
/// record [`METADATA_NAME`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RecordingInfo {
    /// Start of the recording, UTC, RFC 3339 with milliseconds (`2026-11-22T09:30:00.000Z`).
    pub started_utc: String,
    /// Start of the recording, nanoseconds since the UNIX epoch.
    pub started_unix_ns: u64,
    /// The writer, e.g. `fs020n-client 0.1.0`.
    pub client: String,
    /// Replies slower than this counted as late (`ClientConfig::late_reply_after`), ms.
    pub late_reply_after_ms: f64,
}

impl RecordingInfo {
    /// The info as MCAP metadata (string pairs).
    pub fn to_metadata(&self) -> std::collections::BTreeMap<String, String> {
        [
            ("started_utc", self.started_utc.clone()),
            ("started_unix_ns", self.started_unix_ns.to_string()),
            ("client", self.client.clone()),
            ("late_reply_after_ms", self.late_reply_after_ms.to_string()),
        ]
        .into_iter()
        .map(|(k, v)| (k.to_owned(), v))
        .collect()
    }

    /// Reads the info back from MCAP metadata; `None` when a field is missing or malformed.
    pub fn from_metadata(m: &std::collections::BTreeMap<String, String>) -> Option<RecordingInfo> {
        Some(RecordingInfo {
            started_utc: m.get("started_utc")?.clone(),
            started_unix_ns: m.get("started_unix_ns")?.parse().ok()?,
            client: m.get("client")?.clone(),
            late_reply_after_ms: m.get("late_reply_after_ms")?.parse().ok()?,
        })
    }
}

/// The commanded joints of a request as the controller reads it, degrees: the target of
/// command 6, the position and velocity of a command-7 sample; `None` for anything else.
///
/// ```
/// use fs020n_client::record_format::commanded_joints;
/// let (target, velocity) = commanded_joints("1040 6 9 0 0 0 10 0 -90 0 -90 0").unwrap();
/// assert_eq!(target, [10.0, 0.0, -90.0, 0.0, -90.0, 0.0]);
/// assert!(velocity.is_none());
/// assert!(commanded_joints("0 0 0").is_none());
/// ```
pub fn commanded_joints(request: &str) -> Option<([f64; 6], Option<[f64; 6]>)> {
    let r = fs020n_proto::ServerRequest::parse(request.as_bytes());
    if !r.version_matches() {
        return None;
    }
    match r.command() {
        fs020n_proto::Command::JointMove { target } => Some((target.0, None)),
        fs020n_proto::Command::StreamedMove(s) => Some((s.position.0, Some(s.velocity.0))),
        _ => None,
    }
}

/// Formats nanoseconds since the UNIX epoch as UTC, RFC 3339 with milliseconds.
///
/// ```
/// use fs020n_client::record_format::utc_rfc3339;
/// assert_eq!(utc_rfc3339(0), "1970-01-01T00:00:00.000Z");
/// assert_eq!(utc_rfc3339(1_795_340_245_123_000_000), "2026-11-22T09:37:25.123Z");
/// ```
pub fn utc_rfc3339(unix_ns: u64) -> String {
    let secs = unix_ns / 1_000_000_000;
    let ms = (unix_ns % 1_000_000_000) / 1_000_000;
    let days = (secs / 86_400) as i64;
    let rem = secs % 86_400;
    // Civil date from days since 1970-01-01 (H. Hinnant's algorithm).
    let z = days + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z.rem_euclid(146_097);
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let day = doy - (153 * mp + 2) / 5 + 1;
    let month = if mp < 10 { mp + 3 } else { mp - 9 };
    let year = yoe + era * 400 + i64::from(month <= 2);
    format!(
        "{year:04}-{month:02}-{day:02}T{:02}:{:02}:{:02}.{ms:03}Z",
        rem / 3600,
        rem % 3600 / 60,
        rem % 60
    )
}

/// A `sensor_msgs/msg/JointState` message.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct JointStateMessage {
    /// `header.stamp`, nanoseconds since the UNIX epoch.
    pub stamp_ns: u64,
    /// `header.frame_id` (empty: joint states have no frame).
    pub frame_id: String,
    /// Joint names.
    pub name: Vec<String>,
    /// Positions, radians.
    pub position: Vec<f64>,
    /// Velocities, radians per second (empty when unknown).
    pub velocity: Vec<f64>,
    /// Efforts (empty: the controller does not report them).
    pub effort: Vec<f64>,
}

/// A malformed CDR message.
#[derive(Debug, Clone, PartialEq, Eq, Error)]
pub enum CdrError {
    /// The message ends before a field.
    #[error("CDR message truncated at byte {offset} (reading {field})")]
    Truncated {
        /// Where the missing bytes start.
        offset: usize,
        /// The field being read.
        field: &'static str,
    },
    /// Not little- or big-endian plain CDR.
    #[error("unsupported CDR encapsulation {0:#06x} (expected plain CDR, 0x0000 or 0x0001)")]
    Encapsulation(u16),
    /// A string that is not UTF-8 or lacks its terminating zero.
    #[error("malformed CDR string at byte {0}")]
    String(usize),
}

impl JointStateMessage {
    /// The six joints of the FS020N named [`JOINT_NAMES`], from degrees.
    pub fn from_degrees(
        stamp_ns: u64,
        position_deg: &[f64; 6],
        velocity_deg: Option<&[f64; 6]>,
    ) -> Self {
        JointStateMessage {
            stamp_ns,
            frame_id: String::new(),
            name: JOINT_NAMES.iter().map(|n| (*n).to_owned()).collect(),
            position: position_deg.iter().map(|d| d.to_radians()).collect(),
            velocity: velocity_deg
                .map(|v| v.iter().map(|d| d.to_radians()).collect())
                .unwrap_or_default(),
            effort: Vec::new(),
        }
    }

    /// Encodes as little-endian CDR (encapsulation `00 01 00 00`), the way ROS 2 middlewares
    /// serialize it.
    pub fn encode_cdr(&self) -> Vec<u8> {
        let mut w = CdrWriter::new();
        let sec = (self.stamp_ns / 1_000_000_000).min(i32::MAX as u64) as i32;
        w.u32(sec as u32);
        w.u32((self.stamp_ns % 1_000_000_000) as u32);
        w.string(&self.frame_id);
        w.u32(self.name.len() as u32);
        for n in &self.name {
            w.string(n);
        }
        for seq in [&self.position, &self.velocity, &self.effort] {
            w.u32(seq.len() as u32);
            for v in seq.iter() {
                w.f64(*v);
            }
        }
        w.buf
    }

    /// Decodes plain CDR (little- or big-endian).
    pub fn decode_cdr(bytes: &[u8]) -> Result<JointStateMessage, CdrError> {
        let mut r = CdrReader::new(bytes)?;
        let sec = r.u32("header.stamp.sec")? as i32;
        let nsec = r.u32("header.stamp.nanosec")?;
        let frame_id = r.string("header.frame_id")?;
        let n = r.len("name")?;
        let mut name = Vec::with_capacity(n);
        for _ in 0..n {
            name.push(r.string("name")?);
        }
        let mut seqs: [Vec<f64>; 3] = Default::default();
        for (seq, field) in seqs.iter_mut().zip(["position", "velocity", "effort"]) {
            let n = r.len(field)?;
            seq.reserve(n);
            for _ in 0..n {
                seq.push(r.f64(field)?);
            }
        }
        let [position, velocity, effort] = seqs;
        Ok(JointStateMessage {
            stamp_ns: (i64::from(sec).max(0) as u64) * 1_000_000_000 + u64::from(nsec),
            frame_id,
            name,
            position,
            velocity,
            effort,
        })
    }
}

struct CdrWriter {
    buf: Vec<u8>,
}

impl CdrWriter {
    /// Alignment is counted from the end of the 4-byte encapsulation header.
    const ORIGIN: usize = 4;

    fn new() -> CdrWriter {
        let mut buf = Vec::with_capacity(256);
        buf.extend_from_slice(&[0x00, 0x01, 0x00, 0x00]);
        CdrWriter { buf }
    }

    fn align(&mut self, n: usize) {
        while (self.buf.len() - Self::ORIGIN) % n != 0 {
            self.buf.push(0);
        }
    }

    fn u32(&mut self, v: u32) {
        self.align(4);
        self.buf.extend_from_slice(&v.to_le_bytes());
    }

    fn f64(&mut self, v: f64) {
        self.align(8);
        self.buf.extend_from_slice(&v.to_le_bytes());
    }

    fn string(&mut self, s: &str) {
        self.u32(s.len() as u32 + 1);
        self.buf.extend_from_slice(s.as_bytes());
        self.buf.push(0);
    }
}

struct CdrReader<'a> {
    data: &'a [u8],
    pos: usize,
    little: bool,
}

impl<'a> CdrReader<'a> {
    fn new(data: &'a [u8]) -> Result<CdrReader<'a>, CdrError> {
        if data.len() < 4 {
            return Err(CdrError::Truncated {
                offset: data.len(),
                field: "encapsulation header",
            });
        }
        let kind = u16::from_be_bytes([data[0], data[1]]);
        let little = match kind {
            0x0000 => false,
            0x0001 => true,
            other => return Err(CdrError::Encapsulation(other)),
        };
        Ok(CdrReader {
            data,
            pos: 4,
            little,
        })
    }

    fn take(&mut self, n: usize, align: usize, field: &'static str) -> Result<&'a [u8], CdrError> {
        while (self.pos - 4) % align != 0 {
            self.pos += 1;
        }
        let end = self.pos.checked_add(n).filter(|&e| e <= self.data.len());
        match end {
            Some(end) => {
                let s = &self.data[self.pos..end];
                self.pos = end;
                Ok(s)
            }
            None => Err(CdrError::Truncated {
                offset: self.pos.min(self.data.len()),
                field,
            }),
        }
    }

    fn u32(&mut self, field: &'static str) -> Result<u32, CdrError> {
        let b: [u8; 4] = self
            .take(4, 4, field)?
            .try_into()
            .map_err(|_| CdrError::Truncated {
                offset: self.pos,
                field,
            })?;
        Ok(if self.little {
            u32::from_le_bytes(b)
        } else {
            u32::from_be_bytes(b)
        })
    }

    /// A sequence length, bounded by the bytes left (so a corrupt length cannot allocate).
    fn len(&mut self, field: &'static str) -> Result<usize, CdrError> {
        let n = self.u32(field)? as usize;
        if n > self.data.len().saturating_sub(self.pos) {
            return Err(CdrError::Truncated {
                offset: self.pos,
                field,
            });
        }
        Ok(n)
    }

    fn f64(&mut self, field: &'static str) -> Result<f64, CdrError> {
        let b: [u8; 8] = self
            .take(8, 8, field)?
            .try_into()
            .map_err(|_| CdrError::Truncated {
                offset: self.pos,
                field,
            })?;
        Ok(if self.little {
            f64::from_le_bytes(b)
        } else {
            f64::from_be_bytes(b)
        })
    }

    fn string(&mut self, field: &'static str) -> Result<String, CdrError> {
        let at = self.pos;
        let n = self.len(field)?;
        let bytes = self.take(n, 1, field)?;
        let text = match bytes.split_last() {
            None => "",
            Some((0, text)) => std::str::from_utf8(text).map_err(|_| CdrError::String(at))?,
            Some(_) => return Err(CdrError::String(at)),
        };
        Ok(text.to_owned())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn joint_state_round_trips_through_cdr() {
        let m = JointStateMessage::from_degrees(
            1_795_340_245_123_456_789,
            &[0.0, 10.0, -90.0, 0.0, -90.0, 180.0],
            Some(&[1.0, 0.0, 0.0, 0.0, 0.0, 0.0]),
        );
        let bytes = m.encode_cdr();
        assert_eq!(&bytes[..4], &[0, 1, 0, 0]);
        // stamp (8), empty frame_id (4 + 1), then the name count aligned to 4.
        assert_eq!(&bytes[12..17], &[1, 0, 0, 0, 0]);
        assert_eq!(&bytes[20..24], &6u32.to_le_bytes());
        let back = JointStateMessage::decode_cdr(&bytes).unwrap();
        assert_eq!(back, m);
        assert_eq!(back.name[5], "joint_6");
        assert!((back.position[2] + std::f64::consts::FRAC_PI_2).abs() < 1e-15);
        // Six names of 4 + 8 bytes end at 96; the position count; the first double at 100,
        // a multiple of 8 from the end of the header.
        assert_eq!(&bytes[96..100], &6u32.to_le_bytes());
        assert_eq!(&bytes[100..108], &0f64.to_le_bytes());
        assert_eq!(&bytes[108..116], &10f64.to_radians().to_le_bytes());
    }

    #[test]
    fn truncated_and_corrupt_cdr_are_errors_not_panics() {
        let bytes = JointStateMessage::from_degrees(5, &[1.0; 6], None).encode_cdr();
        for n in 0..bytes.len() {
            assert!(JointStateMessage::decode_cdr(&bytes[..n]).is_err(), "{n}");
        }
        let mut huge = bytes.clone();
        huge[12..16].copy_from_slice(&u32::MAX.to_le_bytes());
        assert!(JointStateMessage::decode_cdr(&huge).is_err());
        assert_eq!(
            JointStateMessage::decode_cdr(&[0, 3, 0, 0]),
            Err(CdrError::Encapsulation(3))
        );
    }

    #[test]
    fn utc_dates() {
        assert_eq!(
            utc_rfc3339(951_782_400_000_000_000),
            "2000-02-29T00:00:00.000Z"
        );
        assert_eq!(
            utc_rfc3339(4_102_444_799_999_000_000),
            "2099-12-31T23:59:59.999Z"
        );
    }
}
