//! Prints the robot's status, what blocks motion (with remedies) and the link statistics.
//!
//! ```text
//! cargo run -p fs020n-client --example status -- --robot 192.168.0.2:10050
//! ```

use std::time::Duration;

use fs020n_client::{ClientConfig, ClientError, Robot};

fn robot_arg() -> String {
    let args: Vec<String> = std::env::args().collect();
    args.iter()
        .position(|a| a == "--robot")
        .and_then(|i| args.get(i + 1).cloned())
        .unwrap_or_else(|| "127.0.0.1:10050".into())
}

#[tokio::main(flavor = "current_thread")]
async fn main() -> Result<(), ClientError> {
    let robot = Robot::connect(&robot_arg(), ClientConfig::default()).await?;
    let s = robot.poll().await?;
    let sw = |b: bool, on: &'static str, off: &'static str| if b { on } else { off };
    println!("error      {}", s.error);
    println!("RUN/HOLD   {}", sw(s.run, "RUN", "HOLD"));
    println!("REPEAT     {}", sw(s.repeat, "REPEAT", "TEACH"));
    println!("TEACH LOCK {}", sw(s.teach_lock, "ON", "OFF"));
    println!("power      {}", sw(s.power, "ON", "OFF"));
    println!(
        "program    {}",
        sw(s.task_running, "running", "not running")
    );
    println!("timer      {:?} s", s.timer.seconds());
    println!("joints     {}", s.joints);
    match robot.preflight().await {
        Ok(()) => println!("ready to start"),
        Err(ClientError::Blocked(list)) => {
            for b in list {
                println!("blocked: {b}");
            }
        }
        Err(e) => return Err(e),
    }
    // Let the keep-alive run for a second, then show the link figures.
    tokio::time::sleep(Duration::from_secs(1)).await;
    let st = robot.stats();
    println!(
        "round trips: {} (min {:?}, mean {:?}, p99 {:?}, max {:?}), late {}",
        st.rtt.count, st.rtt.min, st.rtt.mean, st.rtt.p99, st.rtt.max, st.late_replies
    );
    robot.close().await
}
