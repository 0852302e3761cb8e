//! Emulator speed on virtual time: one robot streaming command 7 at 100 Hz for a number of
//! simulated seconds, on the `Controller` directly (the workload of the `emulator` bench's
//! `stream_100hz` group). Prints simulated seconds per wall second.
//!
//! ```text
//! cargo run --release -p fs020n-sim --example stream_speed -- [SECONDS] [MONITOR_PERCENT]
//! ```
//!
//! Wall-clock figures are noisy on a shared machine; for repeatable figures count instructions
//! (docs/PERFORMANCE.md, "## Emulator"):
//! `valgrind --tool=callgrind target/release/examples/stream_speed 10`.

use std::time::Instant;

#[path = "../benches/streamer/mod.rs"]
mod streamer;

fn main() {
    let mut args = std::env::args().skip(1);
    let seconds: u32 = args.next().and_then(|s| s.parse().ok()).unwrap_or(50);
    let monitor: f64 = args.next().and_then(|s| s.parse().ok()).unwrap_or(100.0);
    let mut s = streamer::Streamer::new(monitor, false);
    let t = Instant::now();
    for _ in 0..seconds {
        s.second();
    }
    let wall = t.elapsed().as_secs_f64();
    let counters = s.c.counters();
    println!(
        "{seconds} simulated s at monitor {monitor} %: {:.0} simulated s per wall s \
         ({} requests, {} passes, {} motions; joints at the end {:?})",
        f64::from(seconds) / wall,
        counters.requests,
        counters.passes,
        counters.motions,
        s.c.joints().0
    );
}
