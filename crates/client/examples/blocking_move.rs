//! The blocking API against an emulated FS020N in the same process: no async code, no robot.
//!
//! ```text
//! cargo run -p fs020n-client --features sim --example blocking_move
//! ```

use fs020n_client::emulated::{ControllerConfig, Emulator, EmulatorConnector};
use fs020n_client::{blocking::Robot, ClientConfig, ClientError, Completion, JointsDeg};

fn main() -> Result<(), ClientError> {
    let emulator = Emulator::new(ControllerConfig::default());
    let robot = Robot::connect_with(EmulatorConnector::new(&emulator), ClientConfig::default())?;
    robot.preflight()?;
    robot.set_speed(50.0)?;
    robot.start()?;
    for target in [
        [15.0, 5.0, -85.0, 0.0, -90.0, 0.0],
        [0.0, 0.0, -90.0, 0.0, -90.0, 0.0],
    ] {
        let report = robot.move_joints_and_wait(JointsDeg::new(target), Completion::default())?;
        println!(
            "reached {} in {:.2} s",
            report.final_joints,
            report.elapsed.as_secs_f64()
        );
    }
    robot.close()
}
