//! Replay: a run's requests sent again, with their original timing, to a controller or an
//! emulator; every reply compared with the recorded one.
//!
//! Each recorded session is replayed on a connection of its own, strictly lock-step like the
//! client: the request bytes exactly as recorded (keep-alive polls included), each at its
//! original time after the first request of the run (later when a reply is slow: the lag is
//! reported). A session that ended with 255 waits for the server to close; one that ended
//! otherwise (link lost, recorder killed) is dropped after its last request.
//!
//! Compared per reply: the six joints (beyond a tolerance), the error number, the RUN/HOLD,
//! TEACH/REPEAT, TEACH LOCK and power switches and the program flag. The timer is not compared
//! (the two controllers started their clocks at different moments).

use std::collections::BTreeMap;
use std::future::Future;
use std::time::Duration;

use fs020n_proto::{ReplyDecoder, Status};
use serde::Serialize;
use tokio::io::{AsyncRead, AsyncReadExt, AsyncWrite, AsyncWriteExt};
use tokio::time::{sleep_until, timeout, timeout_at, Instant};

use crate::error::RecordError;
use crate::read::{Exchange, Run};

/// How to replay.
#[derive(Debug, Clone, PartialEq)]
pub struct ReplayOptions {
    /// A joint differing by more than this is a divergence, degrees. Default 1°: a reply taken a
    /// few milliseconds earlier or later during a fast move differs by a fraction of a degree.
    pub tolerance_deg: f64,
    /// Deadline of each reply. Default 1 s (below the controller's 2 s send timeout).
    pub reply_timeout: Duration,
    /// How long to keep trying to connect for each session (listen windows, the previous
    /// session closing). Default 10 s.
    pub connect_timeout: Duration,
    /// Divergent replies listed in detail (all are counted). Default 100.
    pub max_listed: usize,
}

impl Default for ReplayOptions {
    fn default() -> Self {
        ReplayOptions {
            tolerance_deg: 1.0,
            reply_timeout: Duration::from_secs(1),
            connect_timeout: Duration::from_secs(10),
            max_listed: 100,
        }
    }
}

/// One field of one reply that differs.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct FieldDiff {
    /// `joint 1`…`joint 6`, `error`, `run`, `repeat`, `teach_lock`, `power`, `program`, or
    /// `reply` (none came, or it could not be decoded).
    pub field: String,
    /// As recorded.
    pub recorded: String,
    /// As replayed.
    pub replayed: String,
}

/// A reply that differs from the recorded one.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Divergence {
    /// Session number in the recording.
    pub session: u64,
    /// Index of the exchange in [`Run::exchanges`].
    pub exchange: usize,
    /// When the request was sent in the recording, seconds since it started.
    pub t_s: f64,
    /// The request.
    pub request: String,
    /// What differs.
    pub fields: Vec<FieldDiff>,
}

/// What a replay found.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ReplayReport {
    /// Sessions replayed.
    pub sessions: usize,
    /// Requests sent.
    pub requests: usize,
    /// Replies compared with a recorded one.
    pub compared: usize,
    /// Replies that differ.
    pub divergent: usize,
    /// Divergent replies per field.
    pub by_field: BTreeMap<String, usize>,
    /// Largest joint difference over all compared replies, degrees (JT1..JT6).
    pub max_joint_diff_deg: [f64; 6],
    /// The first [`ReplayOptions::max_listed`] divergent replies.
    pub divergences: Vec<Divergence>,
    /// How far the replay fell behind the original timing at worst, seconds.
    pub max_lag_s: f64,
    /// The tolerance used, degrees.
    pub tolerance_deg: f64,
}

impl ReplayReport {
    /// `true` when every compared reply matched.
    pub fn matches(&self) -> bool {
        self.divergent == 0
    }
}

/// Compares a recorded reply with a replayed one.
pub fn compare(recorded: &Status, replayed: &Status, tolerance_deg: f64) -> Vec<FieldDiff> {
    let mut out = Vec::new();
    for j in 0..6 {
        let (a, b) = (recorded.joints[j], replayed.joints[j]);
        // A NaN on either side is a divergence too.
        let within = (a - b).abs() <= tolerance_deg;
        if !within {
            out.push(FieldDiff {
                field: format!("joint {}", j + 1),
                recorded: format!("{a:.3}"),
                replayed: format!("{b:.3}"),
            });
        }
    }
    if recorded.error != replayed.error {
        out.push(FieldDiff {
            field: "error".into(),
            recorded: recorded.error.to_string(),
            replayed: replayed.error.to_string(),
        });
    }
    for (field, a, b) in [
        ("run", recorded.run, replayed.run),
        ("repeat", recorded.repeat, replayed.repeat),
        ("teach_lock", recorded.teach_lock, replayed.teach_lock),
        ("power", recorded.power, replayed.power),
        ("program", recorded.task_running, replayed.task_running),
    ] {
        if a != b {
            out.push(FieldDiff {
                field: field.into(),
                recorded: a.to_string(),
                replayed: b.to_string(),
            });
        }
    }
    out
}

/// The state a controller must start in to replay `run`: the first recorded reply.
pub fn initial_status(run: &Run) -> Option<Status> {
    run.exchanges
        .iter()
        .filter_map(|e| e.reply.as_deref())
        .find_map(|r| Status::decode(r).ok())
}

/// Replays `run` over the connections `connect` makes (a TCP connection, an in-memory
/// emulator).
pub async fn replay<F, Fut, S>(
    run: &Run,
    connect: F,
    opts: &ReplayOptions,
) -> Result<ReplayReport, RecordError>
where
    F: Fn() -> Fut,
    Fut: Future<Output = std::io::Result<S>>,
    S: AsyncRead + AsyncWrite + Unpin,
{
    if !(opts.tolerance_deg.is_finite() && opts.tolerance_deg >= 0.0) {
        return Err(RecordError::Options(format!(
            "tolerance {} deg: give a number of degrees of 0 or more",
            opts.tolerance_deg
        )));
    }
    let sent: Vec<(usize, &Exchange)> = run
        .exchanges
        .iter()
        .enumerate()
        .filter(|(_, e)| !e.request.is_empty())
        .collect();
    let Some(first) = sent.first() else {
        return Err(RecordError::Empty(
            "the recording holds no requests (a status CSV of `fs020n record` cannot be \
             replayed: record with a .mcap, .csv or .jsonl file through the client)"
                .into(),
        ));
    };
    let origin_s = first.1.sent_s;
    let mut sessions: Vec<(u64, Vec<(usize, &Exchange)>)> = Vec::new();
    for (i, e) in sent {
        match sessions.last_mut() {
            Some((s, list)) if *s == e.session => list.push((i, e)),
            _ => sessions.push((e.session, vec![(i, e)])),
        }
    }
    let mut report = ReplayReport {
        sessions: sessions.len(),
        requests: 0,
        compared: 0,
        divergent: 0,
        by_field: BTreeMap::new(),
        max_joint_diff_deg: [0.0; 6],
        divergences: Vec::new(),
        max_lag_s: 0.0,
        tolerance_deg: opts.tolerance_deg,
    };
    let mut start: Option<Instant> = None;
    for (session, list) in sessions {
        replay_session(
            session,
            &list,
            origin_s,
            &mut start,
            &connect,
            opts,
            &mut report,
        )
        .await?;
    }
    Ok(report)
}

async fn replay_session<F, Fut, S>(
    session: u64,
    list: &[(usize, &Exchange)],
    origin_s: f64,
    start: &mut Option<Instant>,
    connect: &F,
    opts: &ReplayOptions,
    report: &mut ReplayReport,
) -> Result<(), RecordError>
where
    F: Fn() -> Fut,
    Fut: Future<Output = std::io::Result<S>>,
    S: AsyncRead + AsyncWrite + Unpin,
{
    let due = |start: Option<Instant>, t_s: f64| {
        start.map(|s| s + Duration::from_secs_f64((t_s - origin_s).max(0.0)))
    };
    if let Some(at) = due(*start, list[0].1.sent_s) {
        sleep_until(at).await;
    }
    let mut conn = connect_with_retry(connect, opts.connect_timeout).await?;
    let mut decoder = ReplyDecoder::new();
    let mut buf = vec![0u8; 1024];
    let last_closes = list.last().is_some_and(|(_, e)| e.kind == "close");
    for &(index, e) in list {
        if let Some(at) = due(*start, e.sent_s) {
            let now = Instant::now();
            if now > at {
                report.max_lag_s = report.max_lag_s.max((now - at).as_secs_f64());
            }
            sleep_until(at).await;
        }
        let sent_at = Instant::now();
        start.get_or_insert(sent_at);
        report.requests += 1;
        let got = exchange(
            &mut conn,
            &mut decoder,
            &mut buf,
            &e.request,
            opts.reply_timeout,
        )
        .await;
        let recorded = e.reply.as_deref().map(Status::decode);
        let mut fields = Vec::new();
        let mut lost = false;
        match (&recorded, &got) {
            (None, _) => {} // The recording has no reply to compare with.
            (Some(Err(_)), _) => {}
            (Some(Ok(rec)), Ok(rep)) => {
                report.compared += 1;
                for (j, m) in report.max_joint_diff_deg.iter_mut().enumerate() {
                    let d = (rec.joints[j] - rep.joints[j]).abs();
                    if d.is_finite() {
                        *m = m.max(d);
                    }
                }
                fields = compare(rec, rep, opts.tolerance_deg);
            }
            (Some(Ok(_)), Err(why)) => {
                report.compared += 1;
                lost = true;
                fields.push(FieldDiff {
                    field: "reply".into(),
                    recorded: e.reply.clone().unwrap_or_default(),
                    replayed: why.clone(),
                });
            }
        }
        if got.is_err() {
            lost = true;
        }
        if !fields.is_empty() {
            report.divergent += 1;
            for f in &fields {
                *report.by_field.entry(f.field.clone()).or_default() += 1;
            }
            if report.divergences.len() < opts.max_listed {
                report.divergences.push(Divergence {
                    session,
                    exchange: index,
                    t_s: e.sent_s,
                    request: e.request.clone(),
                    fields,
                });
            }
        }
        if lost {
            // No reply: this connection is over (as the client would have found).
            return Ok(());
        }
    }
    if last_closes {
        // After 255 the server closes the connection; wait for it (bounded).
        let _ = timeout(Duration::from_secs(2), async {
            loop {
                match conn.read(&mut buf).await {
                    Ok(0) | Err(_) => break,
                    Ok(_) => {}
                }
            }
        })
        .await;
    }
    Ok(())
}

async fn connect_with_retry<F, Fut, S>(connect: &F, limit: Duration) -> Result<S, RecordError>
where
    F: Fn() -> Fut,
    Fut: Future<Output = std::io::Result<S>>,
{
    let deadline = Instant::now() + limit;
    loop {
        let err = match timeout_at(deadline, connect()).await {
            Ok(Ok(s)) => return Ok(s),
            Ok(Err(e)) => e.to_string(),
            Err(_) => "the connection attempt did not complete in time".to_owned(),
        };
        if Instant::now() + Duration::from_millis(50) >= deadline {
            return Err(RecordError::Replay(format!(
                "cannot connect within {limit:?}: {err} (is the controller or emulator \
                 running and free?)"
            )));
        }
        tokio::time::sleep(Duration::from_millis(50)).await;
    }
}

/// Writes `request` in one write and reads one complete reply.
async fn exchange<S: AsyncRead + AsyncWrite + Unpin>(
    conn: &mut S,
    decoder: &mut ReplyDecoder,
    buf: &mut [u8],
    request: &str,
    reply_timeout: Duration,
) -> Result<Status, String> {
    let deadline = Instant::now() + reply_timeout;
    timeout_at(deadline, conn.write_all(request.as_bytes()))
        .await
        .map_err(|_| "write timed out".to_owned())?
        .map_err(|e| format!("write failed: {e}"))?;
    loop {
        match decoder.next_reply() {
            Ok(Some(frame)) => return Ok(frame.status),
            Ok(None) => {}
            Err(e) => return Err(format!("undecodable reply: {e}")),
        }
        let n = timeout_at(deadline, conn.read(buf))
            .await
            .map_err(|_| format!("no reply within {reply_timeout:?}"))?
            .map_err(|e| format!("read failed: {e}"))?;
        if n == 0 {
            return Err("the connection was closed".into());
        }
        decoder
            .push(&buf[..n])
            .map_err(|e| format!("undecodable reply: {e}"))?;
    }
}

/// Replays over TCP to `addr` (`HOST:PORT`).
pub async fn replay_tcp(
    run: &Run,
    addr: &str,
    opts: &ReplayOptions,
) -> Result<ReplayReport, RecordError> {
    let addr = addr.to_owned();
    replay(
        run,
        || {
            let addr = addr.clone();
            async move {
                let s = tokio::net::TcpStream::connect(addr.as_str()).await?;
                s.set_nodelay(true)?;
                Ok(s)
            }
        },
        opts,
    )
    .await
}
