//! An emulated controller in the same process, as a [`Connector`] (feature `sim`): develop,
//! test and try examples without a robot or a network.
//!
//! ```
//! use fs020n_client::emulated::{ControllerConfig, Emulator, EmulatorConnector};
//! use fs020n_client::{blocking, ClientConfig, Completion, JointsDeg};
//!
//! let emulator = Emulator::new(ControllerConfig::default());
//! let robot = blocking::Robot::connect_with(EmulatorConnector::new(&emulator), ClientConfig::default())?;
//! robot.set_speed(100.0)?;
//! robot.start()?;
//! let target = JointsDeg::new([5.0, 0.0, -90.0, 0.0, -90.0, 0.0]);
//! robot.move_joints_and_wait(target, Completion::default())?;
//! assert!(emulator.with(|c| c.joints()).max_abs_diff(&target) < 0.1);
//! robot.close()?;
//! # Ok::<(), fs020n_client::ClientError>(())
//! ```

use crate::transport::{BoxedStream, ConnectFuture, Connector};

pub use fs020n_sim::{ControllerConfig, Emulator};

/// Connects to an [`Emulator`] in memory, as a TCP connect to a controller would: refused
/// during the emulator's listen gaps and while another session is open (the client retries).
/// The emulator runs on the clock of the runtime that drives the connection (virtual time
/// under a paused tokio test runtime).
#[derive(Debug, Clone)]
pub struct EmulatorConnector {
    emulator: Emulator,
}

impl EmulatorConnector {
    /// A connector to `emulator` (a cheap clone of it is kept).
    pub fn new(emulator: &Emulator) -> EmulatorConnector {
        EmulatorConnector {
            emulator: emulator.clone(),
        }
    }

    /// The emulator (observe it, operate its pendant, inject faults).
    pub fn emulator(&self) -> &Emulator {
        &self.emulator
    }
}

impl Connector for EmulatorConnector {
    fn connect(&self) -> ConnectFuture<'_> {
        Box::pin(async move { Ok(Box::new(self.emulator.connect()?) as BoxedStream) })
    }

    fn describe(&self) -> String {
        "the in-process emulator".into()
    }
}
