//! The client against an emulated FS020N in the same process (no robot, no network): preflight,
//! speed, start, a joint move in one call, a pose move, a streamed trajectory, statistics.
//!
//! ```text
//! cargo run -p fs020n-client --features sim --example emulated_tour
//! ```

use fs020n_client::emulated::{ControllerConfig, Emulator, EmulatorConnector};
use fs020n_client::{
    ClientConfig, ClientError, Completion, JointsDeg, Robot, StreamOptions, Trajectory,
    TrajectoryPoint, Xyzoat,
};

#[tokio::main(flavor = "current_thread")]
async fn main() -> Result<(), ClientError> {
    let emulator = Emulator::new(ControllerConfig::default());
    let robot =
        Robot::connect_with(EmulatorConnector::new(&emulator), ClientConfig::default()).await?;
    robot.preflight().await?;
    robot.set_speed(100.0).await?;
    robot.start().await?;
    println!("connected, program running: {:?}", robot.status().status);

    // One call: send the move and wait until the robot is there.
    let target = JointsDeg::new([20.0, 10.0, -80.0, 0.0, -80.0, 0.0]);
    let report = robot
        .move_joints_and_wait(target, Completion::default())
        .await?;
    println!(
        "joint move: reached {} in {:.2} s (error {:.4} deg)",
        report.final_joints,
        report.elapsed.as_secs_f64(),
        report.error_deg
    );

    // A pose of the flange (mm, deg), through the IK solution nearest the current joints.
    let here = robot
        .model()
        .forward(&robot.status().status.joints.to_rad());
    let mut pose = here.to_xyzoat();
    pose.z_mm -= 50.0;
    let report = robot
        .move_pose_and_wait(Xyzoat { ..pose }, Completion::default())
        .await?;
    println!(
        "pose move: 50 mm down in {:.2} s",
        report.elapsed.as_secs_f64()
    );

    // Stream JT1 back by 10 degrees in 2 s with command 7.
    let start = robot.status().status.joints;
    let points = (0..=40)
        .map(|k| {
            let t = f64::from(k) * 0.05;
            let s = 0.5 - 0.5 * (std::f64::consts::PI * t / 2.0).cos();
            let mut q = start;
            q[0] -= 10.0 * s;
            TrajectoryPoint::new(t, q)
        })
        .collect();
    let trajectory = Trajectory::new(points)?;
    let options = StreamOptions::default();
    options.validate(robot.model(), &trajectory)?;
    let stream = robot.stream(trajectory, options).await?;
    let report = stream.wait().await?;
    println!(
        "stream: {} samples, tracking error max {:.3} deg, final error {:.3} deg",
        report.samples_sent, report.tracking_error_max_deg, report.final_error_deg
    );

    let stats = robot.stats();
    println!(
        "{} round trips, mean {:?}; the emulator acted on {} requests",
        stats.rtt.count,
        stats.rtt.mean,
        emulator.with(|c| c.counters().effective_requests)
    );
    robot.close().await
}
