//! Shared plumbing of the commands that talk to a robot: the runtime, connecting, the embedded
//! emulator, error mapping and Ctrl-C.

use std::net::SocketAddr;
use std::time::Duration;

use fs020n_client::{ClientConfig, ClientError, Robot};
use fs020n_kin::RobotModel;
use fs020n_sim::{ControllerConfig, Emulator, TcpServer};

use crate::error::client_error;
use crate::error::{CliError, CliResult};
use crate::output::rounded;

/// Default robot address when `--robot` is not given (where `fs020n sim` listens).
pub(crate) const DEFAULT_ROBOT: &str = "127.0.0.1:10050";

/// What every robot command needs.
#[derive(Debug)]
pub(crate) struct Ctx {
    /// The robot's address.
    pub(crate) addr: Option<String>,
    /// Print JSON.
    pub(crate) json: bool,
    /// The robot model.
    pub(crate) model: RobotModel,
    /// Overall connect timeout.
    pub(crate) connect_timeout: Duration,
    /// stderr is a terminal: show what takes time (connecting, progress).
    pub(crate) interactive: bool,
    /// `--record FILE`: every request and reply of the session.
    pub(crate) record: Option<fs020n_client::Recording>,
}

impl Ctx {
    /// The address to use: `--robot`, else the default.
    pub(crate) fn addr_or_default(&self) -> String {
        self.addr
            .clone()
            .unwrap_or_else(|| DEFAULT_ROBOT.to_owned())
    }

    /// The client configuration for this robot.
    pub(crate) fn client_config(&self) -> ClientConfig {
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
pub(crate) fn runtime() -> CliResult<tokio::runtime::Runtime> {
    tokio::runtime::Builder::new_multi_thread()
        .worker_threads(2)
        .enable_all()
        .build()
        .map_err(|e| CliError::failure(format!("cannot start the async runtime: {e}")))
}

/// A single-threaded runtime for a command that talks to one robot: the client's session task
/// and the command's own loop share one thread, so a round trip wakes no other thread (fewer
/// context switches and futex calls than on a thread pool; docs/PERFORMANCE.md, "Client").
pub(crate) fn runtime_one_thread() -> CliResult<tokio::runtime::Runtime> {
    tokio::runtime::Builder::new_current_thread()
        .enable_all()
        .build()
        .map_err(|e| CliError::failure(format!("cannot start the async runtime: {e}")))
}

/// How long connecting may take before a terminal is told what is going on.
const CONNECT_NOTICE_AFTER: Duration = Duration::from_millis(300);

/// Connects to `addr`. On a terminal, says so when it takes more than a moment (the
/// controller listens in 3 s windows, so a connect can take seconds).
pub(crate) async fn connect(addr: &str, ctx: &Ctx) -> CliResult<Robot> {
    let connecting = Robot::connect(addr, ctx.client_config());
    tokio::pin!(connecting);
    let r = tokio::select! {
        r = &mut connecting => r,
        () = tokio::time::sleep(CONNECT_NOTICE_AFTER), if ctx.interactive => {
            eprintln!(
                "connecting to {addr} (the controller listens in 3 s windows; giving up after {})…",
                rounded(ctx.connect_timeout)
            );
            connecting.await
        }
    };
    r.map_err(client_error)
}

/// An emulator inside this process on a free loopback port.
pub(crate) struct Embedded {
    /// The emulator (for observing it).
    pub emulator: Emulator,
    /// Its robot port.
    pub server: TcpServer,
}

impl Embedded {
    /// Starts the embedded emulator (call inside the runtime).
    pub(crate) async fn start(model: &RobotModel) -> CliResult<Embedded> {
        let emulator = Emulator::new(ControllerConfig::new(model.clone()));
        let addr: SocketAddr = ([127, 0, 0, 1], 0).into();
        let server = emulator
            .serve_tcp(addr)
            .await
            .map_err(|e| CliError::failure(format!("cannot start the embedded emulator: {e}")))?;
        Ok(Embedded { emulator, server })
    }

    /// Its address as HOST:PORT.
    pub(crate) fn addr(&self) -> String {
        self.server.local_addr().to_string()
    }
}

/// The robot of `demo` and `bench`: `--robot` if given, else an embedded emulator (returned so
/// that it lives as long as the session).
pub(crate) async fn robot_or_embedded(ctx: &Ctx) -> CliResult<(String, Option<Embedded>)> {
    match &ctx.addr {
        Some(addr) => Ok((addr.clone(), None)),
        None => {
            let e = Embedded::start(&ctx.model).await?;
            Ok((e.addr(), Some(e)))
        }
    }
}

/// Ctrl-C, remembered: once pressed it stays pressed, so a signal that arrives while a command
/// is busy (in a poll, a move) is never lost. Install it once per command, inside the runtime.
#[derive(Clone)]
pub(crate) struct Interrupt(std::sync::Arc<tokio::sync::watch::Sender<bool>>);

impl Interrupt {
    /// Starts listening for Ctrl-C.
    pub(crate) fn install() -> Interrupt {
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
    pub(crate) async fn wait(&self) {
        let mut rx = self.0.subscribe();
        if rx.wait_for(|pressed| *pressed).await.is_err() {
            std::future::pending::<()>().await;
        }
    }

    /// Forgets a Ctrl-C already handled (the shell goes on after one).
    pub(crate) fn clear(&self) {
        self.0.send_replace(false);
    }
}

/// Resolves when the user presses Ctrl-C (for `sim`, which has no session to close).
pub(crate) async fn ctrl_c() {
    if tokio::signal::ctrl_c().await.is_err() {
        std::future::pending::<()>().await;
    }
}

/// Ends the session cleanly (255), reporting but not failing on a dead link.
pub(crate) async fn close_quietly(robot: &Robot) {
    if let Err(e) = tokio::time::timeout(Duration::from_secs(3), robot.close())
        .await
        .unwrap_or(Err(ClientError::Closed))
    {
        tracing::info!("closing the session: {e}");
    }
}

/// Checks a joint target against the model; `when` says what was not done yet ("before
/// connecting", "; nothing was sent").
pub(crate) fn check_target(
    model: &RobotModel,
    values: &[f64],
    when: &str,
) -> CliResult<fs020n_proto::JointsDeg> {
    let arr: [f64; 6] = values
        .try_into()
        .map_err(|_| CliError::input("expected 6 joint angles"))?;
    let j = fs020n_proto::JointsDeg::new(arr);
    if !j.is_finite() {
        return Err(CliError::input("joint angles must be finite numbers"));
    }
    model
        .check_limits(&j)
        .map_err(|e| CliError::input(format!("target refused{when}: {e}")))?;
    Ok(j)
}

/// Longest `--timeout` accepted, seconds (a day).
pub(crate) const MAX_TIMEOUT_S: f64 = 86_400.0;

/// Checks a `--timeout` in seconds.
pub(crate) fn check_timeout(seconds: f64) -> CliResult<Duration> {
    if seconds.is_finite() && seconds > 0.0 && seconds <= MAX_TIMEOUT_S {
        Ok(Duration::from_secs_f64(seconds))
    } else {
        Err(CliError::input(format!(
            "--timeout {seconds} must be above 0 and at most {MAX_TIMEOUT_S} s"
        )))
    }
}

/// Checks a speed percent before any connection is made.
pub(crate) fn check_speed(percent: f64) -> CliResult<f64> {
    if percent.is_finite() && (1.0..=100.0).contains(&percent) {
        Ok(percent)
    } else {
        Err(CliError::input(format!(
            "speed {percent} % refused: give a speed from 1 to 100 %"
        )))
    }
}
