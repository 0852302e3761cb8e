//! Benchmark of an online servo loop in Rust: the push rate and jitter a plain thread achieves
//! against an emulator in the same process over loopback TCP (real time). The Python package's
//! examples hold its twin, servo_bench.py (docs/PYTHON.md); both print the same JSON figures,
//! one line per rate.
//!
//! ```sh
//! cargo run --release -p fs020n-client --example servo_bench -- --rate 125 --rate 500 --rate 1000 --seconds 10
//! ```
//!
//! For each rate the loop sleeps until the next tick (`std::thread::sleep`), computes a sine
//! sample and pushes it ([`ServoHandle::push`] never waits for the network).

use std::net::SocketAddr;
use std::time::{Duration, Instant};

use fs020n_client::{ClientConfig, JointsDeg, Robot, ServoOptions, ServoSample};
use fs020n_sim::{run_robot, SimOptions};

fn percentile(v: &[f64], q: f64) -> f64 {
    let mut s = v.to_vec();
    s.sort_by(f64::total_cmp);
    let rank = ((q * s.len() as f64).ceil() as usize).clamp(1, s.len());
    s[rank - 1]
}

fn mean(v: &[f64]) -> f64 {
    v.iter().sum::<f64>() / v.len() as f64
}

fn run(
    rt: &tokio::runtime::Runtime,
    address: &str,
    rate: f64,
    seconds: f64,
) -> Result<serde_json::Value, Box<dyn std::error::Error>> {
    let robot = rt.block_on(Robot::connect(address, ClientConfig::default()))?;
    rt.block_on(robot.set_speed(100.0))?;
    rt.block_on(robot.start())?;
    let home = rt.block_on(robot.poll())?.joints;
    let servo = rt.block_on(robot.servo(ServoOptions {
        watchdog: Duration::from_millis(500),
        ..ServoOptions::default()
    }))?;
    let period = Duration::from_secs_f64(1.0 / rate);
    let n = (seconds * rate).round() as usize;
    let w = 2.0 * std::f64::consts::PI / 4.0;
    let (mut stamps, mut lateness, mut costs) = (Vec::new(), Vec::new(), Vec::new());
    let t0 = Instant::now() + Duration::from_millis(10);
    for k in 0..n {
        let tick = t0 + period * u32::try_from(k)?;
        let now = Instant::now();
        if tick > now {
            std::thread::sleep(tick - now);
        }
        let t = Instant::now();
        let x = t.saturating_duration_since(t0).as_secs_f64();
        let mut q = home;
        q[0] += 5.0 * (w * x).sin();
        let mut qd = JointsDeg::ZERO;
        qd[0] = 5.0 * w * (w * x).cos();
        servo.push(ServoSample::new(q).with_velocity(qd))?;
        let done = Instant::now();
        stamps.push(t);
        lateness.push(t.saturating_duration_since(tick).as_secs_f64());
        costs.push(done.duration_since(t).as_secs_f64());
    }
    let report = rt.block_on(servo.finish())?;
    rt.block_on(robot.close())?;
    let intervals: Vec<f64> = stamps
        .windows(2)
        .map(|w| w[1].duration_since(w[0]).as_secs_f64())
        .collect();
    let m = mean(&intervals);
    let sd =
        (intervals.iter().map(|v| (v - m).powi(2)).sum::<f64>() / intervals.len() as f64).sqrt();
    let span = stamps[n - 1].duration_since(stamps[0]).as_secs_f64();
    let us = 1e6;
    let r1 = |v: f64| (v * 10.0).round() / 10.0;
    let st = report.stats;
    Ok(serde_json::json!({
        "client": "rust",
        "target_hz": rate,
        "pushes": n,
        "achieved_hz": r1((n - 1) as f64 / span),
        "late_mean_us": r1(mean(&lateness) * us),
        "late_p99_us": r1(percentile(&lateness, 0.99) * us),
        "late_max_us": r1(lateness.iter().copied().fold(0.0, f64::max) * us),
        "interval_sd_us": r1(sd * us),
        "push_mean_us": (mean(&costs) * us * 100.0).round() / 100.0,
        "push_p99_us": (percentile(&costs, 0.99) * us * 100.0).round() / 100.0,
        "sent": st.sent,
        "coalesced": st.coalesced,
        "unsent": st.unsent,
        "push_to_send_mean_us": r1(st.push_to_send_mean.as_secs_f64() * us),
        "push_to_send_max_us": r1(st.push_to_send_max.as_secs_f64() * us),
        "rtt_mean_us": r1(st.rtt_mean.as_secs_f64() * us),
        "tracking_rms_deg": (st.tracking_error_rms_deg * 1e4).round() / 1e4,
    }))
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut rates = Vec::new();
    let mut seconds: f64 = 10.0;
    let mut robot: Option<String> = None;
    let mut args = std::env::args().skip(1);
    while let Some(a) = args.next() {
        let mut value = || args.next().ok_or(format!("{a} needs a value"));
        match a.as_str() {
            "--rate" => rates.push(value()?.parse::<f64>()?),
            "--seconds" => seconds = value()?.parse()?,
            "--robot" => robot = Some(value()?),
            other => {
                return Err(format!(
                    "unknown argument {other}; use --rate HZ (repeatable), --seconds S, --robot HOST:PORT"
                )
                .into())
            }
        }
    }
    if rates.is_empty() {
        rates = vec![125.0, 500.0, 1000.0];
    }
    if !(seconds.is_finite() && seconds > 0.0)
        || rates.iter().any(|r| !(*r > 0.0 && *r <= 10_000.0))
    {
        return Err("--seconds must be above 0 and --rate from 0 to 10000".into());
    }
    // Two workers, like the Python package's runtime.
    let rt = tokio::runtime::Builder::new_multi_thread()
        .worker_threads(2)
        .enable_all()
        .build()?;
    let (address, emulator) = match robot {
        Some(a) => (a, None),
        None => {
            let e = rt.block_on(run_robot(
                SimOptions::default().listen(SocketAddr::from(([127, 0, 0, 1], 0))),
            ))?;
            (e.robot_addr().to_string(), Some(e))
        }
    };
    for rate in rates {
        println!("{}", run(&rt, &address, rate, seconds)?);
        // Let the stopped program end before the next session starts it again.
        std::thread::sleep(Duration::from_millis(300));
    }
    if let Some(e) = emulator {
        let _guard = rt.enter();
        e.stop();
    }
    Ok(())
}
