//! Commands that talk to a robot: status, speed, move, play, record, raw, bench.

use std::io::Write;
use std::time::{Duration, Instant};

use fs020n_client::{
    ClientError, Completion, Robot, StreamMode, StreamOptions, StreamOutcome, StreamReport,
    Trajectory, TrajectoryPoint,
};
use fs020n_proto::server::ServerRequest;
use fs020n_proto::{Status, Timer};
use indicatif::{ProgressBar, ProgressStyle};
use serde_json::json;

use crate::args::{MoveArgs, PlayArgs, PlayMode};
use crate::error::{CliError, CliResult, Exit};
use crate::output::{joints_json, status_json, status_table};
use crate::session::{
    check_speed, check_target, check_timeout, client_error, close_quietly, connect,
    robot_or_embedded, runtime, Ctx, Interrupt, MAX_TIMEOUT_S,
};
use crate::trajectory_file;

fn interrupted() -> CliError {
    CliError::new(
        Exit::Interrupted,
        "interrupted: motion cancelled and the session closed",
    )
}

/// Runs `body` in a session with the robot and always ends the session cleanly (255). The body
/// gets the Ctrl-C flag.
fn with_robot<T>(
    ctx: &Ctx,
    body: impl AsyncFnOnce(&Robot, &Interrupt) -> CliResult<T>,
) -> CliResult<T> {
    let rt = runtime()?;
    rt.block_on(async {
        let stop = Interrupt::install();
        let robot = connect(&ctx.addr_or_default(), ctx).await?;
        let result = body(&robot, &stop).await;
        close_quietly(&robot).await;
        result
    })
}

fn bar(len: u64, template: &str) -> ProgressBar {
    let pb = ProgressBar::new(len);
    if let Ok(style) = ProgressStyle::with_template(template) {
        pb.set_style(style.progress_chars("=> "));
    }
    pb
}

/// Lowest sampling rate of `status --watch` and `record`, Hz.
pub const MIN_RATE_HZ: f64 = 0.01;

/// `status`.
pub fn status(ctx: &Ctx, watch: bool, rate: f64) -> CliResult {
    if watch && !(rate.is_finite() && (MIN_RATE_HZ..=100.0).contains(&rate)) {
        return Err(CliError::input(format!(
            "--rate must be from {MIN_RATE_HZ} to 100 Hz"
        )));
    }
    with_robot(ctx, async |robot: &Robot, stop: &Interrupt| {
        let s = robot.poll().await.map_err(client_error)?;
        print_status(&s, ctx.json, false)?;
        if !watch {
            return Ok(());
        }
        let mut tick = tokio::time::interval(Duration::from_secs_f64(1.0 / rate));
        loop {
            let s = tokio::select! {
                _ = stop.wait() => return Ok(()),
                s = async {
                    tick.tick().await;
                    robot.poll().await
                } => s.map_err(client_error)?,
            };
            match print_status(&s, ctx.json, true) {
                // The reader went away (e.g. `| head`): a normal end.
                Err(e) if e.kind() == std::io::ErrorKind::BrokenPipe => return Ok(()),
                r => r?,
            }
        }
    })
}

fn print_status(s: &Status, as_json: bool, redraw: bool) -> std::io::Result<()> {
    let mut out = std::io::stdout().lock();
    if as_json {
        writeln!(out, "{}", status_json(s))?;
    } else {
        if redraw {
            // Clear the screen and go home.
            write!(out, "\x1b[2J\x1b[H")?;
        }
        write!(out, "{}", status_table(s))?;
        if redraw {
            writeln!(out, "(Ctrl-C to stop)")?;
        }
    }
    out.flush()
}

/// `speed`.
pub fn speed(ctx: &Ctx, percent: f64) -> CliResult {
    let percent = check_speed(percent)?;
    with_robot(ctx, async |robot: &Robot, _stop: &Interrupt| {
        robot.set_speed(percent).await.map_err(client_error)?;
        if ctx.json {
            println!("{}", json!({ "speed_percent": percent }));
        } else {
            println!("monitor speed set to {percent} % (it stays set in the controller)");
        }
        Ok(())
    })
}

/// Largest `--tolerance` of `move`, degrees.
pub const MAX_TOLERANCE_DEG: f64 = 5.0;

/// `move`: preflight, start, move, wait, close — in one session (the controller stops the
/// robot when the session ends, so the command always waits for the motion to finish).
pub fn move_joints(ctx: &Ctx, args: &MoveArgs) -> CliResult {
    let target = check_target(&ctx.model, &args.joints)?;
    let speed = args.speed.map(check_speed).transpose()?;
    if !(args.tolerance.is_finite() && args.tolerance > 0.0 && args.tolerance <= MAX_TOLERANCE_DEG)
    {
        return Err(CliError::input(format!(
            "--tolerance must be above 0 and at most {MAX_TOLERANCE_DEG} degrees (the session \
             end stops the arm where it is, so it must really be at the target)"
        )));
    }
    let timeout = args.timeout.map(check_timeout).transpose()?;
    with_robot(ctx, async |robot: &Robot, stop: &Interrupt| {
        robot.preflight().await.map_err(client_error)?;
        if let Some(p) = speed {
            robot.set_speed(p).await.map_err(client_error)?;
        }
        robot.start().await.map_err(client_error)?;
        let handle = robot.move_joints(target).await.map_err(client_error)?;
        let planned = handle.planned_duration();
        let timeout = timeout.unwrap_or(planned * 2 + Duration::from_secs(5));
        let completion = Completion {
            tolerance_deg: args.tolerance,
            settle: Duration::from_millis(100),
            timeout: Some(timeout),
        };
        let pb = if args.wait && !ctx.json {
            bar(1000, "{spinner} moving [{bar:40}] {percent:>3}% {msg}")
        } else {
            ProgressBar::hidden()
        };
        let wait = handle.wait(completion);
        tokio::pin!(wait);
        let mut tick = tokio::time::interval(Duration::from_millis(100));
        let report = loop {
            tokio::select! {
                r = &mut wait => break r,
                _ = tick.tick() => {
                    if let Some(p) = handle.progress() {
                        pb.set_position((p.fraction.clamp(0.0, 1.0) * 1000.0) as u64);
                        pb.set_message(format!("{:.2} deg to go", p.remaining_deg));
                    }
                }
                _ = stop.wait() => {
                    pb.abandon_with_message("cancelled");
                    let _ = handle.cancel().await;
                    return Err(interrupted());
                }
            }
        };
        pb.finish_and_clear();
        let report = report.map_err(client_error)?;
        if ctx.json {
            println!(
                "{}",
                json!({
                    "target_deg": joints_json(&target),
                    "final_deg": joints_json(&report.final_joints),
                    "error_deg": report.error_deg,
                    "elapsed_s": report.elapsed.as_secs_f64(),
                })
            );
        } else {
            println!(
                "reached {} in {:.2} s (largest joint error {:.4} deg)",
                report.final_joints,
                report.elapsed.as_secs_f64(),
                report.error_deg
            );
        }
        Ok(())
    })
}

/// Converts file points to the client's trajectory type.
fn to_trajectory(points: &[trajectory_file::FilePoint]) -> CliResult<Trajectory> {
    Trajectory::new(
        points
            .iter()
            .map(|p| TrajectoryPoint {
                time_s: p.time_s,
                position: p.position,
                velocity: p.velocity,
                acceleration: p.acceleration,
            })
            .collect(),
    )
    .map_err(|e| CliError::input(format!("trajectory refused: {e}")))
}

/// `play`: everything that can be checked is checked before connecting; then the start
/// position before anything is sent that acts; then preflight, speed, start, (approach), stream.
pub fn play(ctx: &Ctx, args: &PlayArgs, approach: bool) -> CliResult {
    let speed = check_speed(args.speed)?;
    if !(args.rate.is_finite() && args.rate >= MIN_PLAY_RATE_HZ && args.rate <= MAX_PLAY_RATE_HZ) {
        return Err(CliError::input(format!(
            "--rate must be from {MIN_PLAY_RATE_HZ} to {MAX_PLAY_RATE_HZ} Hz"
        )));
    }
    let points = trajectory_file::load(&args.file, &ctx.model)?;
    let trajectory = to_trajectory(&points)?;
    let defaults = StreamOptions::default();
    let period = Duration::from_secs_f64(1.0 / args.rate);
    let options = StreamOptions {
        mode: match args.mode {
            PlayMode::Stream => defaults.mode,
            PlayMode::Waypoints => StreamMode::Waypoints,
        },
        period,
        // A gap of two periods (at least the default) before the stream counts as starved.
        max_gap: defaults.max_gap.max(period * 2),
        ..defaults
    };
    let checked = match options.mode {
        StreamMode::Extrapolated { lookahead_passes } => trajectory.validate_extrapolated(
            &ctx.model,
            period.as_secs_f64(),
            options.max_step_deg,
            lookahead_passes,
        ),
        StreamMode::Waypoints => {
            trajectory.validate(&ctx.model, period.as_secs_f64(), options.max_step_deg)
        }
    };
    checked.map_err(|e| CliError::input(format!("{}: {e}", args.file.display())))?;
    with_robot(ctx, async |robot: &Robot, stop: &Interrupt| {
        let first = trajectory.first();
        let here = robot.poll().await.map_err(client_error)?.joints;
        let away = here.max_abs_diff(&first) > options.start_tolerance_deg;
        if away && !approach {
            return Err(CliError::input(format!(
                "the robot is at {here} but the trajectory starts at {first}; move there first \
                 (fs020n move …) or add --approach to do it with a joint move at --speed ({speed} %)"
            )));
        }
        robot.preflight().await.map_err(client_error)?;
        robot.set_speed(speed).await.map_err(client_error)?;
        robot.start().await.map_err(client_error)?;
        if away {
            let h = robot.move_joints(first).await.map_err(client_error)?;
            let timeout = h.planned_duration() * 2 + Duration::from_secs(5);
            tokio::select! {
                r = h.wait(Completion { timeout: Some(timeout), ..Completion::default() }) => {
                    r.map_err(client_error)?;
                }
                _ = stop.wait() => {
                    let _ = h.cancel().await;
                    return Err(interrupted());
                }
            }
        }
        let handle = robot
            .stream(trajectory, options)
            .await
            .map_err(client_error)?;
        let pb = if ctx.json {
            ProgressBar::hidden()
        } else {
            bar(1000, "{spinner} playing [{bar:40}] {percent:>3}% {msg}")
        };
        let mut tick = tokio::time::interval(Duration::from_millis(100));
        loop {
            tokio::select! {
                _ = tick.tick() => {
                    let p = handle.progress();
                    pb.set_position((p.fraction.clamp(0.0, 1.0) * 1000.0) as u64);
                    pb.set_message(format!("t = {:.2} s, tracking error max {:.3} deg", p.time_s, p.tracking_error_max_deg));
                    if handle.is_finished() {
                        break;
                    }
                }
                _ = stop.wait() => {
                    pb.abandon_with_message("cancelled");
                    handle.cancel();
                    let _ = robot.cancel().await;
                    return Err(interrupted());
                }
            }
        }
        pb.finish_and_clear();
        let report = handle.wait().await.map_err(client_error)?;
        print_stream_report(&report, ctx.json);
        if report.outcome != StreamOutcome::Completed {
            return Err(CliError::new(Exit::Motion, "the stream did not complete"));
        }
        Ok(())
    })
}

/// Lowest `play --rate`, Hz (the client allows at most 500 ms between samples).
pub const MIN_PLAY_RATE_HZ: f64 = 4.0;
/// Highest `play --rate`, Hz.
pub const MAX_PLAY_RATE_HZ: f64 = 500.0;

/// A stream report as JSON, durations in seconds.
pub fn stream_report_json(r: &StreamReport) -> serde_json::Value {
    json!({
        "outcome": r.outcome,
        "samples_sent": r.samples_sent,
        "late_replies": r.late_replies,
        "underruns": r.underruns,
        "tracking_error_max_deg": r.tracking_error_max_deg,
        "tracking_error_rms_deg": r.tracking_error_rms_deg,
        "tracking_samples": r.tracking_samples,
        "final_error_deg": r.final_error_deg,
        "settled": r.settled,
        "duration_s": r.duration.as_secs_f64(),
        "rtt_mean_s": r.rtt_mean.as_secs_f64(),
        "rtt_max_s": r.rtt_max.as_secs_f64(),
        "lag_s": r.lag_s,
        "lead_s": r.lead_s,
    })
}

/// Prints a stream report.
pub fn print_stream_report(r: &StreamReport, as_json: bool) {
    if as_json {
        println!("{}", stream_report_json(r));
        return;
    }
    println!(
        "stream {}: {} samples in {:.2} s; tracking error max {:.3} deg, rms {:.3} deg, lag {}, lead {:.0} ms; final error {:.3} deg ({}); late replies {}, underruns {}; round trip mean {:.2} ms, max {:.2} ms",
        match r.outcome {
            StreamOutcome::Completed => "completed",
            StreamOutcome::Cancelled => "cancelled",
        },
        r.samples_sent,
        r.duration.as_secs_f64(),
        r.tracking_error_max_deg,
        r.tracking_error_rms_deg,
        r.lag_s
            .map_or_else(|| "n/a".to_owned(), |l| format!("{:.0} ms", l * 1e3)),
        r.lead_s * 1e3,
        r.final_error_deg,
        if r.settled { "settled" } else { "not settled" },
        r.late_replies,
        r.underruns,
        r.rtt_mean.as_secs_f64() * 1e3,
        r.rtt_max.as_secs_f64() * 1e3,
    );
}

/// `record`.
pub fn record(ctx: &Ctx, file: &std::path::Path, rate: f64, duration: Option<f64>) -> CliResult {
    if !(rate.is_finite() && (MIN_RATE_HZ..=1000.0).contains(&rate)) {
        return Err(CliError::input(format!(
            "--rate must be from {MIN_RATE_HZ} to 1000 Hz"
        )));
    }
    if let Some(d) = duration {
        if !(d.is_finite() && d > 0.0 && d <= MAX_TIMEOUT_S) {
            return Err(CliError::input(format!(
                "--duration must be above 0 and at most {MAX_TIMEOUT_S} s"
            )));
        }
    }
    let mut out = std::io::BufWriter::new(
        std::fs::File::create(file)
            .map_err(|e| CliError::input(format!("cannot create {}: {e}", file.display())))?,
    );
    with_robot(ctx, async |robot: &Robot, stop: &Interrupt| {
        writeln!(out, "time_s,timer_s,error_code,error,run,repeat,teach_lock,power,task_running,j1,j2,j3,j4,j5,j6")?;
        let start = Instant::now();
        let end = duration.map(|d| start + Duration::from_secs_f64(d));
        let mut tick = tokio::time::interval(Duration::from_secs_f64(1.0 / rate));
        let mut rows = 0u64;
        loop {
            let s = tokio::select! {
                _ = stop.wait() => break,
                s = async {
                    tick.tick().await;
                    robot.poll().await
                } => s.map_err(client_error)?,
            };
            if end.is_some_and(|e| Instant::now() >= e) {
                break;
            }
            let t = start.elapsed().as_secs_f64();
            let timer = match s.timer {
                Timer::Seconds(v) => format!("{v:.3}"),
                Timer::Overflow => String::new(),
            };
            let b = |v: bool| if v { "1" } else { "0" };
            let error = if s.error.is_none() {
                String::new()
            } else {
                s.error.to_string()
            };
            let j = s.joints.values();
            writeln!(
                out,
                "{t:.4},{timer},{},{error},{},{},{},{},{},{:.3},{:.3},{:.3},{:.3},{:.3},{:.3}",
                s.error.raw(),
                b(s.run),
                b(s.repeat),
                b(s.teach_lock),
                b(s.power),
                b(s.task_running),
                j[0],
                j[1],
                j[2],
                j[3],
                j[4],
                j[5]
            )?;
            out.flush()?;
            rows += 1;
        }
        if ctx.json {
            println!(
                "{}",
                json!({ "rows": rows, "file": file.display().to_string() })
            );
        } else {
            println!("recorded {rows} row(s) to {}", file.display());
        }
        Ok(())
    })
}

/// `raw`.
pub fn raw(ctx: &Ctx, text: &str, yes: bool) -> CliResult {
    with_robot(ctx, async |robot: &Robot, _stop: &Interrupt| {
        let frame = robot.send_raw(text, yes).await.map_err(|e| {
            let request = ServerRequest::parse(text.as_bytes());
            let motion = request.version_matches() && request.command().is_motion();
            match e {
                ClientError::RawRefused { .. } if motion && !yes => CliError::input(format!(
                    "{text:?} is a motion command (the controller would move the robot); add --yes to send it"
                )),
                e => client_error(e),
            }
        })?;
        if ctx.json {
            println!(
                "{}",
                json!({ "request": text, "reply": frame.text, "decoded": status_json(&frame.status) })
            );
        } else {
            println!("request  {text:?}");
            println!("reply    {:?}", frame.text);
            print!("{}", status_table(&frame.status));
        }
        Ok(())
    })
}

/// Round-trip statistics of `count` status polls.
#[derive(Debug, Clone, serde::Serialize)]
pub struct BenchResult {
    /// Round trips.
    pub count: u32,
    /// Round trips per second.
    pub rate_hz: f64,
    /// Microseconds.
    pub rtt_us: RttUs,
}

/// Round-trip times in microseconds.
#[derive(Debug, Clone, serde::Serialize)]
pub struct RttUs {
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
pub async fn measure(robot: &Robot, count: u32) -> CliResult<BenchResult> {
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
pub fn bench(ctx: &Ctx, count: u32) -> CliResult {
    if count == 0 {
        return Err(CliError::input("--count must be at least 1"));
    }
    let rt = runtime()?;
    rt.block_on(async {
        let (addr, embedded) = robot_or_embedded(ctx).await?;
        let robot = connect(&addr, ctx).await?;
        let result = measure(&robot, count).await;
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
