//! Commands that talk to a robot: status, speed, move, play, record, raw, bench.

use std::io::{IsTerminal, Write};
use std::path::Path;
use std::time::{Duration, Instant};

use fs020n_client::{
    Completion, Robot, StreamMode, StreamOptions, StreamOutcome, StreamReport, Trajectory,
    TrajectoryPoint,
};
use fs020n_kin::{Pose, Xyzoat};
use fs020n_proto::{JointsDeg, Status, Timer};
use indicatif::{ProgressBar, ProgressStyle};
use serde_json::json;

use crate::args::{MoveArgs, PlayArgs, PlayMode, RecordArgs};
use crate::error::{CliError, CliResult, Exit};
use crate::linear;
use crate::output::{
    flange_pose, joints_json, pose_json, pose_line, robot_status_json, robot_status_table,
    status_table,
};
use crate::session::{
    check_speed, check_target, check_timeout, client_error, close_quietly, connect, describe,
    robot_or_embedded, rounded, runtime, runtime_one_thread, Ctx, Interrupt, Place, MAX_TIMEOUT_S,
};
use crate::trajectory_file;

fn interrupted() -> CliError {
    CliError::new(
        Exit::Interrupted,
        "interrupted: motion cancelled and the session closed",
    )
}

/// Runs `body` in a session with the robot and always ends the session cleanly (255). The body
/// gets the Ctrl-C flag; Ctrl-C while connecting gives up at once.
fn with_robot<T>(
    ctx: &Ctx,
    body: impl AsyncFnOnce(&Robot, &Interrupt) -> CliResult<T>,
) -> CliResult<T> {
    with_robot_on(runtime()?, ctx, body)
}

/// [`with_robot`] on a given runtime.
fn with_robot_on<T>(
    rt: tokio::runtime::Runtime,
    ctx: &Ctx,
    body: impl AsyncFnOnce(&Robot, &Interrupt) -> CliResult<T>,
) -> CliResult<T> {
    rt.block_on(async {
        let stop = Interrupt::install();
        let addr = ctx.addr_or_default();
        let robot = tokio::select! {
            r = connect(&addr, ctx) => r?,
            () = stop.wait() => {
                return Err(CliError::new(
                    Exit::Interrupted,
                    "interrupted while connecting; nothing was sent",
                ))
            }
        };
        let result = body(&robot, &stop).await;
        close_quietly(&robot).await;
        result
    })
}

fn bar(ctx: &Ctx, show: bool, len: u64, template: &str) -> ProgressBar {
    if !show || ctx.json {
        return ProgressBar::hidden();
    }
    let pb = ProgressBar::new(len);
    if let Ok(style) = ProgressStyle::with_template(template) {
        pb.set_style(style.progress_chars("=> "));
    }
    pb
}

/// Says when the controller holds the motion and when it goes on: above the progress bar, or
/// as a line on stderr (not with `--json`, whose stderr is for the error object).
struct HoldNotice {
    held: bool,
    limit: Option<Duration>,
    json: bool,
}

impl HoldNotice {
    fn new(ctx: &Ctx, limit: Option<Duration>) -> HoldNotice {
        HoldNotice {
            held: false,
            limit,
            json: ctx.json,
        }
    }

    fn update(&mut self, held: bool, pb: &ProgressBar) {
        if held == self.held {
            return;
        }
        self.held = held;
        let line = match (held, self.limit) {
            (true, Some(limit)) => format!(
                "held — switch RUN/HOLD to RUN to resume (waiting up to {})",
                rounded(limit)
            ),
            (true, None) => "held — switch RUN/HOLD to RUN to resume".to_owned(),
            (false, _) => "resumed".to_owned(),
        };
        if !pb.is_hidden() {
            pb.println(line);
        } else if !self.json {
            eprintln!("{line}");
        }
    }
}

/// Checks `--hold-timeout` (seconds): 0 means fail at once (`None`).
fn hold_limit(seconds: f64) -> CliResult<Option<Duration>> {
    if !(seconds.is_finite() && (0.0..=MAX_TIMEOUT_S).contains(&seconds)) {
        return Err(CliError::input(format!(
            "--hold-timeout {seconds} must be from 0 to {MAX_TIMEOUT_S} s"
        )));
    }
    Ok((seconds > 0.0).then(|| Duration::from_secs_f64(seconds)))
}

/// Lowest sampling rate of `status --watch` and `record`, Hz.
pub(crate) const MIN_RATE_HZ: f64 = 0.01;

/// `status`.
pub(crate) fn status(ctx: &Ctx, watch: bool, rate: f64) -> CliResult {
    if watch && !(rate.is_finite() && (MIN_RATE_HZ..=100.0).contains(&rate)) {
        return Err(CliError::input(format!(
            "--rate must be from {MIN_RATE_HZ} to 100 Hz"
        )));
    }
    let redraw = watch && std::io::stdout().is_terminal();
    with_robot(ctx, async |robot: &Robot, stop: &Interrupt| {
        let s = robot.poll().await.map_err(client_error)?;
        print_status(ctx, &s, redraw)?;
        if !watch {
            return Ok(());
        }
        let mut tick = tokio::time::interval(Duration::from_secs_f64(1.0 / rate));
        loop {
            let s = tokio::select! {
                () = stop.wait() => {
                    return Err(CliError::new(Exit::Interrupted, "stopped by Ctrl-C; the session is closed"));
                }
                s = async {
                    tick.tick().await;
                    robot.poll().await
                } => s.map_err(client_error)?,
            };
            match print_status(ctx, &s, redraw) {
                // The reader went away (e.g. `| head`): a normal end.
                Err(e) if e.kind() == std::io::ErrorKind::BrokenPipe => return Ok(()),
                r => r?,
            }
        }
    })
}

fn print_status(ctx: &Ctx, s: &Status, redraw: bool) -> std::io::Result<()> {
    let mut out = std::io::stdout().lock();
    if ctx.json {
        writeln!(out, "{}", robot_status_json(s, &ctx.model))?;
    } else {
        if redraw {
            // Clear the screen and go home (only on a terminal).
            write!(out, "\x1b[2J\x1b[H")?;
        }
        write!(out, "{}", robot_status_table(s, &ctx.model))?;
        if redraw {
            writeln!(out, "(Ctrl-C to stop)")?;
        }
    }
    out.flush()
}

/// `speed`.
pub(crate) fn speed(ctx: &Ctx, percent: f64) -> CliResult {
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
pub(crate) const MAX_TOLERANCE_DEG: f64 = 5.0;

/// Default pace of `move --linear`, percent of the joints' top speeds.
pub(crate) const DEFAULT_LINEAR_PACE_PERCENT: f64 = 10.0;

/// What a `move` goes to.
enum Goal {
    Joints(JointsDeg),
    Pose(Xyzoat),
}

/// `move`: preflight, start, move, wait, close — in one session (the controller stops the
/// robot when the session ends, so the command always waits for the motion to finish).
pub(crate) fn move_cmd(ctx: &Ctx, args: &MoveArgs) -> CliResult {
    let speed = args.speed.map(check_speed).transpose()?;
    if !(args.tolerance.is_finite() && args.tolerance > 0.0 && args.tolerance <= MAX_TOLERANCE_DEG)
    {
        return Err(CliError::input(format!(
            "--tolerance must be above 0 and at most {MAX_TOLERANCE_DEG} degrees (the session \
             end stops the arm where it is, so it must really be at the target)"
        )));
    }
    let timeout = args.timeout.map(check_timeout).transpose()?;
    let hold = hold_limit(args.hold_timeout)?;
    let goal = match &args.pose {
        None => Goal::Joints(check_target(
            &ctx.model,
            &args.joints,
            " before connecting",
        )?),
        Some(v) => Goal::Pose(check_pose(ctx, v)?),
    };
    match goal {
        Goal::Joints(target) => with_robot(ctx, async |robot: &Robot, stop: &Interrupt| {
            let plan = JointPlan {
                target,
                pose: None,
                speed,
                tolerance: args.tolerance,
                timeout,
                hold,
                bar: args.wait,
            };
            joint_move(ctx, robot, stop, &plan).await
        }),
        Goal::Pose(xyzoat) if args.linear => {
            let pace = speed.unwrap_or(DEFAULT_LINEAR_PACE_PERCENT) / 100.0;
            with_robot(ctx, async |robot: &Robot, stop: &Interrupt| {
                linear_move(ctx, robot, stop, xyzoat, pace, hold, args.wait).await
            })
        }
        Goal::Pose(xyzoat) => with_robot(ctx, async |robot: &Robot, stop: &Interrupt| {
            // The solution nearest the joints the robot has now; checked before anything acts.
            let here = robot.poll().await.map_err(client_error)?.joints;
            let target = ctx
                .model
                .inverse_nearest(&Pose::from_xyzoat(xyzoat), &here.to_rad())
                .map_err(|e| {
                    CliError::input(format!(
                        "no joint solution for the pose inside the joint ranges: {e}; nothing \
                         was sent"
                    ))
                })?
                .to_deg();
            check_target(&ctx.model, &target.values(), "; nothing was sent")?;
            let plan = JointPlan {
                target,
                pose: Some(xyzoat),
                speed,
                tolerance: args.tolerance,
                timeout,
                hold,
                bar: args.wait,
            };
            joint_move(ctx, robot, stop, &plan).await
        }),
    }
}

/// A `--pose` argument: six finite numbers of a pose with at least one joint solution inside
/// the ranges (checked before connecting).
fn check_pose(ctx: &Ctx, v: &[f64]) -> CliResult<Xyzoat> {
    let [x, y, z, o, a, t]: [f64; 6] = v
        .try_into()
        .map_err(|_| CliError::input("--pose takes six numbers: X Y Z (mm) O A T (deg)"))?;
    let p = Xyzoat::new(x, y, z, o, a, t);
    if !p.is_finite() {
        return Err(CliError::input("--pose values must be finite numbers"));
    }
    ctx.model.inverse_all(&Pose::from_xyzoat(p)).map_err(|e| {
        CliError::input(format!(
            "pose refused before connecting: no joint solution inside the joint ranges: {e}"
        ))
        .with_remedy("choose a reachable pose (`fs020n ik X Y Z O A T` lists its solutions)")
    })?;
    Ok(p)
}

/// A joint move as the user asked for it.
struct JointPlan {
    target: JointsDeg,
    pose: Option<Xyzoat>,
    speed: Option<f64>,
    tolerance: f64,
    timeout: Option<Duration>,
    hold: Option<Duration>,
    bar: bool,
}

async fn joint_move(ctx: &Ctx, robot: &Robot, stop: &Interrupt, plan: &JointPlan) -> CliResult {
    robot.preflight().await.map_err(client_error)?;
    if let Some(p) = plan.speed {
        robot.set_speed(p).await.map_err(client_error)?;
    }
    robot.start().await.map_err(client_error)?;
    let handle = robot.move_joints(plan.target).await.map_err(client_error)?;
    let planned = handle.planned_duration();
    let completion = Completion {
        tolerance_deg: plan.tolerance,
        settle: Duration::from_millis(100),
        timeout: Some(plan.timeout.unwrap_or(planned * 2 + Duration::from_secs(5))),
        hold_timeout: plan.hold,
    };
    let pb = bar(
        ctx,
        plan.bar,
        1000,
        "{spinner} moving [{bar:40}] {percent:>3}% {msg}",
    );
    let mut notice = HoldNotice::new(ctx, plan.hold);
    let wait = handle.wait(completion);
    tokio::pin!(wait);
    let mut tick = tokio::time::interval(Duration::from_millis(100));
    let report = loop {
        tokio::select! {
            r = &mut wait => break r,
            _ = tick.tick() => {
                if let Some(p) = handle.progress() {
                    notice.update(p.held, &pb);
                    pb.set_position((p.fraction.clamp(0.0, 1.0) * 1000.0) as u64);
                    pb.set_message(format!("{:.2} deg to go", p.remaining_deg));
                }
            }
            () = stop.wait() => {
                pb.abandon_with_message("cancelled");
                let _ = handle.cancel().await;
                return Err(interrupted());
            }
        }
    };
    pb.finish_and_clear();
    let report = report.map_err(client_error)?;
    let final_pose = flange_pose(&ctx.model, &report.final_joints);
    if ctx.json {
        let mut v = json!({
            "target_deg": joints_json(&plan.target),
            "final_deg": joints_json(&report.final_joints),
            "error_deg": report.error_deg,
            "elapsed_s": report.elapsed.as_secs_f64(),
        });
        if let Some(p) = &plan.pose {
            v["target_pose"] = pose_json(p);
            v["final_pose"] = pose_json(&final_pose);
        }
        println!("{v}");
    } else {
        println!(
            "reached {} in {:.2} s (largest joint error {:.4} deg)",
            report.final_joints,
            report.elapsed.as_secs_f64(),
            report.error_deg
        );
        if plan.pose.is_some() {
            println!("flange at {}", pose_line(&final_pose));
        }
    }
    Ok(())
}

/// `move --pose … --linear`: the line from the current pose is planned and checked after a
/// status poll and before anything that acts; then preflight, speed 100 %, start, stream.
async fn linear_move(
    ctx: &Ctx,
    robot: &Robot,
    stop: &Interrupt,
    target: Xyzoat,
    pace: f64,
    hold: Option<Duration>,
    show_bar: bool,
) -> CliResult {
    let here = robot.poll().await.map_err(client_error)?.joints;
    let trajectory = linear::line(&ctx.model, here, &Pose::from_xyzoat(target), pace)?;
    let options = StreamOptions {
        hold_timeout: hold,
        // A move promises arrival: settle as tightly as a joint move's completion does.
        end_tolerance_deg: fs020n_client::Completion::default().tolerance_deg,
        // The path matters here, not the timing: a lead extrapolates along the joint-space
        // velocity, which leaves a Cartesian line by millimetres.
        lag_compensation: fs020n_client::LagCompensation::Off,
        ..StreamOptions::default()
    };
    options
        .validate(&ctx.model, &trajectory)
        .map_err(|e| CliError::input(format!("the straight line is refused: {e}")))?;
    robot.preflight().await.map_err(client_error)?;
    // Command 7 moves in 0.1 s segments scaled by the monitor speed: stream at 100 %.
    robot.set_speed(100.0).await.map_err(client_error)?;
    robot.start().await.map_err(client_error)?;
    let end = trajectory.last();
    let report = stream(ctx, robot, stop, trajectory, options, show_bar).await?;
    let final_joints = robot.poll().await.map_err(client_error)?.joints;
    let final_pose = flange_pose(&ctx.model, &final_joints);
    if ctx.json {
        println!(
            "{}",
            json!({
                "target_deg": joints_json(&end),
                "final_deg": joints_json(&final_joints),
                "error_deg": final_joints.max_abs_diff(&end),
                "elapsed_s": report.duration.as_secs_f64(),
                "target_pose": pose_json(&target),
                "final_pose": pose_json(&final_pose),
                "stream": stream_report_json(&report),
            })
        );
    } else {
        print_stream_report(&report, false);
        println!("flange at {}", pose_line(&final_pose));
    }
    Ok(())
}

/// Streams `trajectory` with a progress bar (when `show_bar`), HOLD notices and Ctrl-C;
/// fails unless the stream completes.
async fn stream(
    ctx: &Ctx,
    robot: &Robot,
    stop: &Interrupt,
    trajectory: Trajectory,
    options: StreamOptions,
    show_bar: bool,
) -> CliResult<StreamReport> {
    let handle = robot
        .stream(trajectory, options)
        .await
        .map_err(client_error)?;
    let pb = bar(
        ctx,
        show_bar,
        1000,
        "{spinner} playing [{bar:40}] {percent:>3}% {msg}",
    );
    let mut notice = HoldNotice::new(ctx, options.hold_timeout);
    let wait = handle.wait();
    tokio::pin!(wait);
    let mut tick = tokio::time::interval(Duration::from_millis(100));
    let report = loop {
        tokio::select! {
            r = &mut wait => break r,
            _ = tick.tick() => {
                let p = handle.progress();
                notice.update(p.held, &pb);
                pb.set_position((p.fraction.clamp(0.0, 1.0) * 1000.0) as u64);
                pb.set_message(format!("t = {:.2} s, tracking error max {:.3} deg", p.time_s, p.tracking_error_max_deg));
            }
            () = stop.wait() => {
                pb.abandon_with_message("cancelled");
                let _ = handle.cancel().await;
                return Err(interrupted());
            }
        }
    };
    pb.finish_and_clear();
    let report = report.map_err(client_error)?;
    if report.outcome != StreamOutcome::Completed {
        print_stream_report(&report, ctx.json);
        return Err(CliError::new(Exit::Motion, "the stream did not complete"));
    }
    Ok(report)
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
pub(crate) fn play(ctx: &Ctx, args: &PlayArgs) -> CliResult {
    let speed = check_speed(args.speed)?;
    if !(args.rate.is_finite() && args.rate >= MIN_PLAY_RATE_HZ && args.rate <= MAX_PLAY_RATE_HZ) {
        return Err(CliError::input(format!(
            "--rate must be from {MIN_PLAY_RATE_HZ} to {MAX_PLAY_RATE_HZ} Hz"
        )));
    }
    let hold = hold_limit(args.hold_timeout)?;
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
        hold_timeout: hold,
        ..defaults
    };
    // The same check the client makes before it sends (rate, ranges, speeds, steps, and for
    // command 7 every target the controller can extrapolate to).
    options.validate(&ctx.model, &trajectory).map_err(|e| {
        let e = CliError::input(format!("{}: {e}", args.file.display()));
        match e.message.contains("steps") {
            true => e.with_remedy("slow the trajectory down, or play it at a higher --rate"),
            false => e,
        }
    })?;
    // One thread: the stream's pacing, its round trips and the keep-alive task share it, so a
    // sample wakes no other thread (docs/PERFORMANCE.md, "Client").
    with_robot_on(
        runtime_one_thread()?,
        ctx,
        async |robot: &Robot, stop: &Interrupt| {
            let first = trajectory.first();
            let here = robot.poll().await.map_err(client_error)?.joints;
            let away = here.max_abs_diff(&first) > options.start_tolerance_deg;
            if away && !args.approach {
                return Err(CliError::input(format!(
                    "the robot is at {here} but the trajectory starts at {first}; nothing was sent"
                ))
                .with_remedy(format!(
                "move there first (fs020n move …), or add --approach to do it with a joint move \
                 at --speed ({speed} %)"
            )));
            }
            robot.preflight().await.map_err(client_error)?;
            robot.set_speed(speed).await.map_err(client_error)?;
            robot.start().await.map_err(client_error)?;
            if away {
                let h = robot.move_joints(first).await.map_err(client_error)?;
                let timeout = h.planned_duration() * 2 + Duration::from_secs(5);
                let completion = Completion {
                    timeout: Some(timeout),
                    hold_timeout: hold,
                    ..Completion::default()
                };
                tokio::select! {
                    r = h.wait(completion) => {
                        r.map_err(client_error)?;
                    }
                    () = stop.wait() => {
                        let _ = h.cancel().await;
                        return Err(interrupted());
                    }
                }
            }
            let report = stream(ctx, robot, stop, trajectory, options, true).await?;
            print_stream_report(&report, ctx.json);
            Ok(())
        },
    )
}

/// Lowest `play --rate`, Hz (the client allows at most 500 ms between samples).
pub(crate) const MIN_PLAY_RATE_HZ: f64 = 4.0;
/// Highest `play --rate`, Hz.
pub(crate) const MAX_PLAY_RATE_HZ: f64 = 500.0;

/// A stream report as JSON, durations in seconds.
pub(crate) fn stream_report_json(r: &StreamReport) -> serde_json::Value {
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
pub(crate) fn print_stream_report(r: &StreamReport, as_json: bool) {
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

/// The header of `record` files.
pub(crate) const RECORD_HEADER: &str =
    "time_s,timer_s,error_code,error,run,repeat,teach_lock,power,task_running,j1,j2,j3,j4,j5,j6";

/// Opens the file of `record` before connecting: a new file, or with `--force` a truncated
/// one, or with `--append` the end of one (which must be a recording: its first line is the
/// header). Returns the file and whether the header must be written.
fn open_record_file(args: &RecordArgs) -> CliResult<(std::fs::File, bool)> {
    let path = &args.file;
    let cannot =
        |e: std::io::Error| CliError::input(format!("cannot open {}: {e}", path.display()));
    if args.append {
        let existing = match std::fs::read_to_string(path) {
            Ok(text) => Some(text),
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => None,
            Err(e) => return Err(cannot(e)),
        };
        if let Some(text) = &existing {
            if !text.is_empty() && text.lines().next() != Some(RECORD_HEADER) {
                return Err(CliError::input(format!(
                    "{} is not a recording of `fs020n record` (its first line is not the \
                     header); nothing was added",
                    path.display()
                ))
                .with_remedy("give another file, or --force to overwrite it"));
            }
        }
        let file = std::fs::OpenOptions::new()
            .create(true)
            .append(true)
            .open(path)
            .map_err(cannot)?;
        let needs_header = existing.is_none_or(|t| t.is_empty());
        return Ok((file, needs_header));
    }
    let mut options = std::fs::OpenOptions::new();
    options.write(true);
    if args.force {
        options.create(true).truncate(true);
    } else {
        options.create_new(true);
    }
    match options.open(path) {
        Ok(file) => Ok((file, true)),
        Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => Err(CliError::input(format!(
            "{} exists; nothing was written",
            path.display()
        ))
        .with_remedy("add --force to overwrite it or --append to add to it, or give another file")),
        Err(e) => Err(cannot(e)),
    }
}

/// `record`. Ctrl-C ends it like every command (exit 130); the file is complete up to the last
/// row, which is flushed as it is written.
pub(crate) fn record(ctx: &Ctx, args: &RecordArgs) -> CliResult {
    let (rate, duration) = (args.rate, args.duration);
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
    let (file, needs_header) = open_record_file(args)?;
    let mut out = std::io::BufWriter::new(file);
    let path: &Path = &args.file;
    with_robot(ctx, async |robot: &Robot, stop: &Interrupt| {
        if needs_header {
            writeln!(out, "{RECORD_HEADER}")?;
            out.flush()?;
        }
        let start = Instant::now();
        let end = duration.map(|d| start + Duration::from_secs_f64(d));
        let mut tick = tokio::time::interval(Duration::from_secs_f64(1.0 / rate));
        let mut rows = 0u64;
        let mut by_ctrl_c = false;
        loop {
            let s = tokio::select! {
                () = stop.wait() => {
                    by_ctrl_c = true;
                    break;
                }
                s = async {
                    tick.tick().await;
                    robot.poll().await
                } => s.map_err(client_error)?,
            };
            if end.is_some_and(|e| Instant::now() >= e) {
                break;
            }
            write_row(&mut out, start.elapsed().as_secs_f64(), &s)?;
            out.flush()?;
            rows += 1;
        }
        if ctx.json {
            println!(
                "{}",
                json!({ "rows": rows, "file": path.display().to_string() })
            );
        } else {
            println!("recorded {rows} row(s) to {}", path.display());
        }
        if by_ctrl_c {
            return Err(CliError::new(
                Exit::Interrupted,
                format!(
                    "stopped by Ctrl-C after {rows} row(s); the file is complete and the session \
                     closed"
                ),
            ));
        }
        Ok(())
    })
}

fn write_row(out: &mut impl Write, t: f64, s: &Status) -> std::io::Result<()> {
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
    )
}

/// `raw`.
pub(crate) fn raw(ctx: &Ctx, text: &str, yes: bool) -> CliResult {
    with_robot(ctx, async |robot: &Robot, _stop: &Interrupt| {
        let frame = robot
            .send_raw(text, yes)
            .await
            .map_err(|e| describe(e, Place::Command))?;
        if ctx.json {
            println!(
                "{}",
                json!({ "request": text, "reply": frame.text, "decoded": robot_status_json(&frame.status, &ctx.model) })
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
