//! Fleet load generator: one lock-step client per emulated robot, each polling its robot at a
//! fixed rate, reporting reply latency percentiles, the achieved rate and every error.
//!
//! Start the robots in one process, then the load in another:
//!
//! ```text
//! fs020n --json sim --robots 1000 --threads 1 --listen 127.0.0.1:20000 > robots.jsonl &
//! cargo run --release -p fs020n-sim --example fleet_load -- \
//!     --robots 1000 --base 127.0.0.1:20000 --rate 100 --duration 30 --sim-pid $!
//! ```
//!
//! `--list robots.jsonl` takes the addresses from `fs020n --json sim` instead (one JSON object
//! per line with a `"listen"` address, e.g. when the robots listen on port 0).
//!
//! Each client connects (retrying through the controller's listen gaps), then sends the
//! side-effect-free poll `0 0 0` every 1/rate seconds (phases spread evenly over the period) and
//! reads until one complete reply has arrived (framed by its 14 fields and final blank, checked
//! for the version field, and one in 64 decoded in full). The latency of a poll is from just before
//! its `write` to the complete reply. A poll that cannot be sent on time because the previous
//! reply came late is sent at once and the period restarts from it (the achieved rate shows
//! such lateness). Errors: a connection that cannot be made within `--connect-timeout`, a
//! reply not received within `--timeout-ms`, a closed or reset connection, an undecodable reply;
//! after an error the client reconnects.
//!
//! With `--sim-pid` the emulator process's CPU time (user + system, from `/proc`) over the
//! measurement is reported too, as a share of one core and per reply: on a shared machine these
//! are steadier than the latencies. The load generator's own CPU time is reported likewise.
//! Prints a JSON summary (`--json`) or a short table.

use std::net::SocketAddr;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::Duration;

use tokio::io::{AsyncReadExt, AsyncWriteExt};
use tokio::net::TcpStream;
use tokio::time::{sleep_until, timeout, Instant};

const USAGE: &str = "usage: fleet_load (--base HOST:PORT --robots N | --list FILE) \
[--rate HZ=100] [--duration S=30] [--warmup S=2] [--timeout-ms MS=1000] \
[--connect-timeout S=15] [--threads N=1] [--sim-pid PID] [--request TEXT='0 0 0'] [--json]";

struct Options {
    addrs: Vec<SocketAddr>,
    rate: f64,
    duration: Duration,
    warmup: Duration,
    reply_timeout: Duration,
    connect_timeout: Duration,
    threads: usize,
    sim_pid: Option<u32>,
    request: Vec<u8>,
    json: bool,
}

fn fail(msg: impl std::fmt::Display) -> ! {
    eprintln!("fleet_load: {msg}\n{USAGE}");
    std::process::exit(2)
}

fn parse_options() -> Options {
    let mut base: Option<SocketAddr> = None;
    let mut robots: Option<usize> = None;
    let mut list: Option<String> = None;
    let mut o = Options {
        addrs: Vec::new(),
        rate: 100.0,
        duration: Duration::from_secs(30),
        warmup: Duration::from_secs(2),
        reply_timeout: Duration::from_millis(1000),
        connect_timeout: Duration::from_secs(15),
        threads: 1,
        sim_pid: None,
        request: b"0 0 0".to_vec(),
        json: false,
    };
    let mut args = std::env::args().skip(1);
    while let Some(flag) = args.next() {
        if flag == "--json" {
            o.json = true;
            continue;
        }
        if flag == "-h" || flag == "--help" {
            println!("{USAGE}");
            std::process::exit(0);
        }
        let value = args
            .next()
            .unwrap_or_else(|| fail(format!("{flag} needs a value")));
        let num = |v: &str| -> f64 {
            v.parse::<f64>()
                .ok()
                .filter(|x| x.is_finite() && *x >= 0.0)
                .unwrap_or_else(|| fail(format!("{flag} {v}: expected a number >= 0")))
        };
        match flag.as_str() {
            "--base" => {
                base = Some(
                    value
                        .parse()
                        .unwrap_or_else(|e| fail(format!("--base {value}: {e}"))),
                )
            }
            "--robots" => robots = Some(num(&value) as usize),
            "--list" => list = Some(value),
            "--rate" => o.rate = num(&value),
            "--duration" => o.duration = Duration::from_secs_f64(num(&value)),
            "--warmup" => o.warmup = Duration::from_secs_f64(num(&value)),
            "--timeout-ms" => o.reply_timeout = Duration::from_secs_f64(num(&value) / 1e3),
            "--connect-timeout" => o.connect_timeout = Duration::from_secs_f64(num(&value)),
            "--threads" => o.threads = (num(&value) as usize).max(1),
            "--sim-pid" => o.sim_pid = Some(num(&value) as u32),
            "--request" => o.request = value.into_bytes(),
            _ => fail(format!("unknown option {flag}")),
        }
    }
    if !(o.rate > 0.0 && o.rate <= 10_000.0) {
        fail("--rate must be above 0 and at most 10000 Hz");
    }
    o.addrs = match (base, list) {
        (Some(base), None) => {
            let n = robots.unwrap_or_else(|| fail("--base needs --robots N"));
            (0..n)
                .map(|i| {
                    let port = usize::from(base.port()) + i;
                    let port = u16::try_from(port)
                        .unwrap_or_else(|_| fail(format!("port {port} is beyond 65535")));
                    SocketAddr::new(base.ip(), port)
                })
                .collect()
        }
        (None, Some(path)) => {
            let text = std::fs::read_to_string(&path)
                .unwrap_or_else(|e| fail(format!("--list {path}: {e}")));
            let mut addrs: Vec<SocketAddr> = text
                .lines()
                .filter(|l| !l.trim().is_empty())
                .map(|l| {
                    let v: serde_json::Value = serde_json::from_str(l)
                        .unwrap_or_else(|e| fail(format!("--list {path}: {e} in {l:?}")));
                    v["listen"]
                        .as_str()
                        .and_then(|a| a.parse().ok())
                        .unwrap_or_else(|| fail(format!("--list {path}: no \"listen\" in {l:?}")))
                })
                .collect();
            if let Some(n) = robots {
                addrs.truncate(n);
            }
            addrs
        }
        _ => fail("give either --base with --robots, or --list"),
    };
    if o.addrs.is_empty() {
        fail("no robots");
    }
    o
}

/// What one client measured.
#[derive(Default)]
struct ClientReport {
    /// Reply latencies within the measurement window, microseconds.
    latencies_us: Vec<u32>,
    /// Polls sent within the window.
    sent: u64,
    connect_failures: u64,
    timeouts: u64,
    disconnects: u64,
    bad_replies: u64,
    reconnects: u64,
}

impl ClientReport {
    fn errors(&self) -> u64 {
        self.connect_failures + self.timeouts + self.disconnects + self.bad_replies
    }
}

async fn connect(addr: SocketAddr, within: Duration) -> Option<TcpStream> {
    let deadline = Instant::now() + within;
    loop {
        if let Ok(Ok(s)) = timeout(Duration::from_secs(3), TcpStream::connect(addr)).await {
            let _ = s.set_nodelay(true);
            return Some(s);
        }
        // Refused: between two listen windows (or not yet listening).
        if Instant::now() + Duration::from_millis(50) > deadline {
            return None;
        }
        tokio::time::sleep(Duration::from_millis(50)).await;
    }
}

enum Exchange {
    Reply,
    Timeout,
    Closed,
    Bad,
}

/// Frames lock-step replies cheaply: a reply is complete once 14 fields (runs of non-blank
/// bytes) have arrived and the last byte is a blank (the controller ends every reply with one).
/// Every reply must start with the version field `1040`; one reply in [`FULL_DECODE_EVERY`] is
/// also decoded in full with [`Status::decode`] (the emulator formats every reply the same way,
/// so a sample catches a malformed one without paying the full decoder on each).
#[derive(Default)]
struct Framer {
    pending: Vec<u8>,
    count: u64,
}

/// One reply in this many is decoded in full.
const FULL_DECODE_EVERY: u64 = 64;

impl Framer {
    /// Takes received bytes: `Some(true)` a complete good reply, `Some(false)` a bad one,
    /// `None` incomplete.
    fn push(&mut self, bytes: &[u8]) -> Option<bool> {
        self.pending.extend_from_slice(bytes);
        let p = &self.pending;
        if p.last() != Some(&b' ') {
            return (p.len() > 512).then_some(false);
        }
        let mut fields = 0;
        let mut in_field = false;
        for &c in p {
            let blank = c == b' ';
            if !blank && !in_field {
                fields += 1;
            }
            in_field = !blank;
        }
        if fields < 14 {
            return (p.len() > 512).then_some(false);
        }
        self.count += 1;
        let text = std::str::from_utf8(p).unwrap_or("");
        let mut good = fields == 14 && text.split_ascii_whitespace().next() == Some("1040");
        if good && self.count % FULL_DECODE_EVERY == 1 {
            good = fs020n_proto::Status::decode(text).is_ok();
        }
        self.pending.clear();
        Some(good)
    }
}

async fn exchange(
    stream: &mut TcpStream,
    request: &[u8],
    framer: &mut Framer,
    buf: &mut [u8],
) -> Exchange {
    if stream.write_all(request).await.is_err() {
        return Exchange::Closed;
    }
    loop {
        let n = match stream.read(buf).await {
            Ok(0) | Err(_) => return Exchange::Closed,
            Ok(n) => n,
        };
        match framer.push(&buf[..n]) {
            Some(true) => return Exchange::Reply,
            Some(false) => return Exchange::Bad,
            None => {}
        }
    }
}

#[allow(clippy::too_many_arguments)]
async fn client(
    addr: SocketAddr,
    first: Instant,
    period: Duration,
    window: (Instant, Instant),
    o: Arc<Options>,
    stop: Arc<AtomicBool>,
) -> ClientReport {
    let mut r = ClientReport {
        latencies_us: Vec::with_capacity((o.rate * o.duration.as_secs_f64() * 1.05) as usize + 16),
        ..ClientReport::default()
    };
    let mut buf = vec![0u8; 4096];
    let mut next = first;
    'session: while !stop.load(Ordering::Relaxed) && Instant::now() < window.1 {
        let Some(mut stream) = connect(addr, o.connect_timeout).await else {
            r.connect_failures += 1;
            continue;
        };
        let mut framer = Framer::default();
        loop {
            sleep_until(next).await;
            if stop.load(Ordering::Relaxed) || Instant::now() >= window.1 {
                break 'session;
            }
            let t0 = Instant::now();
            let in_window = t0 >= window.0;
            let outcome = timeout(
                o.reply_timeout,
                exchange(&mut stream, &o.request, &mut framer, &mut buf),
            )
            .await
            .unwrap_or(Exchange::Timeout);
            let done = Instant::now();
            if in_window {
                r.sent += 1;
            }
            match outcome {
                Exchange::Reply => {
                    if in_window {
                        let us = (done - t0).as_micros().min(u128::from(u32::MAX)) as u32;
                        r.latencies_us.push(us);
                    }
                }
                Exchange::Timeout => r.timeouts += 1,
                Exchange::Closed => r.disconnects += 1,
                Exchange::Bad => r.bad_replies += 1,
            }
            next += period;
            if next < done {
                // Late: send the next poll at once and restart the period from it.
                next = done;
            }
            if !matches!(outcome, Exchange::Reply) {
                r.reconnects += 1;
                continue 'session;
            }
        }
    }
    r
}

/// User + system CPU time of a process, seconds (Linux `/proc/PID/stat`, clock ticks of
/// 1/100 s).
fn process_cpu_s(pid: &str) -> Option<f64> {
    let stat = std::fs::read_to_string(format!("/proc/{pid}/stat")).ok()?;
    // Fields after the command name (which is in parentheses and may contain blanks).
    let rest = &stat[stat.rfind(')')? + 2..];
    let f: Vec<&str> = rest.split_whitespace().collect();
    let utime: f64 = f.get(11)?.parse().ok()?;
    let stime: f64 = f.get(12)?.parse().ok()?;
    Some((utime + stime) / 100.0)
}

fn loadavg() -> String {
    std::fs::read_to_string("/proc/loadavg")
        .map(|s| s.split_whitespace().take(3).collect::<Vec<_>>().join(" "))
        .unwrap_or_else(|_| "?".to_owned())
}

fn percentile(sorted: &[u32], p: f64) -> f64 {
    if sorted.is_empty() {
        return f64::NAN;
    }
    let i = ((sorted.len() as f64 - 1.0) * p).round() as usize;
    f64::from(sorted[i.min(sorted.len() - 1)]) / 1000.0
}

fn main() {
    let o = Arc::new(parse_options());
    let rt = if o.threads == 1 {
        tokio::runtime::Builder::new_current_thread()
            .enable_all()
            .build()
    } else {
        tokio::runtime::Builder::new_multi_thread()
            .worker_threads(o.threads)
            .enable_all()
            .build()
    };
    let rt = rt.unwrap_or_else(|e| fail(format!("cannot start the runtime: {e}")));
    let n = o.addrs.len();
    let period = Duration::from_secs_f64(1.0 / o.rate);
    let load_before = loadavg();
    let (reports, wall, sim_cpu, own_cpu) = rt.block_on(async {
        let stop = Arc::new(AtomicBool::new(false));
        // Connections and the first polls are spread over the connect phase; every client
        // has its own phase within the period.
        let start = Instant::now() + Duration::from_millis(200);
        let window_start = start + o.warmup;
        let window_end = window_start + o.duration;
        let mut tasks = Vec::with_capacity(n);
        for (i, &addr) in o.addrs.iter().enumerate() {
            let phase = period.mul_f64(i as f64 / n as f64);
            tasks.push(tokio::spawn(client(
                addr,
                start + phase,
                period,
                (window_start, window_end),
                o.clone(),
                stop.clone(),
            )));
        }
        sleep_until(window_start).await;
        let sim0 = o.sim_pid.and_then(|p| process_cpu_s(&p.to_string()));
        let own0 = process_cpu_s("self");
        let t0 = std::time::Instant::now();
        sleep_until(window_end).await;
        let wall = t0.elapsed().as_secs_f64();
        let sim1 = o.sim_pid.and_then(|p| process_cpu_s(&p.to_string()));
        let own1 = process_cpu_s("self");
        stop.store(true, Ordering::Relaxed);
        let mut reports = Vec::with_capacity(n);
        for t in tasks {
            match tokio::time::timeout(o.reply_timeout + Duration::from_secs(5), t).await {
                Ok(Ok(r)) => reports.push(r),
                _ => reports.push(ClientReport {
                    timeouts: 1,
                    ..ClientReport::default()
                }),
            }
        }
        let diff = |a: Option<f64>, b: Option<f64>| a.zip(b).map(|(a, b)| b - a);
        (reports, wall, diff(sim0, sim1), diff(own0, own1))
    });
    let load_after = loadavg();
    let mut all: Vec<u32> = Vec::with_capacity(reports.iter().map(|r| r.latencies_us.len()).sum());
    for r in &reports {
        all.extend_from_slice(&r.latencies_us);
    }
    all.sort_unstable();
    let sent: u64 = reports.iter().map(|r| r.sent).sum();
    let replies = all.len() as u64;
    let errors: u64 = reports.iter().map(ClientReport::errors).sum();
    let sum = |f: fn(&ClientReport) -> u64| reports.iter().map(f).sum::<u64>();
    let expected = o.rate * wall * n as f64;
    let achieved = replies as f64 / wall;
    let per_reply_us = |cpu: Option<f64>| cpu.map(|c| c / replies.max(1) as f64 * 1e6);
    let summary = serde_json::json!({
        "robots": n,
        "rate_hz": o.rate,
        "duration_s": wall,
        "polls_sent": sent,
        "replies": replies,
        "replies_per_s": achieved,
        "rate_achieved_percent": 100.0 * replies as f64 / expected.max(1.0),
        "latency_ms": {
            "p50": percentile(&all, 0.50),
            "p90": percentile(&all, 0.90),
            "p99": percentile(&all, 0.99),
            "p99_9": percentile(&all, 0.999),
            "max": all.last().map_or(f64::NAN, |&v| f64::from(v) / 1000.0),
        },
        "errors": errors,
        "connect_failures": sum(|r| r.connect_failures),
        "timeouts": sum(|r| r.timeouts),
        "disconnects": sum(|r| r.disconnects),
        "bad_replies": sum(|r| r.bad_replies),
        "reconnects": sum(|r| r.reconnects),
        "emulator_cpu_percent_of_a_core": sim_cpu.map(|c| 100.0 * c / wall),
        "emulator_cpu_us_per_reply": per_reply_us(sim_cpu),
        "load_generator_cpu_percent_of_a_core": own_cpu.map(|c| 100.0 * c / wall),
        "load_generator_cpu_us_per_reply": per_reply_us(own_cpu),
        "load_average_before": load_before,
        "load_average_after": load_after,
    });
    if o.json {
        println!("{summary}");
        return;
    }
    let lat = &summary["latency_ms"];
    println!(
        "{n} robots at {} Hz for {wall:.1} s: {replies} replies ({achieved:.0}/s, {:.1} % of the \
         rate), {errors} errors",
        o.rate, summary["rate_achieved_percent"]
    );
    println!(
        "latency ms: p50 {:.3}  p90 {:.3}  p99 {:.3}  p99.9 {:.3}  max {:.3}",
        lat["p50"], lat["p90"], lat["p99"], lat["p99_9"], lat["max"]
    );
    println!(
        "errors: {} connect, {} timeouts, {} disconnects, {} bad replies",
        summary["connect_failures"],
        summary["timeouts"],
        summary["disconnects"],
        summary["bad_replies"]
    );
    if let Some(c) = sim_cpu {
        println!(
            "emulator CPU: {:.0} % of a core, {:.1} µs per reply",
            100.0 * c / wall,
            c / replies.max(1) as f64 * 1e6
        );
    }
    if let Some(c) = own_cpu {
        println!(
            "load generator CPU: {:.0} % of a core, {:.1} µs per reply",
            100.0 * c / wall,
            c / replies.max(1) as f64 * 1e6
        );
    }
    println!("load average before {load_before}, after {load_after}");
}
