//! Starting a whole emulated robot (robot port + optional pendant API) from options a command
//! line maps to. Several robots in one process: several [`run_robot`] calls with different ports.

use std::io;
use std::net::SocketAddr;
use std::path::PathBuf;

use fs020n_kin::RobotModel;
use fs020n_proto::DEFAULT_PORT;
use fs020n_proto::{ErrorCode, JointsDeg};

use crate::controller::{Controller, ProgramStart};
use crate::machine::ControllerConfig;
use crate::network::{Network, PortMap};
use crate::panel::Panel;
#[cfg(feature = "pendant")]
use crate::pendant::{serve_pendant, PendantServer};
use crate::server::{Emulator, ProgramPorts, TcpServer, LISTENERS_WAIT};

/// Everything needed to start one emulated robot. `SimOptions::default()` is a ready-to-run
/// FS020N on `127.0.0.1:10050`, monitor speed from the model (10 %), at the model's home pose,
/// no pendant API.
#[derive(Debug, Clone, PartialEq)]
pub struct SimOptions {
    /// Robot (protocol) port address. Default `127.0.0.1:10050`; port 0 picks a free one.
    pub listen: SocketAddr,
    /// Pendant API address (`None`: no pendant API).
    pub pendant: Option<SocketAddr>,
    /// Bearer token of the pendant API (mandatory when it is bound off loopback).
    pub pendant_token: Option<String>,
    /// Robot-model file (TOML, see fs020n-kin); `None`: the built-in FS020N model.
    pub model_file: Option<PathBuf>,
    /// A model given directly (takes precedence over `model_file`).
    pub model: Option<RobotModel>,
    /// Initial panel switches.
    pub panel: Panel,
    /// Initial monitor speed, percent (`None`: the model's default).
    pub monitor_speed_percent: Option<f64>,
    /// Initial joints, degrees (`None`: the model's home pose).
    pub joints: Option<JointsDeg>,
    /// Initial error (default none).
    pub error: ErrorCode,
    /// An AS program file to run instead of the native server (`None`: the native server).
    /// The first port it listens on is served at [`SimOptions::listen`].
    pub program: Option<PathBuf>,
    /// How [`SimOptions::program`] is loaded (instructions declared no-ops, `--stub`).
    pub program_load: fs020n_as::LoadOptions,
    /// A new controller with nothing loaded (`--bare`): no protocol port until a program is
    /// loaded through the terminal and started; then the first port it listens on is served at
    /// [`SimOptions::listen`]. Excludes [`SimOptions::program`].
    pub bare: bool,
    /// The controller's AS monitor terminal address (`None`: no terminal).
    pub terminal: Option<SocketAddr>,
    /// Largest piece of the terminal's output sent at once (`None`: whole replies; a real
    /// controller's text comes in pieces).
    pub terminal_piece: Option<usize>,
    /// How the terminal plays its controller generation and test hooks (see
    /// [`fs020n_term::SessionConfig::of`]); its `max_piece` is [`SimOptions::terminal_piece`].
    pub terminal_session: fs020n_term::SessionConfig,
    /// The controller's address and the hosts its programs reach (`--address`, `--host`).
    pub network: Network,
    /// Where every port an AS program listens on is served, at the IP address of
    /// [`SimOptions::listen`] (`--port-map`; default: the same port numbers). The first port
    /// is also served at [`SimOptions::listen`].
    pub ports: PortMap,
    /// Input signals (1001–1999) set before any program step runs (`--signal N=1`).
    pub inputs: Vec<(i32, bool)>,
    /// Programs started once the ports are served, in order, as `PCEXECUTE`/`EXECUTE` start
    /// them (`--pcexecute`, `--execute`): each has run to its first wait, and the ports it
    /// listens on are served, when [`run_robot`] returns. Needs [`SimOptions::program`].
    pub start: Vec<ProgramStart>,
}

impl Default for SimOptions {
    fn default() -> Self {
        SimOptions {
            listen: SocketAddr::from(([127, 0, 0, 1], DEFAULT_PORT)),
            pendant: None,
            pendant_token: None,
            model_file: None,
            model: None,
            panel: Panel::default(),
            monitor_speed_percent: None,
            joints: None,
            error: ErrorCode::NONE,
            program: None,
            program_load: fs020n_as::LoadOptions::new(),
            bare: false,
            terminal: None,
            terminal_piece: None,
            terminal_session: fs020n_term::SessionConfig::default(),
            network: Network::default(),
            ports: PortMap::default(),
            inputs: Vec::new(),
            start: Vec::new(),
        }
    }
}

impl SimOptions {
    /// Runs this AS program file instead of the native server.
    pub fn program(mut self, path: impl Into<PathBuf>) -> Self {
        self.program = Some(path.into());
        self
    }

    /// Starts a new controller with nothing loaded (see [`SimOptions::bare`]).
    pub fn bare(mut self) -> Self {
        self.bare = true;
        self
    }

    /// Serves the controller's AS monitor terminal on `addr`.
    pub fn terminal(mut self, addr: SocketAddr) -> Self {
        self.terminal = Some(addr);
        self
    }

    /// Sets the controller's address and host map.
    pub fn network(mut self, network: Network) -> Self {
        self.network = network;
        self
    }

    /// Sets where the AS program's listening ports are served.
    pub fn ports(mut self, ports: PortMap) -> Self {
        self.ports = ports;
        self
    }

    /// Sets the robot port address.
    pub fn listen(mut self, addr: SocketAddr) -> Self {
        self.listen = addr;
        self
    }

    /// Serves the pendant API on `addr`.
    pub fn pendant(mut self, addr: SocketAddr) -> Self {
        self.pendant = Some(addr);
        self
    }

    /// Sets the pendant API token.
    pub fn pendant_token(mut self, token: impl Into<String>) -> Self {
        self.pendant_token = Some(token.into());
        self
    }

    /// Loads the robot model from this file.
    pub fn model_file(mut self, path: impl Into<PathBuf>) -> Self {
        self.model_file = Some(path.into());
        self
    }

    /// Sets the initial panel.
    pub fn panel(mut self, panel: Panel) -> Self {
        self.panel = panel;
        self
    }

    /// Sets the initial monitor speed, percent.
    pub fn monitor_speed(mut self, percent: f64) -> Self {
        self.monitor_speed_percent = Some(percent);
        self
    }

    /// Sets the initial joints, degrees.
    pub fn joints(mut self, joints: JointsDeg) -> Self {
        self.joints = Some(joints);
        self
    }

    /// Sets the initial error.
    pub fn error(mut self, error: ErrorCode) -> Self {
        self.error = error;
        self
    }

    /// The controller configuration these options describe: loads the model file and checks
    /// the initial monitor speed (0 < % ≤ 100) and joints (finite, inside the joint ranges).
    /// Errors are `InvalidInput`/`InvalidData`/`NotFound` with a message saying what to fix.
    pub fn controller_config(&self) -> io::Result<ControllerConfig> {
        let model = match (&self.model, &self.model_file) {
            (Some(m), _) => m.clone(),
            (None, Some(path)) => RobotModel::from_file(path).map_err(|e| {
                let kind = if path.exists() {
                    io::ErrorKind::InvalidData
                } else {
                    io::ErrorKind::NotFound
                };
                io::Error::new(kind, format!("robot model {}: {e}", path.display()))
            })?,
            (None, None) => RobotModel::fs020n(),
        };
        let mut config = ControllerConfig::new(model);
        config.network = self.network.clone();
        config.panel = self.panel;
        config.error = self.error;
        if let Some(p) = self.monitor_speed_percent {
            if !(p.is_finite() && p > 0.0 && p <= 100.0) {
                return Err(io::Error::new(
                    io::ErrorKind::InvalidInput,
                    format!("monitor speed {p} % is outside 0 < speed <= 100"),
                ));
            }
            config.monitor_speed_percent = p;
        }
        if let Some(j) = self.joints {
            if !j.is_finite() {
                return Err(io::Error::new(
                    io::ErrorKind::InvalidInput,
                    format!("initial joints {j} are not all finite numbers"),
                ));
            }
            config.model.check_limits(&j).map_err(|e| {
                io::Error::new(
                    io::ErrorKind::InvalidInput,
                    format!("initial joints {j}: {e}"),
                )
            })?;
            config.joints = j;
        }
        Ok(config)
    }
}

/// One running emulated robot: its emulator, robot port and (optional) pendant API.
#[derive(Debug)]
pub struct RunningRobot {
    emulator: Emulator,
    robot: TcpServer,
    /// Every port an AS program listens on (none for the native server).
    ports: Option<ProgramPorts>,
    terminal: Option<TcpServer>,
    #[cfg(feature = "pendant")]
    pendant: Option<PendantServer>,
}

impl RunningRobot {
    /// The emulator (observe it, operate the pendant, inject faults).
    pub fn emulator(&self) -> &Emulator {
        &self.emulator
    }

    /// The bound robot (protocol) port address.
    pub fn robot_addr(&self) -> SocketAddr {
        self.robot.local_addr()
    }

    /// The bound terminal address, if served.
    pub fn terminal_addr(&self) -> Option<SocketAddr> {
        self.terminal.as_ref().map(TcpServer::local_addr)
    }

    /// The bound pendant API address, if served (always `None` without the `pendant` feature).
    pub fn pendant_addr(&self) -> Option<SocketAddr> {
        #[cfg(feature = "pendant")]
        return self.pendant.as_ref().map(PendantServer::local_addr);
        #[cfg(not(feature = "pendant"))]
        None
    }

    /// Stops both servers (an open session is dropped).
    pub fn stop(self) {
        self.robot.stop();
        if let Some(p) = self.ports {
            p.stop();
        }
        if let Some(t) = self.terminal {
            t.stop();
        }
        #[cfg(feature = "pendant")]
        if let Some(p) = self.pendant {
            p.stop();
        }
    }
}

/// Starts one emulated robot: checks the options, binds the robot port (listening in 3-second
/// windows as the controller does) and, if asked, the pendant API. Must run inside a tokio
/// runtime; the servers run until [`RunningRobot::stop`].
pub async fn run_robot(opts: SimOptions) -> io::Result<RunningRobot> {
    let config = opts.controller_config()?;
    #[cfg(not(feature = "pendant"))]
    if let Some(addr) = opts.pendant {
        return Err(io::Error::new(
            io::ErrorKind::Unsupported,
            format!(
                "a pendant API on {addr} was asked for, but this build has none (enable the \
                 `pendant` feature of fs020n-sim)"
            ),
        ));
    }
    if let Some(addr) = opts.pendant {
        if !addr.ip().is_loopback() && opts.pendant_token.as_deref().unwrap_or("").is_empty() {
            return Err(io::Error::new(
                io::ErrorKind::InvalidInput,
                format!("the pendant API on {addr} (off loopback) needs a token"),
            ));
        }
    }
    if opts.bare && opts.program.is_some() {
        return Err(io::Error::new(
            io::ErrorKind::InvalidInput,
            "--bare starts a controller with nothing loaded and --as-program one running a \
             program: choose one",
        ));
    }
    if !opts.start.is_empty() && opts.program.is_none() {
        return Err(io::Error::new(
            io::ErrorKind::InvalidInput,
            "starting programs (--pcexecute, --execute) needs the AS file that holds them \
             (--as-program FILE); on a bare controller, load and start them at the terminal",
        ));
    }
    let (emulator, robot) = match &opts.program {
        None if opts.bare => {
            let load = opts.program_load.clone();
            let emulator = Emulator::driven(Controller::bare(config, load));
            let robot = emulator.serve_program_tcp(opts.listen).await;
            (emulator, robot)
        }
        None => {
            let emulator = Emulator::new(config);
            let robot = emulator.serve_tcp(opts.listen).await;
            (emulator, robot)
        }
        Some(path) => {
            let load = &opts.program_load;
            let program =
                crate::program::ServerProgram::from_file_with(path, load).map_err(|e| {
                    let kind = match &e {
                        crate::program::ProgramError::Read { source, .. } => source.kind(),
                        crate::program::ProgramError::Load(_) => io::ErrorKind::InvalidData,
                    };
                    io::Error::new(kind, e.to_string())
                })?;
            let emulator = Emulator::with_program(config, program);
            emulator.with(|c| {
                for &(n, on) in &opts.inputs {
                    c.program_mut().set_input(n, on);
                }
            });
            let robot = emulator.serve_program_tcp(opts.listen).await;
            (emulator, robot)
        }
    };
    let robot = robot.map_err(|e| {
        io::Error::new(
            e.kind(),
            format!("cannot listen on robot port {}: {e}", opts.listen),
        )
    })?;
    let terminal = match opts.terminal {
        Some(addr) => {
            let config = fs020n_term::SessionConfig {
                max_piece: opts.terminal_piece.unwrap_or(usize::MAX).max(1),
                ..opts.terminal_session.clone()
            };
            match emulator.serve_terminal(addr, config).await {
                Ok(t) => Some(t),
                Err(e) => {
                    robot.stop();
                    return Err(io::Error::new(
                        e.kind(),
                        format!("cannot serve the terminal on {addr}: {e}"),
                    ));
                }
            }
        }
        None => None,
    };
    #[cfg(feature = "pendant")]
    let pendant = match opts.pendant {
        Some(addr) => match serve_pendant(emulator.clone(), addr, opts.pendant_token.clone()).await
        {
            Ok(p) => Some(p),
            Err(e) => {
                robot.stop();
                if let Some(t) = terminal {
                    t.stop();
                }
                return Err(io::Error::new(
                    e.kind(),
                    format!("cannot serve the pendant API on {addr}: {e}"),
                ));
            }
        },
        None => None,
    };
    // An AS program's every port, beside the first at the robot address.
    let ports = (opts.bare || opts.program.is_some()).then(|| {
        emulator.serve_program_ports(
            opts.listen.ip(),
            opts.ports.clone(),
            Some(robot.local_addr()),
        )
    });
    // The autostart programs have run to their first wait, as a start at the terminal has
    // (their ports listening, or the error that stopped them known) before anything is said.
    if opts.program.is_some() {
        emulator.with(|c| {
            for n in 1..=5 {
                if c.program().task_running(fs020n_as::TaskId::Pc(n)) {
                    c.program_mut().run_first_steps(fs020n_as::TaskId::Pc(n));
                }
            }
        });
    }
    for start in &opts.start {
        let started = emulator.with(|c| c.program_mut().start(start));
        if let Err(e) = started {
            let programs = emulator.with(|c| c.memory().programs()).join(", ");
            robot.stop();
            if let Some(t) = terminal {
                t.stop();
            }
            #[cfg(feature = "pendant")]
            if let Some(p) = pendant {
                p.stop();
            }
            if let Some(p) = ports {
                p.stop();
            }
            return Err(io::Error::new(
                io::ErrorKind::InvalidInput,
                format!(
                    "cannot {start}: {} (the file's programs: {programs})",
                    e.line()
                ),
            ));
        }
        tracing::info!(%start, "program started");
    }
    if opts.program.is_some() && !emulator.wait_program_listeners(LISTENERS_WAIT).await {
        tracing::warn!(
            "a started program listens on a port whose host socket is not listening after \
             {LISTENERS_WAIT:?}"
        );
    }
    if !robot.local_addr().ip().is_loopback() {
        tracing::warn!(
            robot = %robot.local_addr(),
            "the robot port is bound off loopback: protocol 1040 has no authentication"
        );
    }
    let running = RunningRobot {
        emulator,
        robot,
        ports,
        terminal,
        #[cfg(feature = "pendant")]
        pendant,
    };
    tracing::info!(robot = %running.robot_addr(), pendant = ?running.pendant_addr(), terminal = ?running.terminal_addr(), address = %opts.network.address, hosts = ?opts.network.hosts, "emulated robot running");
    Ok(running)
}
