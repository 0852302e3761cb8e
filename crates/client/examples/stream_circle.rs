//! Streams a 50 mm circle of the tool flange in the horizontal plane, starting and ending at
//! the current position, through inverse kinematics (command 7, server-clock stamped).
//!
//! ```text
//! cargo run -p fs020n-client --example stream_circle -- --robot 127.0.0.1:10050
//! ```

use fs020n_client::{ClientConfig, Pose, Robot, StreamOptions, Trajectory, TrajectoryPoint};

fn robot_arg() -> String {
    let args: Vec<String> = std::env::args().collect();
    args.iter()
        .position(|a| a == "--robot")
        .and_then(|i| args.get(i + 1).cloned())
        .unwrap_or_else(|| "127.0.0.1:10050".into())
}

const RADIUS_MM: f64 = 50.0;
const DURATION_S: f64 = 8.0;
const STEP_S: f64 = 0.05;

#[tokio::main(flavor = "current_thread")]
async fn main() -> Result<(), Box<dyn std::error::Error>> {
    let robot = Robot::connect(&robot_arg(), ClientConfig::default()).await?;
    robot.preflight().await?;
    robot.set_speed(100.0).await?;
    robot.start().await?;

    let model = robot.model().clone();
    let start = robot.poll().await?.joints;
    let flange = model.forward(&start.to_rad()).to_xyzoat();
    // Centre one radius behind the start point, so the circle begins where the robot is.
    let (cx, cy) = (flange.x_mm - RADIUS_MM, flange.y_mm);
    let mut seed = start.to_rad();
    let mut points = Vec::new();
    let n = (DURATION_S / STEP_S).round() as usize;
    for k in 0..=n {
        let t = k as f64 * STEP_S;
        // Smooth start and stop: the angle follows a cosine ramp from 0 to 2 pi.
        let phi = std::f64::consts::PI * (1.0 - (std::f64::consts::PI * t / DURATION_S).cos());
        let mut p = flange;
        p.x_mm = cx + RADIUS_MM * phi.cos();
        p.y_mm = cy + RADIUS_MM * phi.sin();
        let q = model.inverse_nearest(&Pose::from_xyzoat(p), &seed)?;
        seed = q;
        points.push(TrajectoryPoint::new(t, q.to_deg()));
    }
    let trajectory = Trajectory::new(points)?;
    let handle = robot.stream(trajectory, StreamOptions::default()).await?;
    let mut progress = handle.subscribe();
    while progress.changed().await.is_ok() {
        let p = *progress.borrow();
        if p.index % 50 == 0 {
            println!("{:5.1} %  sample {}", p.fraction * 100.0, p.index);
        }
        if p.done {
            break;
        }
    }
    let report = handle.wait().await?;
    println!("{report:#?}");
    robot.close().await?;
    Ok(())
}
