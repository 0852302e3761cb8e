//! Emulator speed on virtual time: one robot streaming command 7 at 100 Hz for a number of
//! simulated seconds, on the `Controller` directly (the workload of the `emulator` bench's
//! `stream_100hz` group). Prints simulated seconds per wall second, and per second of this
//! thread's CPU time (Linux: `/proc/thread-self/schedstat`), which a busy shared machine
//! disturbs much less than the wall clock, twice: for the whole workload (the bench builds
//! each request when it is due, then the emulator handles it), and for the emulator alone (a
//! fresh controller replays the requests recorded beforehand, untimed).
//!
//! ```text
//! cargo run --release -p fs020n-sim --example stream_speed -- [SECONDS] [MONITOR_PERCENT]
//! ```
//!
//! For repeatable figures count instructions (docs/PERFORMANCE.md, "## Emulator"):
//! `valgrind --tool=callgrind target/release/examples/stream_speed 10`, then
//! `callgrind_annotate --inclusive=yes` (`Streamer::second` is the whole workload,
//! `Replay::run` the emulator alone). The final joints are printed in full so that two builds
//! can be checked to compute exactly the same motion; the replay's must be the same bits.

use std::time::Instant;

#[path = "../benches/streamer/mod.rs"]
mod streamer;

/// CPU time of this thread so far, nanoseconds (Linux), if known.
fn thread_cpu_ns() -> Option<u64> {
    let text = std::fs::read_to_string("/proc/thread-self/schedstat").ok()?;
    text.split_whitespace().next()?.parse().ok()
}

/// Runs `work` and returns (simulated s per wall s, per CPU s as text).
fn timed(seconds: u32, work: impl FnOnce()) -> (f64, String) {
    let cpu0 = thread_cpu_ns();
    let t = Instant::now();
    work();
    let wall = t.elapsed().as_secs_f64();
    let cpu = match (cpu0, thread_cpu_ns()) {
        (Some(a), Some(b)) if b > a => {
            format!("{:.0}", f64::from(seconds) / ((b - a) as f64 * 1e-9))
        }
        _ => "?".to_owned(),
    };
    (f64::from(seconds) / wall, cpu)
}

fn main() {
    let mut args = std::env::args().skip(1);
    let seconds: u32 = args.next().and_then(|s| s.parse().ok()).unwrap_or(50);
    let monitor: f64 = args.next().and_then(|s| s.parse().ok()).unwrap_or(100.0);
    let mut s = streamer::Streamer::new(monitor, false);
    let (wall, cpu) = timed(seconds, || {
        for _ in 0..seconds {
            s.second();
        }
    });
    let counters = s.c.counters();
    println!(
        "{seconds} simulated s at monitor {monitor} %, whole workload: {wall:.0} simulated s \
         per wall s, {cpu} per CPU s ({} requests, {} passes, {} motions; joints at the end \
         {:?})",
        counters.requests,
        counters.passes,
        counters.motions,
        s.c.joints().0
    );
    let requests = streamer::record(monitor, seconds);
    let mut r = streamer::Replay::new(monitor);
    let (wall, cpu) = timed(seconds, || r.run(&requests));
    let same = streamer::same_bits(&r.c.joints(), &s.c.joints());
    println!(
        "{seconds} simulated s at monitor {monitor} %, emulator alone: {wall:.0} simulated s \
         per wall s, {cpu} per CPU s (the same joints at the end, bit for bit: {same})"
    );
    assert!(same, "the replay computed another motion");
}
