//! scratch: one run of the eight or circle, env FS_PATH=eight|circle FS_RATE_MS FS_PHASE_MS
use std::time::Duration;
use fs020n_client::emulated::{ControllerConfig, Emulator, EmulatorConnector};
use fs020n_client::{ClientConfig, JointsDeg, Robot, StreamOptions, Trajectory, TrajectoryPoint};
fn circle() -> Trajectory {
    let text = include_str!("../../../examples/circle.csv");
    Trajectory::new(text.lines().filter(|l| !l.starts_with('#') && !l.starts_with("time") && !l.trim().is_empty())
        .filter_map(|l| { let v: Vec<f64> = l.split(',').filter_map(|x| x.trim().parse().ok()).collect();
            (v.len()==7).then(|| TrajectoryPoint::new(v[0], JointsDeg::new([v[1],v[2],v[3],v[4],v[5],v[6]]))) }).collect()).unwrap()
}
fn eight() -> Trajectory {
    Trajectory::new((0..=250).map(|k| { let t = k as f64*0.02; let u=t/5.0; let ph = std::f64::consts::TAU*(u-(std::f64::consts::TAU*u).sin()/std::f64::consts::TAU);
        TrajectoryPoint::new(t, JointsDeg::new([15.0*ph.sin(),0.0,-90.0+6.0*(2.0*ph).sin(),0.0,-90.0+10.0*(1.0-ph.cos()),0.0]))}).collect()).unwrap()
}
#[tokio::main(flavor = "current_thread", start_paused = true)]
async fn main() -> Result<(), Box<dyn std::error::Error>> {
    let env = |k: &str, d: u64| std::env::var(k).ok().and_then(|v| v.parse().ok()).unwrap_or(d);
    let path = if std::env::var("FS_PATH").as_deref() == Ok("eight") { eight() } else { circle() };
    let emulator = Emulator::new(ControllerConfig::default());
    let robot = Robot::connect_with(EmulatorConnector::new(&emulator), ClientConfig::default()).await?;
    robot.set_speed(100.0).await?;
    robot.start().await?;
    tokio::time::sleep(Duration::from_millis(env("FS_PHASE_MS", 0))).await;
    let o = StreamOptions { period: Duration::from_millis(env("FS_RATE_MS", 20)), ..StreamOptions::default() };
    let r = robot.stream(path, o).await?.wait().await?;
    println!("rms {:.4} max {:.4} lead {:.1}", r.tracking_error_rms_deg, r.tracking_error_max_deg, r.lead_s*1e3);
    robot.close().await?;
    Ok(())
}
