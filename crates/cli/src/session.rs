//! Shared plumbing of the commands that talk to a robot: the runtime, connecting, the embedded
//! emulator, error mapping and Ctrl-C.

use std::net::SocketAddr;
use std::time::Duration;

use fs020n_client::{Blocker, ClientConfig, ClientError, Robot};
use fs020n_kin::RobotModel;
use fs020n_sim::{ControllerConfig, Emulator, TcpServer};

use crate::error::{CliError, CliResult, Exit};

/// Default robot address when `--robot` is not given (where `fs020n sim` listens).
pub const DEFAULT_ROBOT: &str = "127.0.0.1:10050";

/// What every robot command needs.
pub struct Ctx {
    /// The robot's address.
    pub addr: Option<String>,
    /// Print JSON.
    pub json: bool,
    /// The robot model.
    pub model: RobotModel,
    /// Overall connect timeout.
    pub connect_timeout: Duration,
    /// `--record FILE`: every request and reply of the session.
    pub record: Option<fs020n_client::Recording>,
}

impl Ctx {
    /// The address to use: `--robot`, else the default.
    pub fn addr_or_default(&self) -> String {
        self.addr
            .clone()
            .unwrap_or_else(|| DEFAULT_ROBOT.to_owned())
    }

    /// The client configuration for this robot.
    pub fn client_config(&self) -> ClientConfig {
        ClientConfig {
            model: self.model.clone(),
            connect_timeout: self.connect_timeout,
            record: self.record.clone(),
            ..ClientConfig::default()
        }
    }
}

/// A tokio runtime with worker threads, so the client's keep-alive runs while the main thread
/// waits for input.
pub fn runtime() -> CliResult<tokio::runtime::Runtime> {
    tokio::runtime::Builder::new_multi_thread()
        .worker_threads(2)
        .enable_all()
        .build()
        .map_err(|e| CliError::failure(format!("cannot start the async runtime: {e}")))
}

/// Connects to `addr`.
pub async fn connect(addr: &str, ctx: &Ctx) -> CliResult<Robot> {
    Robot::connect(addr, ctx.client_config())
        .await
        .map_err(client_error)
}

/// An emulator inside this process on a free loopback port.
pub struct Embedded {
    /// The emulator (for observing it).
    pub emulator: Emulator,
    /// Its robot port.
    pub server: TcpServer,
}

impl Embedded {
    /// Starts the embedded emulator (call inside the runtime).
    pub async fn start(model: &RobotModel) -> CliResult<Embedded> {
        let emulator = Emulator::new(ControllerConfig::new(model.clone()));
        let addr: SocketAddr = ([127, 0, 0, 1], 0).into();
        let server = emulator
            .serve_tcp(addr)
            .await
            .map_err(|e| CliError::failure(format!("cannot start the embedded emulator: {e}")))?;
        Ok(Embedded { emulator, server })
    }

    /// Its address as HOST:PORT.
    pub fn addr(&self) -> String {
        self.server.local_addr().to_string()
    }
}

/// The robot of `demo` and `bench`: `--robot` if given, else an embedded emulator (returned so
/// that it lives as long as the session).
pub async fn robot_or_embedded(ctx: &Ctx) -> CliResult<(String, Option<Embedded>)> {
    match &ctx.addr {
        Some(addr) => Ok((addr.clone(), None)),
        None => {
            let e = Embedded::start(&ctx.model).await?;
            Ok((e.addr(), Some(e)))
        }
    }
}

/// Lists blockers with their remedies, one per line.
pub fn blocker_lines(blockers: &[Blocker]) -> String {
    blockers
        .iter()
        .map(|b| {
            let remedy = match b {
                Blocker::ProgramNotRunning => {
                    "start the motion program first (in `fs020n shell`, type `start`)".to_owned()
                }
                other => other.remedy(),
            };
            format!("  - {} — {remedy}", b.condition())
        })
        .collect::<Vec<_>>()
        .join("\n")
}

/// Maps a client error to what the user reads and the exit code.
pub fn client_error(e: ClientError) -> CliError {
    let exit = match &e {
        ClientError::Connect { .. } | ClientError::LinkLost(_) | ClientError::Closed => Exit::Link,
        ClientError::Blocked(_) | ClientError::StartFailed { .. } => Exit::NotReady,
        ClientError::Aborted { .. }
        | ClientError::MoveTimeout { .. }
        | ClientError::StreamUnderrun { .. }
        | ClientError::Cancelled(_) => Exit::Motion,
        ClientError::Limit(_)
        | ClientError::NonFinite { .. }
        | ClientError::Encode(_)
        | ClientError::Speed { .. }
        | ClientError::Trajectory(_)
        | ClientError::Ik(_)
        | ClientError::RawRefused { .. }
        | ClientError::Sample(_)
        | ClientError::Config(_) => Exit::Input,
        _ => Exit::Failure,
    };
    let message = match &e {
        ClientError::Blocked(b) => format!(
            "the robot is not ready to move; nothing was sent:\n{}",
            blocker_lines(b)
        ),
        ClientError::StartFailed { blockers, waited } if !blockers.is_empty() => format!(
            "the robot did not start within {waited:?}:\n{}",
            blocker_lines(blockers)
        ),
        ClientError::Aborted { during, blockers } => {
            format!("{during} stopped:\n{}", blocker_lines(blockers))
        }
        _ => e.to_string(),
    };
    CliError::new(exit, message)
}

/// Ctrl-C, remembered: once pressed it stays pressed, so a signal that arrives while a command
/// is busy (in a poll, a move) is never lost. Install it once per command, inside the runtime.
#[derive(Clone)]
pub struct Interrupt(std::sync::Arc<tokio::sync::watch::Sender<bool>>);

impl Interrupt {
    /// Starts listening for Ctrl-C.
    pub fn install() -> Interrupt {
        let tx = std::sync::Arc::new(tokio::sync::watch::Sender::new(false));
        let listener = tx.clone();
        tokio::spawn(async move {
            while tokio::signal::ctrl_c().await.is_ok() {
                listener.send_replace(true);
            }
        });
        Interrupt(tx)
    }

    /// Resolves once Ctrl-C has been pressed (and not cleared since).
    pub async fn wait(&self) {
        let mut rx = self.0.subscribe();
        if rx.wait_for(|pressed| *pressed).await.is_err() {
            std::future::pending::<()>().await;
        }
    }

    /// Forgets a Ctrl-C already handled (the shell goes on after one).
    pub fn clear(&self) {
        self.0.send_replace(false);
    }
}

/// Resolves when the user presses Ctrl-C (for `sim`, which has no session to close).
pub async fn ctrl_c() {
    if tokio::signal::ctrl_c().await.is_err() {
        std::future::pending::<()>().await;
    }
}

/// Ends the session cleanly (255), reporting but not failing on a dead link.
pub async fn close_quietly(robot: &Robot) {
    if let Err(e) = tokio::time::timeout(Duration::from_secs(3), robot.close())
        .await
        .unwrap_or(Err(ClientError::Closed))
    {
        tracing::info!("closing the session: {e}");
    }
}

/// Checks a joint target against the model before any connection is made.
pub fn check_target(model: &RobotModel, values: &[f64]) -> CliResult<fs020n_proto::JointsDeg> {
    let arr: [f64; 6] = values
        .try_into()
        .map_err(|_| CliError::input("expected 6 joint angles"))?;
    let j = fs020n_proto::JointsDeg::new(arr);
    if !j.is_finite() {
        return Err(CliError::input("joint angles must be finite numbers"));
    }
    model
        .check_limits(&j)
        .map_err(|e| CliError::input(format!("target refused before connecting: {e}")))?;
    Ok(j)
}

/// Longest `--timeout` accepted, seconds (a day).
pub const MAX_TIMEOUT_S: f64 = 86_400.0;

/// Checks a `--timeout` in seconds.
pub fn check_timeout(seconds: f64) -> CliResult<Duration> {
    if seconds.is_finite() && seconds > 0.0 && seconds <= MAX_TIMEOUT_S {
        Ok(Duration::from_secs_f64(seconds))
    } else {
        Err(CliError::input(format!(
            "--timeout {seconds} must be above 0 and at most {MAX_TIMEOUT_S} s"
        )))
    }
}

/// Checks a speed percent before any connection is made.
pub fn check_speed(percent: f64) -> CliResult<f64> {
    if percent.is_finite() && (1.0..=100.0).contains(&percent) {
        Ok(percent)
    } else {
        Err(CliError::input(format!(
            "speed {percent} % refused: give a speed from 1 to 100 %"
        )))
    }
}
