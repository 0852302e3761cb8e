//! MCAP recordings: ROS 2 `JointState` topics in CDR and JSON status, exchange and event
//! topics (`crate::record_format`), in zstd-compressed chunks.
//!
//! **A killed process leaves a file that opens.** Chunks are kept in memory and written whole
//! (one `write`), at the latest [`MCAP_CHUNK_INTERVAL`] after their first message. Each write
//! also appends a provisional end of file, a `DataEnd` and a `Footer` without a summary, that
//! the next write overwrites: whenever the process dies, the file on disk is a complete MCAP
//! file holding every closed chunk; readers fall back to reading it from the start, as they do
//! for any file without a summary. A clean end writes the real summary (indexes, statistics).

use std::collections::BTreeMap;
use std::fs::File;
use std::io::{self, Seek, SeekFrom, Write};
use std::path::Path;

use fs020n_proto::Status;
use mcap::records::{MessageHeader, Metadata};
use mcap::{Compression, WriteOptions, Writer};

use super::{Dir, Entry, Sink, MCAP_CHUNK_INTERVAL};
use crate::record_format::{
    commanded_joints, EventMessage, ExchangeMessage, JointStateMessage, RecordingInfo, Stamp,
    StatusMessage, EVENT_JSON_SCHEMA, EVENT_SCHEMA, EXCHANGE_JSON_SCHEMA, EXCHANGE_SCHEMA,
    JOINT_STATE_MSG_DEF, JOINT_STATE_SCHEMA, METADATA_NAME, STATUS_JSON_SCHEMA, STATUS_SCHEMA,
    TOPIC_COMMANDED, TOPIC_EVENT, TOPIC_EXCHANGE, TOPIC_JOINT_STATES, TOPIC_STATUS,
};

/// Largest uncompressed chunk: a chunk is closed at this size even before its interval ends.
const CHUNK_SIZE: u64 = 256 * 1024;

/// MCAP magic bytes (start and end of a file).
const MAGIC: &[u8; 8] = b"\x89MCAP0\r\n";
/// Record opcodes (MCAP specification).
const OP_FOOTER: u8 = 0x02;
const OP_DATA_END: u8 = 0x0F;

/// The provisional end of file: `DataEnd` (no CRC), `Footer` (no summary), magic.
fn provisional_end() -> Vec<u8> {
    let mut v = Vec::with_capacity(50);
    v.push(OP_DATA_END);
    v.extend_from_slice(&4u64.to_le_bytes());
    v.extend_from_slice(&0u32.to_le_bytes());
    v.push(OP_FOOTER);
    v.extend_from_slice(&20u64.to_le_bytes());
    v.extend_from_slice(&0u64.to_le_bytes()); // summary_start: none
    v.extend_from_slice(&0u64.to_le_bytes()); // summary_offset_start: none
    v.extend_from_slice(&0u32.to_le_bytes()); // summary_crc: none
    v.extend_from_slice(MAGIC);
    v
}

/// The file under the MCAP writer: bytes are held until `flush`, then written in one `write`
/// with the provisional end after them.
struct TailFile {
    file: File,
    /// Where the bytes written so far end on disk (the provisional end starts here).
    committed: u64,
    pending: Vec<u8>,
    /// After `finish`: no provisional end any more.
    finished: bool,
    end: Vec<u8>,
}

impl TailFile {
    fn position(&self) -> u64 {
        self.committed + self.pending.len() as u64
    }
}

impl Write for TailFile {
    fn write(&mut self, buf: &[u8]) -> io::Result<usize> {
        self.pending.extend_from_slice(buf);
        Ok(buf.len())
    }

    fn flush(&mut self) -> io::Result<()> {
        self.file.seek(SeekFrom::Start(self.committed))?;
        let written = self.pending.len() as u64;
        if !self.finished {
            self.pending.extend_from_slice(&self.end);
        }
        self.file.write_all(&self.pending)?;
        self.committed += written;
        self.pending.clear();
        if self.finished {
            // The real end is written: cut the provisional one that may follow it.
            self.file.set_len(self.committed)?;
        }
        Ok(())
    }
}

impl Seek for TailFile {
    /// Only tells the position: the MCAP writer is told not to seek.
    fn seek(&mut self, pos: SeekFrom) -> io::Result<u64> {
        let here = self.position();
        match pos {
            SeekFrom::Current(0) | SeekFrom::End(0) => Ok(here),
            SeekFrom::Start(p) if p == here => Ok(here),
            _ => Err(io::Error::new(
                io::ErrorKind::Unsupported,
                "the recording file is written in order",
            )),
        }
    }
}

struct Channels {
    joint_states: u16,
    commanded: u16,
    status: u16,
    exchange: u16,
    event: u16,
}

/// A request waiting for its reply.
struct Pending {
    session: u64,
    kind: String,
    request: String,
    sent_ns: u64,
}

pub(super) struct McapSink {
    writer: Writer<TailFile>,
    channels: Channels,
    /// Wall time of the recording's start, ns since the UNIX epoch.
    start_ns: u64,
    pending: Vec<Pending>,
    sequence: u32,
    /// When the open chunk got its first message.
    chunk_since: Option<std::time::Instant>,
}

fn to_io(e: mcap::McapError) -> io::Error {
    match e {
        mcap::McapError::Io(e) => e,
        other => io::Error::other(other),
    }
}

impl McapSink {
    /// Creates the file with its schemas, channels and metadata, on disk before this returns.
    pub(super) fn create(path: &Path, info: &RecordingInfo) -> io::Result<McapSink> {
        let file = File::create(path)?;
        let tail = TailFile {
            file,
            committed: 0,
            pending: Vec::with_capacity(64 * 1024),
            finished: false,
            end: provisional_end(),
        };
        let options = WriteOptions::new()
            .profile("")
            .library(info.client.clone())
            .compression(Some(Compression::Zstd))
            .compression_threads(0)
            .chunk_size(Some(CHUNK_SIZE))
            .disable_seeking(true);
        let mut writer = options.create(tail).map_err(to_io)?;
        let no_metadata = BTreeMap::new();
        let joint_state = writer
            .add_schema(
                JOINT_STATE_SCHEMA,
                "ros2msg",
                JOINT_STATE_MSG_DEF.as_bytes(),
            )
            .map_err(to_io)?;
        let mut json_channel = |schema: &str, text: &str, topic: &str| -> io::Result<u16> {
            let id = writer
                .add_schema(schema, "jsonschema", text.as_bytes())
                .map_err(to_io)?;
            writer
                .add_channel(id, topic, "json", &no_metadata)
                .map_err(to_io)
        };
        let status = json_channel(STATUS_SCHEMA, STATUS_JSON_SCHEMA, TOPIC_STATUS)?;
        let exchange = json_channel(EXCHANGE_SCHEMA, EXCHANGE_JSON_SCHEMA, TOPIC_EXCHANGE)?;
        let event = json_channel(EVENT_SCHEMA, EVENT_JSON_SCHEMA, TOPIC_EVENT)?;
        let channels = Channels {
            joint_states: writer
                .add_channel(joint_state, TOPIC_JOINT_STATES, "cdr", &no_metadata)
                .map_err(to_io)?,
            commanded: writer
                .add_channel(joint_state, TOPIC_COMMANDED, "cdr", &no_metadata)
                .map_err(to_io)?,
            status,
            exchange,
            event,
        };
        writer
            .write_metadata(&Metadata {
                name: METADATA_NAME.into(),
                metadata: info.to_metadata(),
            })
            .map_err(to_io)?;
        writer.flush().map_err(to_io)?;
        Ok(McapSink {
            writer,
            channels,
            start_ns: info.started_unix_ns,
            pending: Vec::new(),
            sequence: 0,
            chunk_since: None,
        })
    }

    fn message(&mut self, channel: u16, t_ns: u64, data: &[u8]) -> io::Result<()> {
        self.sequence = self.sequence.wrapping_add(1);
        self.writer
            .write_to_known_channel(
                &MessageHeader {
                    channel_id: channel,
                    sequence: self.sequence,
                    log_time: t_ns,
                    publish_time: t_ns,
                },
                data,
            )
            .map_err(to_io)?;
        self.chunk_since.get_or_insert_with(std::time::Instant::now);
        Ok(())
    }

    fn json<T: serde::Serialize>(&mut self, channel: u16, t_ns: u64, value: &T) -> io::Result<()> {
        let data = serde_json::to_vec(value).map_err(io::Error::other)?;
        self.message(channel, t_ns, &data)
    }

    fn exchange(&mut self, p: Pending, reply: Option<&str>, t_ns: u64) -> io::Result<()> {
        let rtt_ms = reply.map(|_| t_ns.saturating_sub(p.sent_ns) as f64 / 1e6);
        let m = ExchangeMessage {
            session: p.session,
            kind: p.kind,
            request: p.request,
            reply: reply.map(str::to_owned),
            sent: Stamp::from_nanos(p.sent_ns),
            rtt_ms,
        };
        self.json(self.channels.exchange, t_ns, &m)
    }

    fn take_pending(&mut self, session: u64) -> Option<Pending> {
        let i = self.pending.iter().position(|p| p.session == session)?;
        Some(self.pending.swap_remove(i))
    }
}

impl Sink for McapSink {
    fn entry(&mut self, e: &Entry) -> io::Result<()> {
        let t_ns = self
            .start_ns
            .saturating_add(u64::try_from(e.at.as_nanos()).unwrap_or(u64::MAX));
        match e.dir {
            Dir::Tx => {
                // One request at a time per session (lock-step); a leftover was never answered.
                if let Some(old) = self.take_pending(e.session) {
                    self.exchange(old, None, t_ns)?;
                }
                if let Some((position, velocity)) = commanded_joints(&e.text) {
                    let m = JointStateMessage::from_degrees(t_ns, &position, velocity.as_ref());
                    self.message(self.channels.commanded, t_ns, &m.encode_cdr())?;
                }
                self.pending.push(Pending {
                    session: e.session,
                    kind: e.kind.to_owned(),
                    request: e.text.clone(),
                    sent_ns: t_ns,
                });
            }
            Dir::Rx => {
                if let Ok(status) = Status::decode(&e.text) {
                    let m = JointStateMessage::from_degrees(t_ns, &status.joints.0, None);
                    self.message(self.channels.joint_states, t_ns, &m.encode_cdr())?;
                    self.json(
                        self.channels.status,
                        t_ns,
                        &StatusMessage::new(e.session, &status),
                    )?;
                }
                let p = self.take_pending(e.session).unwrap_or_else(|| Pending {
                    session: e.session,
                    kind: e.kind.to_owned(),
                    request: String::new(),
                    sent_ns: t_ns.saturating_sub(
                        e.rtt
                            .map_or(0, |d| u64::try_from(d.as_nanos()).unwrap_or(u64::MAX)),
                    ),
                });
                self.exchange(p, Some(&e.text), t_ns)?;
            }
            Dir::Event => {
                if e.kind == "end" {
                    if let Some(p) = self.take_pending(e.session) {
                        self.exchange(p, None, t_ns)?;
                    }
                }
                let m = EventMessage {
                    session: e.session,
                    event: e.kind.to_owned(),
                    text: e.text.clone(),
                };
                self.json(self.channels.event, t_ns, &m)?;
            }
        }
        Ok(())
    }

    fn idle(&mut self) -> io::Result<()> {
        if self
            .chunk_since
            .is_some_and(|t| t.elapsed() >= MCAP_CHUNK_INTERVAL)
        {
            self.flush()?;
        }
        Ok(())
    }

    fn flush(&mut self) -> io::Result<()> {
        self.chunk_since = None;
        self.writer.flush().map_err(to_io)
    }

    fn finish(mut self: Box<Self>) -> io::Result<()> {
        let leftovers = std::mem::take(&mut self.pending);
        for p in leftovers {
            let t = p.sent_ns;
            self.exchange(p, None, t)?;
        }
        self.writer.finish().map_err(to_io)?;
        let McapSink { writer, .. } = *self;
        let mut tail = writer.into_inner();
        tail.finished = true;
        tail.flush()
    }
}
