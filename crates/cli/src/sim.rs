//! `sim`: the controller emulator in the foreground, one or several robots.

use std::net::{SocketAddr, ToSocketAddrs};

use fs020n_kin::RobotModel;
use fs020n_proto::{ErrorCode, JointsDeg};
use fs020n_sim::{Panel, SimOptions};
use fs020n_web::run_robot;
use serde_json::json;

use crate::args::SimArgs;
use crate::error::{CliError, CliResult};
use crate::session::{ctrl_c, runtime};

fn resolve(text: &str, what: &str) -> CliResult<SocketAddr> {
    text.to_socket_addrs()
        .map_err(|e| CliError::input(format!("{what} {text:?}: {e} (expected HOST:PORT)")))?
        .next()
        .ok_or_else(|| CliError::input(format!("{what} {text:?}: no address")))
}

/// Builds the options of each robot from the flags.
pub fn options(args: &SimArgs, model: &RobotModel) -> CliResult<Vec<SimOptions>> {
    if !args.pendant.is_empty() && args.pendant.len() != args.listen.len() {
        return Err(CliError::input(format!(
            "{} --listen but {} --pendant: give one pendant address per robot, or none",
            args.listen.len(),
            args.pendant.len()
        )));
    }
    let panel = Panel {
        power: args.power,
        run: args.run == "run",
        repeat: args.mode == "repeat",
        teach_lock: args.teach_lock,
        estop: false,
    };
    let error = match &args.error {
        Some(e) => e
            .parse::<ErrorCode>()
            .map_err(|e| CliError::input(format!("--error: {e}")))?,
        None => ErrorCode::NONE,
    };
    let joints = match &args.joints {
        Some(v) => {
            let arr: [f64; 6] = v
                .as_slice()
                .try_into()
                .map_err(|_| CliError::input("--joints: expected 6 angles"))?;
            let j = JointsDeg::new(arr);
            model
                .check_limits(&j)
                .map_err(|e| CliError::input(format!("--joints: {e}")))?;
            Some(j)
        }
        None => None,
    };
    if let Some(p) = args.monitor_speed {
        if !(p.is_finite() && p > 0.0 && p <= 100.0) {
            return Err(CliError::input(
                "--monitor-speed must be above 0 and at most 100 %",
            ));
        }
    }
    let mut out = Vec::new();
    for (i, listen) in args.listen.iter().enumerate() {
        let pendant = match args.pendant.get(i) {
            Some(p) => Some(resolve(p, "--pendant")?),
            None => None,
        };
        out.push(SimOptions {
            listen: resolve(listen, "--listen")?,
            pendant,
            pendant_token: args.token.clone(),
            model_file: None,
            model: Some(model.clone()),
            panel,
            monitor_speed_percent: args.monitor_speed,
            joints,
            error,
        });
    }
    Ok(out)
}

/// `sim`.
pub fn sim(args: &SimArgs, model: &RobotModel, as_json: bool) -> CliResult {
    let all = options(args, model)?;
    let rt = runtime()?;
    rt.block_on(async {
        let mut robots = Vec::new();
        for opts in all {
            let r = run_robot(opts)
                .await
                .map_err(|e| CliError::input(format!("cannot start the emulator: {e}")))?;
            robots.push(r);
        }
        for (i, r) in robots.iter().enumerate() {
            if as_json {
                println!(
                    "{}",
                    json!({
                        "robot": i + 1,
                        "listen": r.robot_addr().to_string(),
                        "pendant": r.pendant_addr().map(|a| format!("http://{a}")),
                    })
                );
            } else {
                match r.pendant_addr() {
                    Some(p) => println!(
                        "robot {}: protocol 1040 on {}, pendant on http://{p}/ (API: /api)",
                        i + 1,
                        r.robot_addr()
                    ),
                    None => println!("robot {}: protocol 1040 on {}", i + 1, r.robot_addr()),
                }
            }
        }
        if !as_json {
            println!(
                "{} emulated {} running; Ctrl-C to stop",
                robots.len(),
                model.name()
            );
        }
        ctrl_c().await;
        for r in robots {
            r.stop();
        }
        Ok(())
    })
}
