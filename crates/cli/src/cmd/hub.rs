//! `hub`: hold the one session with a controller and share it — the web page, a protocol-1040
//! face for existing clients, a safety fence, a Foxglove bridge, a recording (docs/HUB.md).

use std::net::{SocketAddr, ToSocketAddrs};
use std::time::Duration;

use fs020n_kin::RobotModel;
use fs020n_web::hub::{serve_face, serve_hub_page, Fence};
use fs020n_web::{Hub, HubConfig};
use serde_json::json;

use crate::args::HubArgs;
use crate::cmd::sim::ShutdownSignals;
use crate::context::{runtime, Ctx};
use crate::error::client_error;
use crate::error::{CliError, CliResult};

fn resolve(text: &str, what: &str) -> CliResult<SocketAddr> {
    text.to_socket_addrs()
        .map_err(|e| CliError::input(format!("{what} {text:?}: {e} (expected HOST:PORT)")))?
        .next()
        .ok_or_else(|| CliError::input(format!("{what} {text:?}: no address")))
}

/// Checks the options and builds the hub's configuration (before anything connects).
fn config(args: &HubArgs, ctx: &Ctx, model: &RobotModel) -> CliResult<HubConfig> {
    let mut config = HubConfig::new(model.clone());
    config.client.connect_timeout = ctx.connect_timeout;
    if !(args.silence.is_finite() && (0.1..=5.0).contains(&args.silence)) {
        return Err(CliError::input(format!(
            "--silence {} must be from 0.1 to 5 seconds (the controller itself waits 5 s)",
            args.silence
        )));
    }
    config.silence_timeout = Duration::from_secs_f64(args.silence);
    if let Some(path) = &args.fence {
        config.fence =
            Some(Fence::from_file(path, model).map_err(|e| CliError::input(e.to_string()))?);
    }
    // The global `--record FILE` (.mcap, .csv or .jsonl).
    config.client.record = ctx.record.clone();
    Ok(config)
}

/// The hub as the ROS 2 node's robot: the node acts only while it holds the hub's control, and
/// its paths and speeds pass the fence.
#[cfg(feature = "ros2")]
struct HubSource(Hub);

#[cfg(feature = "ros2")]
impl fs020n_ros2::RobotSource for HubSource {
    fn robot(&self) -> Option<std::sync::Arc<fs020n_client::Robot>> {
        self.0.robot()
    }

    fn permit(&self, action: fs020n_ros2::Action<'_>) -> Result<fs020n_ros2::Permit, String> {
        fs020n_ros2::RobotSource::check(self, action)?;
        let claim = self.0.claim_control("ROS 2 node")?;
        Ok(fs020n_ros2::Permit::holding(claim))
    }

    fn check(&self, action: fs020n_ros2::Action<'_>) -> Result<(), String> {
        use fs020n_ros2::Action;
        let verdict = match action {
            Action::SetSpeed(percent) => self.0.check_speed(percent),
            Action::Trajectory(path) => self.0.check_path(path),
            Action::StreamSample(sample) => self.0.check_sample(sample),
            _ => Ok(()),
        };
        verdict.map_err(|v| format!("refused by the hub's fence: {v}"))
    }
}

/// `hub`.
pub(crate) fn hub(args: &HubArgs, ctx: &Ctx, as_json: bool) -> CliResult {
    let model = ctx.model.clone();
    let config = config(args, ctx, &model)?;
    #[cfg(not(feature = "ros2"))]
    if args.ros2 {
        return Err(CliError::input(
            "--ros2: this fs020n was built without the ROS 2 node; build it with \
             `cargo install fs020n --features ros2` (or `cargo build --features ros2`)",
        ));
    }
    #[cfg(feature = "ros2")]
    let node_config = if args.ros2 {
        Some(crate::cmd::ros2::node_config(&args.ros2_node)?)
    } else {
        None
    };
    let http = resolve(&args.http, "--http")?;
    let listen = match &args.listen {
        Some(l) => Some(resolve(l, "--listen")?),
        None => None,
    };
    let foxglove = match &args.foxglove {
        Some(f) => Some(resolve(f, "--foxglove")?),
        None => None,
    };
    #[cfg(not(feature = "foxglove"))]
    if foxglove.is_some() {
        return Err(CliError::input(
            "--foxglove: this fs020n was built without the Foxglove bridge; build it with \
             `cargo install fs020n --features foxglove` (or `cargo build --features foxglove`)",
        ));
    }
    if !http.ip().is_loopback() && args.token.as_deref().unwrap_or("").is_empty() {
        return Err(CliError::input(format!(
            "--http {http} is off loopback: give --token (or FS020N_HUB_TOKEN); the page can stop the robot"
        )));
    }
    let robot = ctx.addr_or_default();
    let rt = runtime()?;
    rt.block_on(async {
        // Handlers first: a signal that arrives while connecting still ends the session.
        let mut signals = ShutdownSignals::install();
        let hub = Hub::connect(&robot, config).await.map_err(client_error)?;
        let page = serve_hub_page(hub.clone(), http, args.token.clone())
            .await
            .map_err(|e| CliError::input(format!("cannot serve the page on {http}: {e}")))?;
        let face = match listen {
            Some(addr) => Some(serve_face(hub.clone(), addr).await.map_err(|e| {
                CliError::input(format!("cannot listen on {addr} (--listen): {e}"))
            })?),
            None => None,
        };
        #[cfg(feature = "foxglove")]
        let bridge = match foxglove {
            Some(addr) => Some(
                fs020n_web::hub::foxglove::serve_foxglove(hub.clone(), addr)
                    .await
                    .map_err(|e| CliError::input(format!("--foxglove {addr}: {e}")))?,
            ),
            None => None,
        };
        #[cfg(feature = "foxglove")]
        let foxglove_addr = bridge.as_ref().map(|b| b.local_addr());
        #[cfg(not(feature = "foxglove"))]
        let foxglove_addr: Option<SocketAddr> = None;
        #[cfg(feature = "ros2")]
        let (node_stop, mut node, node_line) = {
            let (tx, rx) = tokio::sync::oneshot::channel::<()>();
            let line = node_config
                .as_ref()
                .map(|c| (c.fully_qualified_name(), c.action_name(), c.dds.domain_id));
            let task = node_config.map(|c| {
                let source = std::sync::Arc::new(HubSource(hub.clone()));
                tokio::spawn(fs020n_ros2::run(c, model.clone(), source, async move {
                    let _ = rx.await;
                }))
            });
            (tx, task, line)
        };
        #[cfg(not(feature = "ros2"))]
        let node_line: Option<(String, String, u16)> = None;
        let page_url = format!("http://{}/", page.local_addr());
        if as_json {
            println!(
                "{}",
                json!({
                    "robot": robot,
                    "http": page_url,
                    "listen": face.as_ref().map(|f| f.local_addr().to_string()),
                    "foxglove": foxglove_addr.map(|a| format!("ws://{a}")),
                    "fence": args.fence.as_ref().map(|p| p.display().to_string()),
                    "record": ctx.record.as_ref().map(|r| r.path.display().to_string()),
                    "ros2": node_line.as_ref().map(|(node, action, domain)| json!({
                        "node": node, "action": action, "domain_id": domain,
                    })),
                })
            );
        } else {
            println!("hub: holding the session with {robot}");
            println!("  page        {page_url}");
            if let Some(f) = &face {
                println!(
                    "  protocol    {} (one controlling client; the others watch)",
                    f.local_addr()
                );
            }
            if let Some(a) = foxglove_addr {
                println!("  Foxglove    ws://{a}");
            }
            if let Some(p) = &args.fence {
                println!("  fence       {}", p.display());
            }
            if let Some(r) = &ctx.record {
                println!("  recording   {}", r.path.display());
            }
            if let Some((node, action, domain)) = &node_line {
                println!("  ROS 2       node {node} (domain {domain}), action {action}");
            }
            println!("Ctrl-C or SIGTERM ends the session (255: the controller stops the robot)");
        }
        #[cfg(feature = "ros2")]
        let node_failed = async {
            match node.as_mut() {
                Some(task) => match task.await {
                    Ok(Ok(())) => None,
                    Ok(Err(e)) => Some(crate::cmd::ros2::ros2_error(e)),
                    Err(e) => Some(CliError::failure(format!("the ROS 2 node failed: {e}"))),
                },
                None => std::future::pending().await,
            }
        };
        #[cfg(not(feature = "ros2"))]
        let node_failed = std::future::pending::<Option<CliError>>();
        let mut outcome = Ok(());
        tokio::select! {
            signal = signals.recv() => {
                tracing::info!("{signal}: ending the session with the controller");
            }
            failure = node_failed => {
                tracing::error!("the ROS 2 node ended: ending the session with the controller");
                if let Some(e) = failure {
                    outcome = Err(e);
                }
            }
        }
        #[cfg(feature = "ros2")]
        {
            // The node cancels a goal it is executing (the robot brakes) before it ends.
            let _ = node_stop.send(());
            if let Some(task) = node.filter(|t| !t.is_finished()) {
                if tokio::time::timeout(Duration::from_secs(3), task)
                    .await
                    .is_err()
                {
                    tracing::warn!("the ROS 2 node did not end within 3 s");
                }
            }
        }
        if let Some(f) = face {
            f.stop();
        }
        page.stop();
        #[cfg(feature = "foxglove")]
        if let Some(b) = bridge {
            b.stop().await;
        }
        if let Err(e) = tokio::time::timeout(Duration::from_secs(3), hub.close())
            .await
            .unwrap_or(Err(fs020n_client::ClientError::Closed))
        {
            tracing::info!("closing the session: {e}");
        }
        outcome
    })
}
