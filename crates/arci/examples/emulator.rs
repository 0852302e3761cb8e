//! openrr's `arci::JointTrajectoryClient` driving an emulated FS020N: an emulator on a free
//! loopback port, a session, then a joint-position move and a trajectory through arci.
//!
//! ```sh
//! cargo run -p fs020n-arci --example emulator
//! ```

use std::sync::Arc;
use std::time::Duration;

use arci::{JointTrajectoryClient, TrajectoryPoint};
use fs020n_arci::Fs020nClient;
use fs020n_client::{ClientConfig, Robot};
use fs020n_sim::{run_robot, SimOptions};

#[tokio::main]
async fn main() -> Result<(), Box<dyn std::error::Error>> {
    let emulator = run_robot(SimOptions::default().listen(([127, 0, 0, 1], 0).into())).await?;
    let robot = Robot::connect(&emulator.robot_addr().to_string(), ClientConfig::default()).await?;
    robot.set_speed(100.0).await?;
    robot.start().await?;
    let robot = Arc::new(robot);
    let arm = Fs020nClient::new(robot.clone())?;
    println!("joints {:?}", arm.joint_names());
    println!("at     {:?} rad", arm.current_joint_positions()?);

    // JT1 to 0.3 rad in 2 s.
    let mut target = arm.current_joint_positions()?;
    target[0] = 0.3;
    arm.send_joint_positions(target.clone(), Duration::from_secs(2))?
        .await?;
    println!("at     {:?} rad", arm.current_joint_positions()?);

    // Back through a waypoint, 3 s in all.
    let mut mid = target.clone();
    mid[0] = 0.15;
    mid[1] = 0.1;
    let mut home = target;
    home[0] = 0.0;
    arm.send_joint_trajectory(vec![
        TrajectoryPoint::new(mid, Duration::from_millis(1500)),
        TrajectoryPoint::new(home, Duration::from_secs(3)),
    ])?
    .await?;
    println!("at     {:?} rad", arm.current_joint_positions()?);

    // Refused before anything moves: JT1 stops at 160 deg (2.79 rad).
    let mut far = arm.current_joint_positions()?;
    far[0] = 3.0;
    match arm.send_joint_positions(far, Duration::from_secs(10)) {
        Err(e) => println!("refused: {e}"),
        Ok(_) => return Err("an out-of-range target was accepted".into()),
    }
    robot.close().await?;
    emulator.stop();
    Ok(())
}
