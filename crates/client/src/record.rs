//! Recording of every request and reply, written by a thread of its own.
//!
//! The session task hands each line to [`Recorder::line`], which never blocks and never does
//! I/O: it puts the line in a bounded queue. A full queue (a disk stalled for seconds) drops the
//! line and counts it in `Stats::record_errors`; the request and its reply deadline are not
//! delayed. The writer thread takes the lines from the queue in batches (it lets the lines of
//! [`BATCH_PERIOD`] gather, so that the session task does not wake it for every line) and writes
//! them: CSV and JSON lines one `write` per batch, MCAP in chunks closed at least every
//! [`MCAP_CHUNK_INTERVAL`] (see `record/mcap_sink.rs`).

use std::fs::File;
use std::io::{self, Write};
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::mpsc::{self, Receiver, RecvTimeoutError, SyncSender, TrySendError};
use std::sync::Arc;
use std::time::{Duration, SystemTime};

use tokio::time::Instant;

use crate::config::{RecordFormat, Recording};
use crate::error::ClientError;
use crate::record_format::{utc_rfc3339, RecordingInfo};

#[cfg(feature = "mcap")]
mod mcap_sink;

/// Lines the queue between the session task and the writer thread holds (a few minutes of a
/// 50 Hz stream).
pub const RECORD_QUEUE_LINES: usize = 16_384;

/// Longest time an MCAP chunk stays open: a process killed at any moment loses at most the
/// lines of this last interval, and the file up to there opens in every MCAP reader.
pub const MCAP_CHUNK_INTERVAL: Duration = Duration::from_secs(1);

/// How long dropping the recorder waits for the writer thread to write what is queued and to
/// finish the file (MCAP: its summary). After that the thread is left to finish on its own.
const FINISH_TIMEOUT: Duration = Duration::from_secs(5);

/// How often the writer thread wakes without lines (to close an MCAP chunk in time).
const IDLE_TICK: Duration = Duration::from_millis(100);

/// After the first line of a batch, the writer thread lets the lines of this period gather
/// before it writes them: the session task then wakes it at most once per period (a wake per
/// line costs a system call and a thread switch on every request).
const BATCH_PERIOD: Duration = Duration::from_millis(20);

/// Most lines the writer thread takes from the queue at once (the queue stays the bound on
/// memory).
const BATCH_LINES: usize = 4096;

/// Direction of a recorded line.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Dir {
    /// Request written.
    Tx,
    /// Reply received.
    Rx,
    /// Something that happened (start, connect, link lost, close).
    Event,
}

impl Dir {
    fn as_str(self) -> &'static str {
        match self {
            Dir::Tx => "tx",
            Dir::Rx => "rx",
            Dir::Event => "event",
        }
    }
}

/// One line, as the session task hands it over.
#[derive(Debug, Clone)]
pub(crate) struct Entry {
    /// Since the recording started.
    pub(crate) at: Duration,
    pub(crate) session: u64,
    pub(crate) dir: Dir,
    pub(crate) kind: &'static str,
    pub(crate) rtt: Option<Duration>,
    pub(crate) text: String,
}

enum Msg {
    Entry(Entry),
    Flush(tokio::sync::oneshot::Sender<Result<(), String>>),
}

/// What the writer thread writes to.
pub(crate) trait Sink: Send {
    /// Takes one line (written now or at the end of the batch).
    fn entry(&mut self, e: &Entry) -> io::Result<()>;
    /// Called after each batch of lines and whenever the queue stays empty for a while.
    fn idle(&mut self) -> io::Result<()> {
        Ok(())
    }
    /// Lines lost by the last failed call (at least one is counted for each failed call).
    fn take_lost(&mut self) -> u64 {
        0
    }
    /// Everything written so far reaches the file.
    fn flush(&mut self) -> io::Result<()>;
    /// Ends the file.
    fn finish(self: Box<Self>) -> io::Result<()>;
}

/// One open recording: the queue to its writer thread.
#[derive(Debug)]
pub(crate) struct Recorder {
    tx: Option<SyncSender<Msg>>,
    /// Lines lost (queue full, write failures) not reported yet.
    lost: Arc<AtomicU64>,
    /// A loss was logged already (once is enough: the count is in the statistics).
    warned: Arc<AtomicBool>,
    /// Told when the writer thread has ended the file (a `Mutex` only to make it `Sync`).
    done: std::sync::Mutex<Receiver<()>>,
    epoch: Instant,
    path: String,
}

impl Recorder {
    /// Creates the file, writes its header and the `start` line (errors are returned here, at
    /// connect), then starts the writer thread.
    pub(crate) fn open(
        rec: &Recording,
        late_reply_after: Duration,
    ) -> Result<Recorder, ClientError> {
        let path = rec.path.display().to_string();
        let err = |e: io::Error| ClientError::Recording {
            path: path.clone(),
            message: e.to_string(),
        };
        let epoch = Instant::now();
        let unix_ns = SystemTime::now()
            .duration_since(SystemTime::UNIX_EPOCH)
            .map_or(0, |d| u64::try_from(d.as_nanos()).unwrap_or(u64::MAX));
        let info = RecordingInfo {
            started_utc: utc_rfc3339(unix_ns),
            started_unix_ns: unix_ns,
            client: concat!("fs020n-client ", env!("CARGO_PKG_VERSION")).to_owned(),
            late_reply_after_ms: late_reply_after.as_secs_f64() * 1e3,
        };
        let mut sink: Box<dyn Sink> = match rec.format {
            RecordFormat::Csv | RecordFormat::JsonLines => {
                Box::new(LineSink::create(&rec.path, rec.format).map_err(err)?)
            }
            #[cfg(feature = "mcap")]
            RecordFormat::Mcap => {
                Box::new(mcap_sink::McapSink::create(&rec.path, &info).map_err(err)?)
            }
            #[cfg(not(feature = "mcap"))]
            RecordFormat::Mcap => {
                return Err(ClientError::Recording {
                    path,
                    message: "this build of fs020n-client has no MCAP support: enable its `mcap` \
                              feature, or record to .csv or .jsonl"
                        .into(),
                })
            }
        };
        let start = Entry {
            at: Duration::ZERO,
            session: 0,
            dir: Dir::Event,
            kind: "start",
            rtt: None,
            text: serde_json::to_string(&info).unwrap_or_default(),
        };
        sink.entry(&start).map_err(err)?;
        Ok(Recorder::spawn(sink, epoch, path))
    }

    fn spawn(sink: Box<dyn Sink>, epoch: Instant, path: String) -> Recorder {
        let (tx, rx) = mpsc::sync_channel(RECORD_QUEUE_LINES);
        let (done_tx, done) = mpsc::sync_channel(1);
        let lost = Arc::new(AtomicU64::new(0));
        let warned = Arc::new(AtomicBool::new(false));
        let writer = Writer {
            sink,
            lost: lost.clone(),
            warned: warned.clone(),
            path: path.clone(),
        };
        let spawned = std::thread::Builder::new()
            .name("fs020n-record".into())
            .spawn(move || {
                writer.run(rx);
                let _ = done_tx.send(());
            });
        let tx = match spawned {
            Ok(_) => Some(tx),
            Err(e) => {
                tracing::warn!(path = %path, error = %e, "cannot start the recording thread: nothing is recorded");
                None
            }
        };
        Recorder {
            tx,
            lost,
            warned,
            done: std::sync::Mutex::new(done),
            epoch,
            path,
        }
    }

    /// Queues one line; never blocks. `Err(n)`: `n` lines were lost since the last call (this
    /// one included when the queue was full).
    pub(crate) fn line(
        &self,
        at: Instant,
        session: u64,
        dir: Dir,
        kind: &'static str,
        rtt: Option<Duration>,
        text: &str,
    ) -> Result<(), u64> {
        let entry = Entry {
            at: at.saturating_duration_since(self.epoch),
            session,
            dir,
            kind,
            rtt,
            text: text.to_owned(),
        };
        let mut lost = 0;
        let queued = match &self.tx {
            Some(tx) => tx.try_send(Msg::Entry(entry)),
            None => Err(TrySendError::Disconnected(Msg::Entry(entry))),
        };
        if let Err(e) = queued {
            lost += 1;
            let why = match e {
                TrySendError::Full(_) => "the disk is too slow (queue full)",
                TrySendError::Disconnected(_) => "the recording thread is gone",
            };
            warn_once(&self.warned, &self.path, why);
        }
        lost += self.lost.swap(0, Ordering::Relaxed);
        if lost == 0 {
            Ok(())
        } else {
            Err(lost)
        }
    }

    /// Resolves once every line queued before this call is in the file (MCAP: in a closed
    /// chunk, so the file up to here opens in every reader).
    pub(crate) async fn flush(&self) -> Result<(), ClientError> {
        let err = |message: String| ClientError::Recording {
            path: self.path.clone(),
            message,
        };
        let Some(tx) = &self.tx else {
            return Err(err("the recording thread is gone".into()));
        };
        let (ack, done) = tokio::sync::oneshot::channel();
        let mut msg = Msg::Flush(ack);
        loop {
            match tx.try_send(msg) {
                Ok(()) => break,
                Err(TrySendError::Full(m)) => {
                    msg = m;
                    tokio::time::sleep(Duration::from_millis(10)).await;
                }
                Err(TrySendError::Disconnected(_)) => {
                    return Err(err("the recording thread is gone".into()))
                }
            }
        }
        match done.await {
            Ok(r) => r.map_err(err),
            Err(_) => Err(err("the recording thread is gone".into())),
        }
    }
}

impl Drop for Recorder {
    /// Lets the writer thread write what is queued and end the file, waiting at most
    /// [`FINISH_TIMEOUT`].
    fn drop(&mut self) {
        let Some(tx) = self.tx.take() else { return };
        drop(tx);
        let finished = match self.done.get_mut() {
            Ok(done) => done.recv_timeout(FINISH_TIMEOUT).is_ok(),
            Err(_) => false,
        };
        if !finished {
            tracing::warn!(path = %self.path, "the recording is still being written after {FINISH_TIMEOUT:?}; not waiting longer");
        }
    }
}

fn warn_once(warned: &AtomicBool, path: &str, why: &str) {
    if !warned.swap(true, Ordering::Relaxed) {
        tracing::warn!(path = %path, "recording: lines lost: {why} (counted in Stats::record_errors)");
    }
}

/// The writer thread's state.
struct Writer {
    sink: Box<dyn Sink>,
    lost: Arc<AtomicU64>,
    warned: Arc<AtomicBool>,
    path: String,
}

impl Writer {
    fn run(mut self, rx: Receiver<Msg>) {
        let mut open = true;
        let mut batch = Vec::with_capacity(BATCH_LINES);
        while open {
            match rx.recv_timeout(IDLE_TICK) {
                Ok(first) => {
                    batch.push(first);
                    std::thread::sleep(BATCH_PERIOD);
                }
                Err(RecvTimeoutError::Timeout) => {}
                Err(RecvTimeoutError::Disconnected) => open = false,
            }
            // Everything queued, a bounded batch at a time.
            loop {
                while open && batch.len() < BATCH_LINES {
                    match rx.try_recv() {
                        Ok(m) => batch.push(m),
                        Err(mpsc::TryRecvError::Empty) => break,
                        Err(mpsc::TryRecvError::Disconnected) => open = false,
                    }
                }
                let full = batch.len() == BATCH_LINES;
                self.write_batch(&mut batch);
                if !full {
                    break;
                }
            }
        }
        if let Err(e) = self.sink.finish() {
            tracing::warn!(path = %self.path, error = %e, "cannot finish the recording");
        }
    }

    fn write_batch(&mut self, batch: &mut Vec<Msg>) {
        for msg in batch.drain(..) {
            match msg {
                Msg::Entry(e) => {
                    let r = self.sink.entry(&e);
                    self.count(r);
                }
                Msg::Flush(ack) => {
                    let r = self.sink.flush();
                    let _ = ack.send(r.as_ref().map(|_| ()).map_err(|e| e.to_string()));
                    self.count(r);
                }
            }
        }
        let r = self.sink.idle();
        self.count(r);
    }

    fn count(&mut self, r: io::Result<()>) {
        if let Err(e) = r {
            let n = self.sink.take_lost().max(1);
            self.lost.fetch_add(n, Ordering::Relaxed);
            warn_once(&self.warned, &self.path, &e.to_string());
        }
    }
}

/// CSV and JSON lines: the lines of a batch in one `write`.
struct LineSink {
    file: File,
    format: RecordFormat,
    buf: String,
    lines: u64,
    lost: u64,
}

impl LineSink {
    fn create(path: &std::path::Path, format: RecordFormat) -> io::Result<LineSink> {
        let mut file = File::create(path)?;
        if format == RecordFormat::Csv {
            file.write_all(b"t_s,session,dir,kind,rtt_ms,text\n")?;
        }
        Ok(LineSink {
            file,
            format,
            buf: String::with_capacity(16 * 1024),
            lines: 0,
            lost: 0,
        })
    }

    fn write_out(&mut self) -> io::Result<()> {
        if self.buf.is_empty() {
            return Ok(());
        }
        let r = self.file.write_all(self.buf.as_bytes());
        if r.is_err() {
            self.lost += self.lines;
        }
        self.buf.clear();
        self.lines = 0;
        r
    }
}

impl Sink for LineSink {
    fn entry(&mut self, e: &Entry) -> io::Result<()> {
        use std::fmt::Write as _;
        let t = e.at.as_secs_f64();
        let rtt_ms = e.rtt.map(|d| d.as_secs_f64() * 1e3);
        match self.format {
            RecordFormat::JsonLines => {
                let v = serde_json::json!({
                    "t_s": (t * 1e6).round() / 1e6,
                    "session": e.session,
                    "dir": e.dir.as_str(),
                    "kind": e.kind,
                    "rtt_ms": rtt_ms.map(|r| (r * 1e3).round() / 1e3),
                    "text": e.text,
                });
                let _ = writeln!(self.buf, "{v}");
            }
            _ => {
                let _ = writeln!(
                    self.buf,
                    "{t:.6},{},{},{},{},{}",
                    e.session,
                    e.dir.as_str(),
                    e.kind,
                    rtt_ms.map(|r| format!("{r:.3}")).unwrap_or_default(),
                    csv_quote(&e.text)
                );
            }
        }
        self.lines += 1;
        Ok(())
    }

    fn idle(&mut self) -> io::Result<()> {
        self.write_out()
    }

    fn take_lost(&mut self) -> u64 {
        std::mem::take(&mut self.lost)
    }

    fn flush(&mut self) -> io::Result<()> {
        self.write_out()?;
        self.file.flush()
    }

    fn finish(mut self: Box<Self>) -> io::Result<()> {
        self.write_out()?;
        self.file.flush()
    }
}

fn csv_quote(s: &str) -> String {
    format!("\"{}\"", s.replace('"', "\"\""))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn open(path: &std::path::Path, format: RecordFormat) -> Recorder {
        Recorder::open(
            &Recording {
                path: path.to_owned(),
                format,
            },
            Duration::from_millis(100),
        )
        .unwrap()
    }

    #[tokio::test]
    async fn csv_and_jsonl_lines() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("r.csv");
        let r = open(&path, RecordFormat::Csv);
        let t = Instant::now();
        r.line(t, 1, Dir::Tx, "poll", None, "0 0 0").unwrap();
        r.line(
            t,
            1,
            Dir::Rx,
            "poll",
            Some(Duration::from_micros(1500)),
            " 1040 \"x\"",
        )
        .unwrap();
        r.flush().await.unwrap();
        let text = std::fs::read_to_string(&path).unwrap();
        let lines: Vec<&str> = text.lines().collect();
        assert_eq!(lines[0], "t_s,session,dir,kind,rtt_ms,text");
        assert!(
            lines[1].starts_with("0.000000,0,event,start,,\"{\"\"started_utc\"\":\""),
            "{}",
            lines[1]
        );
        assert!(lines[2].ends_with(",1,tx,poll,,\"0 0 0\""), "{}", lines[2]);
        assert!(
            lines[3].ends_with(",1,rx,poll,1.500,\" 1040 \"\"x\"\"\""),
            "{}",
            lines[3]
        );
        drop(r);

        let path = dir.path().join("r.jsonl");
        let r = open(&path, RecordFormat::JsonLines);
        r.line(t, 2, Dir::Event, "connect", None, "x").unwrap();
        drop(r);
        let text = std::fs::read_to_string(&path).unwrap();
        let v: Vec<serde_json::Value> = text
            .lines()
            .map(|l| serde_json::from_str(l).unwrap())
            .collect();
        assert_eq!(v.len(), 2);
        let info: RecordingInfo = serde_json::from_str(v[0]["text"].as_str().unwrap()).unwrap();
        assert_eq!(info.late_reply_after_ms, 100.0);
        assert!(info.client.starts_with("fs020n-client "));
        assert_eq!(v[1]["dir"], "event");
        assert_eq!(v[1]["session"], 2);
        assert!(v[1]["rtt_ms"].is_null());
    }

    #[test]
    fn a_file_that_cannot_be_created_is_an_error_at_open() {
        let dir = tempfile::tempdir().unwrap();
        let e = Recorder::open(
            &Recording {
                path: dir.path().join("missing").join("r.csv"),
                format: RecordFormat::Csv,
            },
            Duration::from_millis(100),
        )
        .unwrap_err();
        assert!(matches!(e, ClientError::Recording { .. }), "{e}");
    }

    /// A sink that stalls until released, like a disk that stopped answering.
    struct Stalled {
        release: std::sync::Mutex<Receiver<()>>,
        written: Arc<AtomicU64>,
    }

    impl Sink for Stalled {
        fn entry(&mut self, _: &Entry) -> io::Result<()> {
            if self.written.load(Ordering::Relaxed) == 0 {
                let _ = self.release.lock().map(|r| r.recv());
            }
            self.written.fetch_add(1, Ordering::Relaxed);
            Ok(())
        }
        fn flush(&mut self) -> io::Result<()> {
            Ok(())
        }
        fn finish(self: Box<Self>) -> io::Result<()> {
            Ok(())
        }
    }

    #[test]
    fn a_stalled_sink_never_blocks_line_and_a_full_queue_counts_the_losses() {
        let (release, rx) = mpsc::channel();
        let written = Arc::new(AtomicU64::new(0));
        let r = Recorder::spawn(
            Box::new(Stalled {
                release: std::sync::Mutex::new(rx),
                written: written.clone(),
            }),
            Instant::now(),
            "stalled".into(),
        );
        // The writer takes the first line and at most a batch more, then stalls on the first.
        let extra = 1000;
        let total = RECORD_QUEUE_LINES + BATCH_LINES + 1 + extra;
        let mut lost = 0;
        for _ in 0..total {
            if let Err(n) = r.line(Instant::now(), 1, Dir::Tx, "poll", None, "0 0 0") {
                lost += n;
            }
        }
        let (lo, hi) = (extra as u64 + 1, (extra + 1 + BATCH_LINES) as u64);
        assert!((lo..=hi).contains(&lost), "lost {lost}");
        release.send(()).unwrap();
        drop(r);
        assert_eq!(written.load(Ordering::Relaxed) + lost, total as u64);
    }
}
