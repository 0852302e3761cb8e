//! Test helpers: in-memory connectors around the emulator.
#![allow(dead_code)]

use std::sync::{Arc, Mutex};
use std::time::Duration;

use fs020n_client::{BoxedStream, ClientConfig, ConnectFuture, Connector, Robot};
use fs020n_proto::JointsDeg;
use fs020n_sim::{ControllerConfig, Emulator};

/// Connects to whichever emulator it currently holds (tests swap it to "restart" the
/// controller).
#[derive(Clone)]
pub struct EmuConnector(pub Arc<Mutex<Emulator>>);

impl EmuConnector {
    pub fn new(emu: &Emulator) -> EmuConnector {
        EmuConnector(Arc::new(Mutex::new(emu.clone())))
    }

    pub fn swap(&self, emu: &Emulator) {
        *self.0.lock().unwrap() = emu.clone();
    }
}

impl Connector for EmuConnector {
    fn connect(&self) -> ConnectFuture<'_> {
        let emu = self.0.lock().unwrap().clone();
        Box::pin(async move { Ok(Box::new(emu.connect()?) as BoxedStream) })
    }

    fn describe(&self) -> String {
        "in-memory emulator".into()
    }
}

pub fn emulator() -> Emulator {
    Emulator::new(ControllerConfig::default())
}

pub async fn connect(emu: &Emulator) -> Robot {
    Robot::connect_with(EmuConnector::new(emu), ClientConfig::default())
        .await
        .expect("connect to the emulator")
}

/// Connected, program started, speed set.
pub async fn ready(emu: &Emulator, speed: f64) -> Robot {
    let robot = connect(emu).await;
    robot.set_speed(speed).await.expect("set speed");
    robot.start().await.expect("start");
    robot
}

pub fn home() -> JointsDeg {
    JointsDeg::new([0.0, 0.0, -90.0, 0.0, -90.0, 0.0])
}

pub fn with_jt1(deg: f64) -> JointsDeg {
    let mut j = home();
    j[0] = deg;
    j
}

pub async fn sleep_ms(ms: u64) {
    tokio::time::sleep(Duration::from_millis(ms)).await;
}

/// Requests the controller acted on (version 1040): keep-alive polls do not count.
pub fn effective(emu: &Emulator) -> u64 {
    emu.with(|c| c.counters().effective_requests)
}

/// JT1 from `from` to `to` degrees in `secs`, a smooth (cosine) profile sampled every 50 ms.
#[allow(dead_code)]
pub fn jt1_ramp(from: f64, to: f64, secs: f64) -> fs020n_client::Trajectory {
    let n = (secs / 0.05).round() as usize;
    let points = (0..=n)
        .map(|k| {
            let t = k as f64 * 0.05;
            let s = 0.5 - 0.5 * (std::f64::consts::PI * t / secs).cos();
            fs020n_client::TrajectoryPoint::new(t, with_jt1(from + (to - from) * s))
        })
        .collect();
    fs020n_client::Trajectory::new(points).unwrap()
}
