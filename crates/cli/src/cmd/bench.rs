//! `bench`: round-trip statistics of status polls.

use std::time::Instant;

use fs020n_client::Robot;

use crate::context::{close_quietly, connect, robot_or_embedded, runtime_one_thread, Ctx};
use crate::error::{client_error, CliError, CliResult};

/// Round-trip statistics of `count` status polls.
#[derive(Debug, Clone, serde::Serialize)]
pub(crate) struct BenchResult {
    /// Round trips.
    pub count: u32,
    /// Round trips per second.
    pub rate_hz: f64,
    /// Microseconds.
    pub rtt_us: RttUs,
}

/// Round-trip times in microseconds.
#[derive(Debug, Clone, serde::Serialize)]
pub(crate) struct RttUs {
    /// Fastest.
    pub min: f64,
    /// Mean.
    pub mean: f64,
    /// 99th percentile.
    pub p99: f64,
    /// Slowest.
    pub max: f64,
}

/// Measures `count` lock-step `0 0 0` polls.
pub(crate) async fn measure(robot: &Robot, count: u32) -> CliResult<BenchResult> {
    let mut rtts = Vec::with_capacity(count as usize);
    let start = Instant::now();
    for _ in 0..count {
        let t = Instant::now();
        robot.poll().await.map_err(client_error)?;
        rtts.push(t.elapsed().as_secs_f64() * 1e6);
    }
    let total = start.elapsed().as_secs_f64();
    rtts.sort_by(f64::total_cmp);
    let n = rtts.len().max(1);
    let p99 = rtts[((n as f64 * 0.99).ceil() as usize).clamp(1, n) - 1];
    Ok(BenchResult {
        count,
        rate_hz: f64::from(count) / total,
        rtt_us: RttUs {
            min: rtts[0],
            mean: rtts.iter().sum::<f64>() / n as f64,
            p99,
            max: rtts[n - 1],
        },
    })
}

/// `bench`: against `--robot`, or the embedded emulator when none is given.
pub(crate) fn bench(ctx: &Ctx, count: u32) -> CliResult {
    if count == 0 {
        return Err(CliError::input("--count must be at least 1"));
    }
    let rt = runtime_one_thread()?;
    rt.block_on(async {
        let (addr, embedded) = robot_or_embedded(ctx).await?;
        let robot = std::sync::Arc::new(connect(&addr, ctx).await?);
        // A task of the runtime, not the `block_on` future: waking it after each reply only
        // queues it (the `block_on` future's wake-up costs one more poll of the I/O driver).
        let r2 = robot.clone();
        let result = match tokio::spawn(async move { measure(&r2, count).await }).await {
            Ok(r) => r,
            Err(e) => Err(CliError::failure(format!("the benchmark task failed: {e}"))),
        };
        close_quietly(&robot).await;
        let r = result?;
        if ctx.json {
            println!("{}", serde_json::to_string(&r).unwrap_or_default());
        } else {
            println!(
                "{} lock-step status polls against {}{}: {:.0} per second",
                r.count,
                addr,
                if embedded.is_some() {
                    " (embedded emulator)"
                } else {
                    ""
                },
                r.rate_hz
            );
            println!(
                "round trip: min {:.1} µs, mean {:.1} µs, p99 {:.1} µs, max {:.1} µs",
                r.rtt_us.min, r.rtt_us.mean, r.rtt_us.p99, r.rtt_us.max
            );
        }
        Ok(())
    })
}
