//! `ros2`: the ROS 2 node (crate `fs020n-ros2`) on one robot session, until Ctrl-C.

use std::net::SocketAddr;
use std::path::Path;
use std::sync::Arc;
use std::time::Duration;

use fs020n_ros2::{DdsConfig, NodeConfig, Ros2Error, ServiceMapping};
use fs020n_sim::{run_robot, SimOptions};
use serde_json::json;

use crate::args::{Ros2Args, Ros2NodeArgs};
use crate::context::{close_quietly, runtime, Ctx, Interrupt};
use crate::error::client_error;
use crate::error::{CliError, CliResult, Exit};

/// The node's settings from the defaults, the ROS 2 environment, the parameter file and the
/// flags (in that order).
pub(crate) fn node_config(args: &Ros2NodeArgs) -> CliResult<NodeConfig> {
    let input = |e: Ros2Error| CliError::input(e.to_string());
    let mut config = NodeConfig {
        dds: DdsConfig::from_env().map_err(input)?,
        ..NodeConfig::default()
    };
    if let Some(n) = &args.node_name {
        config.node_name = n.clone();
    }
    if let Some(ns) = &args.namespace {
        config.namespace = ns.clone();
    }
    if let Some(path) = &args.params_file {
        config.apply_params_file(path).map_err(input)?;
    }
    if let Some(d) = args.domain_id {
        config.dds.domain_id = d;
    }
    if args.localhost_only {
        config.dds.localhost_only = true;
    }
    if let Some(m) = &args.service_mapping {
        config.dds.service_mapping = ServiceMapping::parse(m).map_err(input)?;
    }
    if let Some(r) = args.rate {
        config.joint_state_rate_hz = r;
    }
    if let Some(ns) = &args.action_namespace {
        config.action_namespace = ns.clone();
    }
    if args.auto_start {
        config.execution.auto_start = true;
    }
    if let Some(ros_args) = &args.ros_args {
        let parsed = fs020n_ros2::RosArgs::parse(ros_args).map_err(input)?;
        config.apply_ros_args(&parsed).map_err(input)?;
    }
    config.validate().map_err(input)?;
    Ok(config)
}

pub(crate) fn ros2_error(e: Ros2Error) -> CliError {
    match e {
        Ros2Error::Config(_) | Ros2Error::ParamsFile { .. } => CliError::input(e.to_string()),
        Ros2Error::Robot(c) => client_error(c),
        other => CliError::failure(other.to_string()),
    }
}

/// Writes the MoveIt configuration package into `dir` (created if needed; the generated files
/// are overwritten, others are left alone).
fn write_moveit_config(dir: &Path, files: &[(String, String)]) -> CliResult {
    let failed = |path: &Path, e: std::io::Error| {
        CliError::input(format!(
            "cannot write {}: {e}; give a directory you can write to",
            path.display()
        ))
    };
    for (relative, text) in files {
        let path = dir.join(relative);
        if let Some(parent) = path.parent() {
            std::fs::create_dir_all(parent).map_err(|e| failed(parent, e))?;
        }
        std::fs::write(&path, text).map_err(|e| failed(&path, e))?;
    }
    Ok(())
}

/// `ros2`.
pub(crate) fn ros2(ctx: &Ctx, args: &Ros2Args) -> CliResult {
    let config = node_config(&args.node)?;
    if let Some(what) = &args.print {
        let text = match what.as_str() {
            "urdf" => fs020n_ros2::urdf::generate(&ctx.model, &config.joint_names),
            "srdf" => fs020n_ros2::srdf::generate(&ctx.model, &config.joint_names),
            "joint-limits" => fs020n_ros2::urdf::joint_limits_yaml(&ctx.model, &config.joint_names),
            "moveit-config" => {
                let Some(dir) = &args.output else {
                    return Err(CliError::input(
                        "--print moveit-config writes a package: give its directory, e.g. \
                         `fs020n ros2 --print moveit-config src/fs020n_moveit_config`",
                    ));
                };
                let files = fs020n_ros2::moveit::config_package(&ctx.model, &config);
                write_moveit_config(dir, &files)?;
                if ctx.json {
                    let paths: Vec<_> = files.iter().map(|(p, _)| p.as_str()).collect();
                    println!("{}", json!({ "package": dir, "files": paths }));
                } else {
                    println!(
                        "MoveIt configuration package {} written to {} ({} files)",
                        fs020n_ros2::moveit::PACKAGE_NAME,
                        dir.display(),
                        files.len()
                    );
                }
                return Ok(());
            }
            _ => fs020n_ros2::moveit::moveit_controllers_yaml(&config),
        };
        if args.output.is_some() {
            return Err(CliError::input(
                "a directory is only for --print moveit-config; the other files go to stdout",
            ));
        }
        print!("{text}");
        return Ok(());
    }
    if args.embedded && ctx.addr.is_some() {
        return Err(CliError::input(
            "give either --robot (a controller) or --embedded (an emulator in this process)",
        ));
    }
    let pendant: Option<SocketAddr> =
        match &args.pendant {
            Some(p) if args.embedded => Some(p.parse().map_err(|e| {
                CliError::input(format!("--pendant {p:?}: {e} (expected HOST:PORT)"))
            })?),
            Some(_) => {
                return Err(CliError::input(
                    "--pendant serves the embedded emulator's pendant API: use it with --embedded",
                ))
            }
            None => None,
        };
    let rt = runtime()?;
    rt.block_on(async {
        let stop = Interrupt::install();
        let embedded = if args.embedded {
            let mut opts = SimOptions::default().listen(([127, 0, 0, 1], 0).into());
            opts.model = Some(ctx.model.clone());
            opts.pendant = pendant;
            Some(run_robot(opts).await.map_err(|e| {
                CliError::failure(format!("cannot start the embedded emulator: {e}"))
            })?)
        } else {
            None
        };
        let addr = match &embedded {
            Some(e) => e.robot_addr().to_string(),
            None => ctx.addr_or_default(),
        };
        // Keep-alive polls at the joint-state rate (at most 10 Hz: the node polls in between
        // when the status would be older than one period).
        let keepalive = Duration::from_secs_f64(1.0 / config.joint_state_rate_hz)
            .min(Duration::from_millis(100));
        let client_config = fs020n_client::ClientConfig {
            keepalive_period: keepalive,
            ..ctx.client_config()
        };
        let robot = fs020n_client::Robot::connect(&addr, client_config)
            .await
            .map_err(client_error)?;
        let robot = Arc::new(robot);
        let line = json!({
            "node": config.fully_qualified_name(),
            "domain_id": config.dds.domain_id,
            "localhost_only": config.dds.localhost_only,
            "action": config.action_name(),
            "robot": addr,
            "pendant": embedded.as_ref().and_then(|e| e.pendant_addr()).map(|a| format!("http://{a}")),
        });
        if ctx.json {
            println!("{line}");
        } else {
            println!(
                "ROS 2 node {} (domain {}{}) on the robot at {addr}; action {}; Ctrl-C to stop",
                config.fully_qualified_name(),
                config.dds.domain_id,
                if config.dds.localhost_only {
                    ", localhost only"
                } else {
                    ""
                },
                config.action_name(),
            );
            if let Some(p) = embedded.as_ref().and_then(|e| e.pendant_addr()) {
                println!("embedded emulator's pendant API on http://{p}");
            }
        }
        let mut status = robot.subscribe();
        let diagnostics_period = 1.0 / config.diagnostics_rate_hz;
        let link_lost = async {
            while status.changed().await.is_ok() {}
            // Let /diagnostics report it once before leaving.
            tokio::time::sleep(Duration::from_secs_f64(1.5 * diagnostics_period)).await;
        };
        let model = robot.model().clone();
        let source: Arc<dyn fs020n_ros2::RobotSource> = Arc::new(robot.clone());
        let node = fs020n_ros2::run(config, model, source, stop.wait());
        let result = tokio::select! {
            r = node => r.map_err(ros2_error),
            _ = link_lost => Err(CliError::new(
                Exit::Link,
                match robot.link_error() {
                    Some(e) => format!("{e}; the node stopped (restart it: it never reconnects by itself)"),
                    None => "the robot session ended; the node stopped".to_owned(),
                },
            )),
        };
        close_quietly(&robot).await;
        if let Some(e) = embedded {
            e.stop();
        }
        result
    })
}
