//! Test helpers: in-memory connectors around the emulator.
#![allow(dead_code)]
#![allow(clippy::expect_used)] // test code: a failed expectation is a failed test

use std::sync::{Arc, Mutex};
use std::time::Duration;

use fs020n_client::{
    BoxedStream, ClientConfig, ConnectFuture, Connector, Robot, Trajectory, TrajectoryPoint,
};
use fs020n_proto::JointsDeg;
use fs020n_sim::{ControllerConfig, Emulator};

/// Connects to whichever emulator it currently holds (tests swap it to "restart" the
/// controller).
#[derive(Clone)]
pub(crate) struct EmuConnector(pub Arc<Mutex<Emulator>>);

impl EmuConnector {
    pub(crate) fn new(emu: &Emulator) -> EmuConnector {
        EmuConnector(Arc::new(Mutex::new(emu.clone())))
    }

    pub(crate) fn swap(&self, emu: &Emulator) {
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

pub(crate) fn emulator() -> Emulator {
    Emulator::new(ControllerConfig::default())
}

pub(crate) async fn connect(emu: &Emulator) -> Robot {
    Robot::connect_with(EmuConnector::new(emu), ClientConfig::default())
        .await
        .expect("connect to the emulator")
}

/// Connected, program started, speed set.
pub(crate) async fn ready(emu: &Emulator, speed: f64) -> Robot {
    let robot = connect(emu).await;
    robot.set_speed(speed).await.expect("set speed");
    robot.start().await.expect("start");
    robot
}

pub(crate) fn home() -> JointsDeg {
    JointsDeg::new([0.0, 0.0, -90.0, 0.0, -90.0, 0.0])
}

pub(crate) fn with_jt1(deg: f64) -> JointsDeg {
    let mut j = home();
    j[0] = deg;
    j
}

pub(crate) async fn sleep_ms(ms: u64) {
    tokio::time::sleep(Duration::from_millis(ms)).await;
}

/// Requests the controller acted on (version 1040): keep-alive polls do not count.
pub(crate) fn effective(emu: &Emulator) -> u64 {
    emu.with(|c| c.counters().effective_requests)
}

/// JT1 from `from` to `to` degrees in `secs`, a smooth (cosine) profile sampled every 50 ms.
#[allow(dead_code)]
pub(crate) fn jt1_ramp(from: f64, to: f64, secs: f64) -> fs020n_client::Trajectory {
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

/// Connects to the emulator running the AS text of the server (`Emulator::with_program`).
#[derive(Clone)]
pub(crate) struct ProgramConnector(pub Emulator);

impl Connector for ProgramConnector {
    fn connect(&self) -> ConnectFuture<'_> {
        let emu = self.0.clone();
        Box::pin(async move { Ok(Box::new(emu.connect_program()?) as BoxedStream) })
    }

    fn describe(&self) -> String {
        "in-memory emulator running server1040.as".into()
    }
}

/// The emulator running this project's AS text of the protocol-1040 server.
pub(crate) fn interpreted_emulator() -> Emulator {
    Emulator::with_program(
        ControllerConfig::default(),
        fs020n_sim::ServerProgram::server_1040().expect("the server's AS text loads"),
    )
}

/// Connects to the emulator, natively or through its AS program.
#[derive(Clone)]
pub(crate) enum AnyConnector {
    Native(EmuConnector),
    Program(ProgramConnector),
}

impl Connector for AnyConnector {
    fn connect(&self) -> ConnectFuture<'_> {
        match self {
            AnyConnector::Native(c) => c.connect(),
            AnyConnector::Program(c) => c.connect(),
        }
    }

    fn describe(&self) -> String {
        match self {
            AnyConnector::Native(c) => c.describe(),
            AnyConnector::Program(c) => c.describe(),
        }
    }
}

/// `examples/circle.csv`, the circle `play` streams (the tracking goal's path).
pub(crate) fn circle_csv() -> Trajectory {
    let text = include_str!("../../../../examples/circle.csv");
    let points = text
        .lines()
        .filter(|l| !l.starts_with('#') && !l.starts_with("time"))
        .map(|l| {
            let v: Vec<f64> = l.split(',').map(|x| x.trim().parse().unwrap()).collect();
            TrajectoryPoint::new(v[0], JointsDeg::new([v[1], v[2], v[3], v[4], v[5], v[6]]))
        })
        .collect();
    Trajectory::new(points).unwrap()
}
