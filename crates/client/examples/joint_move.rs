//! Starts the motion program and moves to a joint target, with a progress line.
//!
//! ```text
//! cargo run -p fs020n-client --example joint_move -- --robot 127.0.0.1:10050 \
//!     --to 10,0,-90,0,-90,0 --speed 20
//! ```

use std::io::Write;

use fs020n_client::{ClientConfig, ClientError, Completion, Robot};
use fs020n_proto::JointsDeg;

fn arg(name: &str) -> Option<String> {
    let args: Vec<String> = std::env::args().collect();
    args.iter()
        .position(|a| a == name)
        .and_then(|i| args.get(i + 1).cloned())
}

fn parse_joints(text: &str) -> Result<JointsDeg, String> {
    let v: Vec<f64> = text
        .split(',')
        .map(|t| t.trim().parse::<f64>().map_err(|e| format!("{t:?}: {e}")))
        .collect::<Result<_, _>>()?;
    let a: [f64; 6] = v
        .try_into()
        .map_err(|_| "give six comma-separated angles in degrees".to_string())?;
    Ok(JointsDeg::new(a))
}

#[tokio::main(flavor = "current_thread")]
async fn main() -> Result<(), Box<dyn std::error::Error>> {
    let addr = arg("--robot").unwrap_or_else(|| "127.0.0.1:10050".into());
    let target = parse_joints(&arg("--to").unwrap_or_else(|| "10,0,-90,0,-90,0".into()))?;
    let speed: f64 = arg("--speed").map_or(Ok(10.0), |s| s.parse())?;

    let robot = Robot::connect(&addr, ClientConfig::default()).await?;
    if let Err(e @ ClientError::Blocked(_)) = robot.preflight().await {
        eprintln!("{e}");
        robot.close().await?;
        std::process::exit(2);
    }
    robot.set_speed(speed).await?;
    robot.start().await?;
    let mv = robot.move_joints(target).await?;
    println!(
        "moving to {target} at {speed} % (about {:?})",
        mv.planned_duration()
    );

    let progress = mv.clone();
    let bar = tokio::spawn(async move {
        let mut rx = progress.subscribe();
        while rx.changed().await.is_ok() {
            if let Some(p) = progress.progress() {
                print!(
                    "\r{:5.1} %  {:8.3} deg to go",
                    p.fraction * 100.0,
                    p.remaining_deg
                );
                let _ = std::io::stdout().flush();
            }
        }
    });
    let result = mv.wait(Completion::default()).await;
    bar.abort();
    println!();
    match result {
        Ok(r) => println!(
            "done in {:?}, final error {:.3} deg",
            r.elapsed, r.error_deg
        ),
        Err(e) => eprintln!("move failed: {e}"),
    }
    robot.close().await?;
    Ok(())
}
