//! `move`: a joint move, a pose by inverse kinematics, or a straight line of the flange.

use std::time::Duration;

use fs020n_client::{Completion, Robot, StreamOptions};
use fs020n_kin::{Pose, Xyzoat};
use fs020n_proto::JointsDeg;
use serde_json::json;

use crate::args::MoveArgs;
use crate::cmd::bar;
use crate::cmd::hold_limit;
use crate::cmd::interrupted;
use crate::cmd::play::{print_stream_report, stream, stream_report_json};
use crate::cmd::with_robot;
use crate::cmd::HoldNotice;
use crate::context::{check_speed, check_target, check_timeout, Ctx, Interrupt};
use crate::error::{client_error, CliError, CliResult};
use crate::linear;
use crate::output::{flange_pose, joints_json, pose_json, pose_line};

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
