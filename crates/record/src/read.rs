//! Reading recordings: the client's CSV and JSON lines (every request and reply), the status CSV
//! of `fs020n record`, and MCAP (this project's, or any file with `sensor_msgs/msg/JointState`
//! on `/joint_states`).

use std::collections::BTreeMap;
use std::path::Path;

use fs020n_client::record_format::{
    commanded_joints, EventMessage, ExchangeMessage, JointStateMessage, RecordingInfo,
    StatusMessage, JOINT_NAMES, JOINT_STATE_SCHEMA, TOPIC_COMMANDED, TOPIC_EVENT, TOPIC_EXCHANGE,
    TOPIC_JOINT_STATES, TOPIC_STATUS,
};
use fs020n_proto::Status;
use serde::Serialize;

use crate::error::RecordError;

/// The file formats a recording can have.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum SourceFormat {
    /// The client's CSV: `t_s,session,dir,kind,rtt_ms,text`.
    Csv,
    /// The client's JSON lines.
    JsonLines,
    /// The status CSV of `fs020n record FILE.csv`: `time_s,timer_s,…,j1..j6` (no round trips).
    StatusCsv,
    /// MCAP.
    Mcap,
}

/// The status fields of a reply.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct StatusFields {
    /// AS error number (0 = none).
    pub error_code: i32,
    /// RUN/HOLD on RUN.
    pub run: bool,
    /// TEACH/REPEAT on REPEAT.
    pub repeat: bool,
    /// TEACH LOCK on.
    pub teach_lock: bool,
    /// Motor power on.
    pub power: bool,
    /// The motion program runs.
    pub program_running: bool,
    /// TIMER(1), seconds (`None` on overflow).
    pub timer_s: Option<f64>,
}

impl From<&Status> for StatusFields {
    fn from(s: &Status) -> Self {
        StatusFields {
            error_code: s.error.raw(),
            run: s.run,
            repeat: s.repeat,
            teach_lock: s.teach_lock,
            power: s.power,
            program_running: s.task_running,
            timer_s: s.timer.seconds(),
        }
    }
}

impl From<&StatusMessage> for StatusFields {
    fn from(s: &StatusMessage) -> Self {
        StatusFields {
            error_code: s.error_code,
            run: s.run,
            repeat: s.repeat,
            teach_lock: s.teach_lock,
            power: s.power,
            program_running: s.program_running,
            timer_s: s.timer_s,
        }
    }
}

/// One request with its reply.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Exchange {
    /// Session number (1 = the first connection of the recording).
    pub session: u64,
    /// `poll`, `keepalive`, `command`, `motion`, `raw` or `close`.
    pub kind: String,
    /// The request bytes as sent.
    pub request: String,
    /// The reply bytes as received (`None`: no reply, the link was lost).
    pub reply: Option<String>,
    /// When the request was sent, seconds since the recording started.
    pub sent_s: f64,
    /// Round trip, milliseconds.
    pub rtt_ms: Option<f64>,
}

/// Measured joints (and status) at one reply.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct State {
    /// When the reply arrived, seconds since the recording started.
    pub t_s: f64,
    /// Session number (0 when the format does not tell).
    pub session: u64,
    /// JT1..JT6, degrees.
    pub joints_deg: [f64; 6],
    /// The status fields, when recorded.
    pub status: Option<StatusFields>,
}

/// A commanded position: the target of command 6, a command-7 sample.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Commanded {
    /// When it was sent, seconds since the recording started.
    pub t_s: f64,
    /// JT1..JT6, degrees.
    pub joints_deg: [f64; 6],
    /// Velocities of a command-7 sample, degrees per second.
    pub velocity_deg_s: Option<[f64; 6]>,
    /// `true` for a streamed sample (command 7), `false` for a joint-move target (command 6).
    pub streamed: bool,
}

/// Something that happened: `start`, `connect`, `end`.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Event {
    /// Seconds since the recording started.
    pub t_s: f64,
    /// Session number (0 for `start`).
    pub session: u64,
    /// `start`, `connect` or `end`.
    pub event: String,
    /// The address (`connect`), the cause (`end`), the recording info as JSON (`start`).
    pub text: String,
}

/// A recording, read whole.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Run {
    /// The file's format.
    pub format: SourceFormat,
    /// What the recording says about itself (absent in status CSVs and foreign MCAP files).
    pub info: Option<RecordingInfo>,
    /// Every request with its reply, in order.
    pub exchanges: Vec<Exchange>,
    /// Measured joints, in order.
    pub states: Vec<State>,
    /// Commanded positions, in order.
    pub commanded: Vec<Commanded>,
    /// Events, in order.
    pub events: Vec<Event>,
    /// Set when the file ends in the middle of a record (the recorder was killed, the disk
    /// filled): everything before is here.
    pub truncated: Option<String>,
}

impl Run {
    /// The robot's address: the first `connect` event.
    pub fn robot(&self) -> Option<&str> {
        self.events
            .iter()
            .find(|e| e.event == "connect")
            .map(|e| e.text.as_str())
    }

    /// First to last time stamp, seconds (0 for an empty run).
    pub fn time_span(&self) -> (f64, f64) {
        let times = self
            .states
            .iter()
            .map(|s| s.t_s)
            .chain(self.exchanges.iter().map(|e| e.sent_s))
            .chain(self.commanded.iter().map(|c| c.t_s));
        let (lo, hi) = times.fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), t| {
            (lo.min(t), hi.max(t))
        });
        if lo.is_finite() {
            (lo, hi)
        } else {
            (0.0, 0.0)
        }
    }

    /// Replies slower than this were late when recorded (the client's threshold, 100 ms by
    /// default).
    pub fn late_reply_after_ms(&self) -> f64 {
        self.info.as_ref().map_or(100.0, |i| i.late_reply_after_ms)
    }
}

/// Reads a recording; the format comes from the extension (`.mcap`; `.jsonl`/`.ndjson`;
/// anything else is read as CSV, the client's or `fs020n record`'s, told apart by the header).
pub fn read(path: &Path) -> Result<Run, RecordError> {
    let bytes = std::fs::read(path).map_err(|e| RecordError::Io {
        path: path.display().to_string(),
        message: e.to_string(),
    })?;
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase)
        .unwrap_or_default();
    if bytes.starts_with(b"\x89MCAP") || ext == "mcap" {
        return read_mcap(&bytes);
    }
    let text = String::from_utf8(bytes).map_err(|_| RecordError::Format {
        line: 0,
        message: "not UTF-8 text, nor an MCAP file".into(),
    })?;
    if ext == "jsonl" || ext == "ndjson" || text.trim_start().starts_with('{') {
        read_jsonl(&text)
    } else {
        read_csv(&text)
    }
}

/// One line of the client's CSV or JSON lines.
struct Line {
    t_s: f64,
    session: u64,
    dir: String,
    kind: String,
    rtt_ms: Option<f64>,
    text: String,
}

/// Builds a run from the client's lines: pairs each `tx` with the next `rx` of its session.
fn from_lines(format: SourceFormat, lines: Vec<(usize, Line)>) -> Result<Run, RecordError> {
    let mut run = empty(format);
    let mut pending: BTreeMap<u64, usize> = BTreeMap::new();
    for (no, l) in lines {
        match l.dir.as_str() {
            "tx" => {
                if let Some((position, velocity)) = commanded_joints(&l.text) {
                    run.commanded.push(Commanded {
                        t_s: l.t_s,
                        joints_deg: position,
                        velocity_deg_s: velocity,
                        streamed: velocity.is_some(),
                    });
                }
                pending.insert(l.session, run.exchanges.len());
                run.exchanges.push(Exchange {
                    session: l.session,
                    kind: l.kind,
                    request: l.text,
                    reply: None,
                    sent_s: l.t_s,
                    rtt_ms: None,
                });
            }
            "rx" => {
                if let Ok(s) = Status::decode(&l.text) {
                    run.states.push(State {
                        t_s: l.t_s,
                        session: l.session,
                        joints_deg: s.joints.0,
                        status: Some(StatusFields::from(&s)),
                    });
                }
                match pending.remove(&l.session) {
                    Some(i) => {
                        let e = &mut run.exchanges[i];
                        e.reply = Some(l.text);
                        e.rtt_ms = l.rtt_ms;
                    }
                    None => run.exchanges.push(Exchange {
                        session: l.session,
                        kind: l.kind,
                        request: String::new(),
                        reply: Some(l.text),
                        sent_s: l.t_s - l.rtt_ms.unwrap_or(0.0) / 1e3,
                        rtt_ms: l.rtt_ms,
                    }),
                }
            }
            "event" => {
                if l.kind == "start" {
                    run.info = serde_json::from_str(&l.text).ok();
                }
                if l.kind == "end" {
                    pending.remove(&l.session);
                }
                run.events.push(Event {
                    t_s: l.t_s,
                    session: l.session,
                    event: l.kind,
                    text: l.text,
                });
            }
            other => {
                return Err(RecordError::Format {
                    line: no,
                    message: format!("unknown dir {other:?} (expected tx, rx or event)"),
                })
            }
        }
    }
    Ok(run)
}

fn empty(format: SourceFormat) -> Run {
    Run {
        format,
        info: None,
        exchanges: Vec::new(),
        states: Vec::new(),
        commanded: Vec::new(),
        events: Vec::new(),
        truncated: None,
    }
}

/// The header of the client's CSV.
const CLIENT_CSV_HEADER: [&str; 6] = ["t_s", "session", "dir", "kind", "rtt_ms", "text"];
/// The first columns of `fs020n record`'s status CSV.
const STATUS_CSV_HEADER: [&str; 9] = [
    "time_s",
    "timer_s",
    "error_code",
    "error",
    "run",
    "repeat",
    "teach_lock",
    "power",
    "task_running",
];

fn read_csv(text: &str) -> Result<Run, RecordError> {
    let mut reader = csv::ReaderBuilder::new()
        .has_headers(true)
        .flexible(true)
        .from_reader(text.as_bytes());
    let header: Vec<String> = reader
        .headers()
        .map_err(|e| csv_error(&e, 1))?
        .iter()
        .map(str::to_owned)
        .collect();
    if header.iter().map(String::as_str).eq(CLIENT_CSV_HEADER) {
        let mut lines = Vec::new();
        let mut truncated = None;
        let records: Vec<_> = reader.records().collect();
        let last = records.len().saturating_sub(1);
        for (k, rec) in records.into_iter().enumerate() {
            let no = k + 2;
            // A killed writer can leave a last line cut short (every line ends with a newline).
            if k == last && !text.ends_with('\n') {
                truncated = Some(format!("line {no} is cut short (no end of line)"));
                break;
            }
            let rec = match rec {
                Ok(rec) if rec.len() == 6 => rec,
                Ok(rec) if k == last => {
                    truncated = Some(format!("line {no} has {} fields, expected 6", rec.len()));
                    break;
                }
                Ok(rec) => {
                    return Err(RecordError::Format {
                        line: no,
                        message: format!("{} fields, expected 6", rec.len()),
                    })
                }
                Err(e) if k == last => {
                    truncated = Some(format!("line {no}: {e}"));
                    break;
                }
                Err(e) => return Err(csv_error(&e, no)),
            };
            lines.push((
                no,
                Line {
                    t_s: number(&rec[0], no, "t_s")?,
                    session: rec[1].parse().map_err(|_| bad(no, "session", &rec[1]))?,
                    dir: rec[2].to_owned(),
                    kind: rec[3].to_owned(),
                    rtt_ms: optional_number(&rec[4], no, "rtt_ms")?,
                    text: rec[5].to_owned(),
                },
            ));
        }
        let mut run = from_lines(SourceFormat::Csv, lines)?;
        run.truncated = truncated;
        return Ok(run);
    }
    if header.len() == STATUS_CSV_HEADER.len() + 6
        && header.iter().zip(STATUS_CSV_HEADER).all(|(a, b)| a == b)
    {
        let mut run = empty(SourceFormat::StatusCsv);
        for (k, rec) in reader.records().enumerate() {
            let no = k + 2;
            let rec = rec.map_err(|e| csv_error(&e, no))?;
            if rec.len() != header.len() {
                run.truncated = Some(format!(
                    "line {no} has {} fields, expected {}",
                    rec.len(),
                    header.len()
                ));
                break;
            }
            let flag = |i: usize| &rec[i] == "1";
            let mut joints = [0.0; 6];
            for (j, v) in joints.iter_mut().enumerate() {
                *v = number(&rec[9 + j], no, "joint")?;
            }
            run.states.push(State {
                t_s: number(&rec[0], no, "time_s")?,
                session: 0,
                joints_deg: joints,
                status: Some(StatusFields {
                    error_code: rec[2].parse().map_err(|_| bad(no, "error_code", &rec[2]))?,
                    run: flag(4),
                    repeat: flag(5),
                    teach_lock: flag(6),
                    power: flag(7),
                    program_running: flag(8),
                    timer_s: optional_number(&rec[1], no, "timer_s")?,
                }),
            });
        }
        return Ok(run);
    }
    Err(RecordError::Format {
        line: 1,
        message: format!(
            "unknown CSV header {:?}: expected the client's recording ({}) or `fs020n record`'s \
             status ({},j1..j6)",
            header.join(","),
            CLIENT_CSV_HEADER.join(","),
            STATUS_CSV_HEADER.join(",")
        ),
    })
}

fn csv_error(e: &csv::Error, line: usize) -> RecordError {
    RecordError::Format {
        line: e.position().map_or(line, |p| p.line() as usize),
        message: e.to_string(),
    }
}

fn bad(line: usize, field: &str, value: &str) -> RecordError {
    RecordError::Format {
        line,
        message: format!("{field} {value:?} is not a number"),
    }
}

fn number(s: &str, line: usize, field: &str) -> Result<f64, RecordError> {
    s.trim()
        .parse::<f64>()
        .ok()
        .filter(|v| v.is_finite())
        .ok_or_else(|| bad(line, field, s))
}

fn optional_number(s: &str, line: usize, field: &str) -> Result<Option<f64>, RecordError> {
    if s.trim().is_empty() {
        Ok(None)
    } else {
        number(s, line, field).map(Some)
    }
}

#[derive(serde::Deserialize)]
struct JsonLine {
    t_s: f64,
    session: u64,
    dir: String,
    kind: String,
    rtt_ms: Option<f64>,
    text: String,
}

fn read_jsonl(text: &str) -> Result<Run, RecordError> {
    let mut lines = Vec::new();
    let mut truncated = None;
    let all: Vec<&str> = text.lines().collect();
    for (k, raw) in all.iter().enumerate() {
        let no = k + 1;
        if raw.trim().is_empty() {
            continue;
        }
        match serde_json::from_str::<JsonLine>(raw) {
            Ok(l) => lines.push((
                no,
                Line {
                    t_s: l.t_s,
                    session: l.session,
                    dir: l.dir,
                    kind: l.kind,
                    rtt_ms: l.rtt_ms,
                    text: l.text,
                },
            )),
            // A killed writer can leave the last line cut short.
            Err(e) if no == all.len() && !text.ends_with('\n') => {
                truncated = Some(format!("line {no}: {e}"));
            }
            Err(e) => {
                return Err(RecordError::Format {
                    line: no,
                    message: e.to_string(),
                })
            }
        }
    }
    let mut run = from_lines(SourceFormat::JsonLines, lines)?;
    run.truncated = truncated;
    Ok(run)
}

fn read_mcap(bytes: &[u8]) -> Result<Run, RecordError> {
    let mut run = empty(SourceFormat::Mcap);
    let stream =
        mcap::MessageStream::new_with_options(bytes, mcap::read::Options::IgnoreEndMagic.into())
            .map_err(|e| RecordError::Mcap(e.to_string()))?;
    // Messages with their times in ns; turned into seconds since the start at the end.
    let mut states: Vec<(u64, u64, [f64; 6])> = Vec::new();
    let mut statuses: Vec<StatusMessage> = Vec::new();
    let mut commanded: Vec<(u64, Commanded)> = Vec::new();
    let mut exchanges: Vec<(u64, ExchangeMessage)> = Vec::new();
    let mut events: Vec<(u64, EventMessage)> = Vec::new();
    for m in stream {
        let m = match m {
            Ok(m) => m,
            Err(e) => {
                run.truncated = Some(e.to_string());
                break;
            }
        };
        let topic = m.channel.topic.as_str();
        let is_joint_state = m
            .channel
            .schema
            .as_ref()
            .is_some_and(|s| s.name == JOINT_STATE_SCHEMA)
            && m.channel.message_encoding == "cdr";
        let bad = |e: String| RecordError::Mcap(format!("{topic}: {e}"));
        match topic {
            TOPIC_JOINT_STATES | TOPIC_COMMANDED if is_joint_state => {
                let js = JointStateMessage::decode_cdr(&m.data).map_err(|e| bad(e.to_string()))?;
                let Some(position) = six_joints_deg(&js, &js.position) else {
                    continue;
                };
                if topic == TOPIC_JOINT_STATES {
                    states.push((m.log_time, 0, position));
                } else {
                    let velocity = six_joints_deg(&js, &js.velocity);
                    commanded.push((
                        m.log_time,
                        Commanded {
                            t_s: 0.0,
                            joints_deg: position,
                            velocity_deg_s: velocity,
                            streamed: velocity.is_some(),
                        },
                    ));
                }
            }
            TOPIC_STATUS => {
                let s: StatusMessage =
                    serde_json::from_slice(&m.data).map_err(|e| bad(e.to_string()))?;
                statuses.push(s);
            }
            TOPIC_EXCHANGE => {
                let x: ExchangeMessage =
                    serde_json::from_slice(&m.data).map_err(|e| bad(e.to_string()))?;
                exchanges.push((m.log_time, x));
            }
            TOPIC_EVENT => {
                let e: EventMessage =
                    serde_json::from_slice(&m.data).map_err(|e| bad(e.to_string()))?;
                if e.event == "start" {
                    run.info = serde_json::from_str(&e.text).ok();
                }
                events.push((m.log_time, e));
            }
            _ => {}
        }
    }
    let first = [
        states.first().map(|s| s.0),
        commanded.first().map(|c| c.0),
        exchanges.first().map(|x| x.1.sent.nanos()),
        events.first().map(|e| e.0),
    ]
    .into_iter()
    .flatten()
    .min()
    .unwrap_or(0);
    let start = run
        .info
        .as_ref()
        .map_or(first, |i| i.started_unix_ns.min(first));
    let secs = |ns: u64| ns.saturating_sub(start) as f64 / 1e9;
    // The writer puts a status message after each joint state of a reply: pair them in order
    // (a file from elsewhere may have joint states only).
    let paired = statuses.len() == states.len();
    run.states = states
        .into_iter()
        .enumerate()
        .map(|(i, (t, _, joints))| {
            let status = statuses.get(i).filter(|_| paired);
            State {
                t_s: secs(t),
                session: status.map_or(0, |s| s.session),
                joints_deg: joints,
                status: status.map(StatusFields::from),
            }
        })
        .collect();
    run.commanded = commanded
        .into_iter()
        .map(|(t, mut c)| {
            c.t_s = secs(t);
            c
        })
        .collect();
    run.exchanges = exchanges
        .into_iter()
        .map(|(_, x)| Exchange {
            session: x.session,
            kind: x.kind,
            request: x.request,
            reply: x.reply,
            sent_s: secs(x.sent.nanos()),
            rtt_ms: x.rtt_ms,
        })
        .collect();
    // Exchanges are logged at their reply: order them by when they were sent.
    run.exchanges.sort_by(|a, b| a.sent_s.total_cmp(&b.sent_s));
    run.events = events
        .into_iter()
        .map(|(t, e)| Event {
            t_s: secs(t),
            session: e.session,
            event: e.event,
            text: e.text,
        })
        .collect();
    Ok(run)
}

/// Six values in joint order (by the names `joint_1`…`joint_6` when the message has them), in
/// degrees; `None` when there are not six.
fn six_joints_deg(js: &JointStateMessage, values: &[f64]) -> Option<[f64; 6]> {
    if values.len() < 6 {
        return None;
    }
    let mut out = [0.0; 6];
    for (i, o) in out.iter_mut().enumerate() {
        let k = js
            .name
            .iter()
            .position(|n| n == JOINT_NAMES[i])
            .filter(|&k| k < values.len())
            .unwrap_or(i);
        *o = values[k].to_degrees();
    }
    Some(out)
}
