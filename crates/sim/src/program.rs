//! The AS program server: an AS program run instead of the native server, its interpreter
//! driving the [`Machine`] as its [`fs020n_as::System`] (`program/host.rs`) and its `TCP_…`
//! instructions served by the controller's socket table ([`fs020n_as::sockets::SocketTable`],
//! set up in `program/net.rs`).
//!
//! [`crate::Controller::with_program`] loads a program (e.g. this project's protocol-1040
//! server text, [`ServerProgram::server_1040`], or a user's modified copy): the interpreter runs
//! its tasks on the controller's clock, its motions go to the emulator's own motion planner
//! (the same joint moves, straight lines, blending, braking and limits as the native server),
//! its `SWITCH(…)`, `ERROR` and `MC …` read and operate the same panel, and its `TCP_…`
//! instructions use an in-controller TCP stack whose clients are the network layer
//! ([`crate::Emulator::serve_program_tcp`], [`crate::Emulator::connect_program`]) or a test
//! ([`crate::ProgramMut::connect`]). The pendant and fault injection work as with the
//! native server: reply faults apply to what the program sends to a client,
//! `close_connection` breaks the client connections, `stop_reading` stops delivering the
//! client's bytes.
//!
//! Choices (docs/AS.md, "In the emulator"):
//! - the first port the program listens on is the one served at the robot's address (every
//!   port it listens on is served too, through the port map: `server/program.rs`);
//! - a `TCP_CONNECT` to another host is a dial the network layer makes
//!   ([`crate::ProgramMut::take_dials`]), through the host map ([`crate::Network`]);
//! - `ACCURACY` is the distance of the flange to the target, as for the native server; FINE or
//!   CP OFF blend only once the motion is done;
//! - `SPEED … S` on an LMOVE is the motion time at monitor 100 % (scaled by the monitor speed),
//!   exactly as the native server's 0.1 s LMOVE; percent and mm/s speeds of an LMOVE are
//!   relative to [`MAX_TOOL_SPEED_MM_S`]; ACCEL/DECEL below 100 % are not modelled (the
//!   planner always uses the joints' full acceleration);
//! - `BRAKE` follows [`crate::Behaviour::planned_after_brake`] like command 5 of the native
//!   server; an `ONI` drops the planned motion.

mod host;
mod net;

use std::path::Path;
use std::time::Duration;

use fs020n_as::sockets::SocketTable;
use fs020n_as::{Config, Interpreter, LoadError, MotionRequest, TaskId, TerminalLine, TraceLine};
use fs020n_proto::ServerRequest;
use fs020n_proto::{JointsDeg, Status, PROTOCOL_VERSION};

use crate::machine::{Machine, ServerPicture};
use crate::snapshot::{CommandInfo, MotionTaskState, ProgramInfo, Refused, SessionInfo, Snapshot};
pub use host::MAX_TOOL_SPEED_MM_S;
use host::{panel_of, Host, MotionLink};
use net::{socket_table, Reach, UdpPorts};
pub use net::{ClientId, ClientRead, CLIENT_BUFFER};

/// An outgoing connection a program asked for (`TCP_CONNECT` to a mapped host), for the
/// network layer to make ([`crate::ProgramMut::take_dials`]): once connected (reported
/// with [`crate::ProgramMut::dialed`]) its bytes move as a client's, named by
/// `client`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ProgramDial {
    /// The connection's id (as a client's: [`crate::ProgramMut::send`], …).
    pub client: ClientId,
    /// The address the program connects to, in the cell.
    pub cell: std::net::SocketAddrV4,
    /// The real address the host map gives for it.
    pub to: std::net::SocketAddr,
}

/// Terminal lines shown in the snapshot.
pub const SNAPSHOT_TERMINAL_LINES: usize = 50;

/// An AS program loaded and compiled, ready to run in a controller.
#[derive(Debug, Clone)]
pub struct ServerProgram {
    interp: Interpreter,
    name: String,
    /// The bytes it was loaded from (the controller's program store keeps them).
    bytes: Vec<u8>,
    /// How it was loaded (the store rebuilds with the same options).
    load: fs020n_as::LoadOptions,
}

/// Why a program file could not be loaded.
#[derive(Debug, thiserror::Error)]
pub enum ProgramError {
    /// The file could not be read.
    #[error("cannot read the AS program {path}: {source}")]
    Read {
        /// The file.
        path: String,
        /// Why.
        source: std::io::Error,
    },
    /// The text does not parse or load (every error with file:line:column).
    #[error("the AS program does not load (nothing runs until it does):\n{0}")]
    Load(#[from] LoadError),
}

impl ServerProgram {
    /// Loads program text (`name` is the file name used in messages).
    pub fn from_source(name: &str, text: &str) -> Result<ServerProgram, LoadError> {
        ServerProgram::from_source_with(name, text, Config::default())
    }

    /// Loads program text with interpreter settings (cost model, …).
    pub fn from_source_with(
        name: &str,
        text: &str,
        config: Config,
    ) -> Result<ServerProgram, LoadError> {
        Ok(ServerProgram {
            interp: Interpreter::from_source(name, text, config)?,
            name: name.to_owned(),
            bytes: text.as_bytes().to_vec(),
            load: fs020n_as::LoadOptions::new(),
        })
    }

    /// Loads a program file.
    pub fn from_file(path: &Path) -> Result<ServerProgram, ProgramError> {
        ServerProgram::from_file_with(path, &fs020n_as::LoadOptions::default())
    }

    /// Loads a program file (its bytes, in any encoding) with load options (stubbed
    /// instructions), through the same loader as `fs020n as check`.
    pub fn from_file_with(
        path: &Path,
        opts: &fs020n_as::LoadOptions,
    ) -> Result<ServerProgram, ProgramError> {
        let bytes = std::fs::read(path).map_err(|source| ProgramError::Read {
            path: path.display().to_string(),
            source,
        })?;
        let name = path.display().to_string();
        let loaded = fs020n_as::Loaded::from_bytes(&name, &bytes, opts, Config::default())?;
        Ok(ServerProgram {
            interp: loaded.interpreter,
            name,
            bytes,
            load: opts.clone(),
        })
    }

    /// This project's AS text of the protocol-1040 server ([`fs020n_as::SERVER_1040`]).
    pub fn server_1040() -> Result<ServerProgram, LoadError> {
        ServerProgram::from_source("server1040.as", fs020n_as::SERVER_1040)
    }

    /// The file name.
    pub fn name(&self) -> &str {
        &self.name
    }

    /// The interpreter settings it was loaded with.
    pub(crate) fn config(&self) -> &Config {
        self.interp.config()
    }

    /// The text it was loaded from (bytes outside UTF-8 shown as U+FFFD).
    pub fn text(&self) -> std::borrow::Cow<'_, str> {
        String::from_utf8_lossy(&self.bytes)
    }

    /// The bytes it was loaded from, in the file's own code page.
    pub fn bytes(&self) -> &[u8] {
        &self.bytes
    }

    /// How it was loaded (instructions declared no-ops).
    pub fn load_options(&self) -> &fs020n_as::LoadOptions {
        &self.load
    }

    /// What loaded but is worth knowing (instructions not emulated, sections kept opaque), as
    /// messages: the warnings `fs020n as check` prints.
    pub fn warnings(&self) -> Vec<String> {
        self.interp
            .warnings()
            .iter()
            .map(|w| w.to_string())
            .collect()
    }
}

/// The program server inside a controller: the interpreter, its TCP stack and what the
/// machine's tick needs from it.
#[derive(Debug, Clone)]
pub(crate) struct ProgramServer {
    interp: Interpreter,
    name: String,
    net: SocketTable,
    /// The planned motion (re-planned after a BRAKE when the behaviour is to execute it).
    planned: Option<(MotionRequest, JointsDeg)>,
    link: MotionLink,
    /// The host's UDP sockets behind `UDP_SENDTO`/`UDP_RECVFROM`.
    udp: UdpPorts,
    /// Where the program's connections go (and which unmapped addresses were logged).
    reach: Reach,
    /// The robot task's state after the latest step.
    task: MotionTaskState,
}

impl ProgramServer {
    /// Loads `program` on `m`: its `autostart.pc` (… `autostart5.pc`) start at once, in PC
    /// tasks 1–5.
    pub(crate) fn start(program: ServerProgram, m: &mut Machine) -> ProgramServer {
        let mut p = ProgramServer {
            interp: program.interp,
            name: program.name,
            net: socket_table(),
            planned: None,
            link: MotionLink::default(),
            udp: UdpPorts::default(),
            reach: Reach::default(),
            task: MotionTaskState::NotRunning,
        };
        let (interp, mut host) = p.with_host(m);
        interp.start(&mut host);
        p
    }

    /// A program server over `interp` whose tasks do not run yet (the controller's terminal
    /// starts them), on a fresh TCP stack; its clock is brought to the machine's.
    pub(crate) fn idle(interp: Interpreter, name: String, m: &mut Machine) -> ProgramServer {
        let mut p = ProgramServer {
            interp,
            name,
            net: socket_table(),
            planned: None,
            link: MotionLink::default(),
            udp: UdpPorts::default(),
            reach: Reach::default(),
            task: MotionTaskState::NotRunning,
        };
        p.run_until(m, m.now());
        p
    }

    /// Replaces the programs (the terminal loaded or deleted some while every task was
    /// idle): the sockets stay as they are, the new interpreter's clock is brought to the
    /// machine's.
    pub(crate) fn replace_interpreter(&mut self, interp: Interpreter, m: &mut Machine) {
        self.interp = interp;
        self.planned = None;
        self.run_until(m, m.now());
    }

    /// A controller restart: every socket closes and `interp` replaces the programs.
    pub(crate) fn restart(&mut self, interp: Interpreter, m: &mut Machine) {
        self.net.restart();
        self.udp.close_all();
        self.link = MotionLink::default();
        self.task = MotionTaskState::NotRunning;
        self.replace_interpreter(interp, m);
    }

    /// The address the program's UDP sockets bind to.
    pub(crate) fn udp_address(&self) -> std::net::Ipv4Addr {
        self.udp.address()
    }

    /// Binds the program's UDP sockets to `address` from their next use on.
    pub(crate) fn set_udp_address(&mut self, address: std::net::Ipv4Addr) {
        self.udp.set_address(address);
    }

    /// The interpreter (the terminal's commands act on it).
    pub(crate) fn interpreter(&self) -> &Interpreter {
        &self.interp
    }

    /// The interpreter, to start and stop tasks.
    pub(crate) fn interpreter_mut(&mut self) -> &mut Interpreter {
        &mut self.interp
    }

    /// The interpreter and the system it runs on: the machine `m` with this server's sockets,
    /// motion link and network reach.
    fn with_host<'a>(&'a mut self, m: &'a mut Machine) -> (&'a mut Interpreter, Host<'a>) {
        let host = Host {
            m,
            net: &mut self.net,
            planned: &mut self.planned,
            link: &mut self.link,
            udp: &mut self.udp,
            reach: &mut self.reach,
        };
        (&mut self.interp, host)
    }

    /// `EXECUTE program, cycles` in robot task 1, with the controller's checks.
    pub(crate) fn execute(
        &mut self,
        m: &mut Machine,
        program: &str,
        cycles: i64,
    ) -> Result<(), fs020n_as::Refusal> {
        let (interp, mut host) = self.with_host(m);
        interp.execute_cycles(program, cycles, &mut host)
    }

    /// A statement typed at the terminal, run at once ([`Interpreter::immediate`]).
    pub(crate) fn immediate(
        &mut self,
        m: &mut Machine,
        statement: &str,
    ) -> Result<Vec<String>, fs020n_as::ImmediateError> {
        let (interp, mut host) = self.with_host(m);
        interp.immediate(statement, &mut host)
    }

    /// Runs the program's tasks up to `t`; they advance the machine up to each of their steps.
    pub(crate) fn run_until(&mut self, m: &mut Machine, t: Duration) {
        let (interp, mut host) = self.with_host(m);
        interp.run_until(&mut host, t);
        let task = interp.task_state(TaskId::Robot, &host);
        self.task = match task {
            fs020n_as::TaskState::Idle => MotionTaskState::NotRunning,
            fs020n_as::TaskState::Running => MotionTaskState::Running,
            fs020n_as::TaskState::Paused => MotionTaskState::Paused,
            fs020n_as::TaskState::WaitingMotion => MotionTaskState::Finishing,
        };
    }

    // ----------------------------------------------------------------- observers

    /// The robot task's state after the latest step.
    pub(crate) fn task(&self) -> MotionTaskState {
        self.task
    }

    /// The ABS.SPEED system switch as the program sees it.
    pub(crate) fn abs_speed(&self) -> bool {
        self.interp.system_switch("abs.speed").unwrap_or(false)
    }

    pub(crate) fn set_abs_speed(&mut self, on: bool) {
        self.interp.set_system_switch("abs.speed", on);
    }

    /// The status reply as the native server would send it now (a program builds its own).
    pub(crate) fn status(&self, m: &Machine) -> Status {
        m.status(self.task == MotionTaskState::Running, 0.0)
    }

    /// The tasks now (program, line, state), without the terminal lines of [`Self::info`].
    pub(crate) fn tasks(&self, m: &Machine) -> Vec<fs020n_as::TaskInfo> {
        self.interp.tasks_at(panel_of(m), !m.arm().is_still())
    }

    pub(crate) fn info(&self, m: &Machine) -> ProgramInfo {
        let moving = !m.arm().is_still();
        let terminal: Vec<TerminalLine> = self.interp.terminal().cloned().collect();
        let skip = terminal.len().saturating_sub(SNAPSHOT_TERMINAL_LINES);
        ProgramInfo {
            name: self.name.clone(),
            served_port: self.net.served_port(),
            tasks: self.interp.tasks_at(panel_of(m), moving),
            terminal: terminal[skip..].to_vec(),
        }
    }

    /// A serializable picture of the machine and this server now.
    pub(crate) fn snapshot(&self, m: &Machine) -> Snapshot {
        m.snapshot(ServerPicture {
            task: self.task,
            abs_speed: self.abs_speed(),
            step_s: 0.0,
            last_pass: None,
            program_executes: false,
            session: self.session_info(m),
            program: Some(self.info(m)),
        })
    }

    /// The session part of the snapshot: a client of the served port, and the newest request
    /// when the program keeps the protocol-1040 ring (`ros_cmd_ind`, `ros_cmd[…]`).
    fn session_info(&self, m: &Machine) -> SessionInfo {
        // An accepted client of the served port (not one still waiting in a backlog).
        let client = self
            .net
            .served_port()
            .and_then(|p| self.net.accepted_client_on(p));
        let open = client.is_some();
        let newest = self.interp.real("ros_cmd_ind").and_then(|ind| {
            let ind = ind as i32;
            let number = self.interp.real_at("ros_cmd", &[ind, 0])?;
            let count = self.interp.real_at("ros_cmd", &[ind, 1]).unwrap_or(0.0);
            let count = if count >= 1.0 {
                (count as usize).min(128)
            } else {
                0
            };
            let args = (0..count)
                .map(|k| {
                    f64::from(
                        self.interp
                            .real_at("ros_cmd", &[ind, 2 + k as i32])
                            .unwrap_or(0.0),
                    )
                })
                .collect();
            let cmd = ServerRequest {
                version: PROTOCOL_VERSION as f64,
                command_number: f64::from(number),
                count,
                args,
            }
            .command();
            Some((
                ind,
                CommandInfo {
                    number: cmd.number(),
                    command: cmd,
                },
            ))
        });
        SessionInfo {
            open,
            id: client.map(|c| c as u64),
            timer1_s: open.then(|| f64::from(self.interp.timer(1))),
            newest_index: newest.as_ref().filter(|_| open).map(|(i, _)| *i as usize),
            newest_command: newest.filter(|_| open).map(|(_, c)| c),
            listening: self.listening(None),
            reading_paused: m.reading_paused_until().is_some(),
            last_end: None,
        }
    }

    pub(crate) fn terminal(&self) -> Vec<TerminalLine> {
        self.interp.terminal().cloned().collect()
    }

    pub(crate) fn set_trace(&mut self, on: bool) {
        self.interp.set_trace(on);
    }

    pub(crate) fn take_trace(&mut self) -> Vec<TraceLine> {
        self.interp.take_trace()
    }

    pub(crate) fn next_event(&self) -> Option<Duration> {
        self.interp.next_event()
    }

    pub(crate) fn signal(&self, n: i32) -> bool {
        self.interp.signal(n)
    }

    pub(crate) fn set_input(&mut self, n: i32, on: bool) {
        self.interp.set_signal(n, on);
    }

    pub(crate) fn real(&self, name: &str) -> Option<f32> {
        self.interp.real(name)
    }

    // ----------------------------------------------------------------- clients

    /// Counts every change a client can see (listening, data, a close).
    pub(crate) fn io_generation(&self) -> u64 {
        self.net.generation()
    }

    /// The port served at the robot's address (the first the program listened on).
    pub(crate) fn served_port(&self) -> Option<u16> {
        self.net.served_port()
    }

    /// The ports the program listens on now.
    pub(crate) fn listening_ports(&self) -> Vec<u16> {
        self.net.listening_ports()
    }

    /// Takes the outgoing connections to make (`TCP_CONNECT` to mapped hosts), each with the
    /// real address the host map gives now; one whose address is no longer mapped fails at
    /// once (E4023).
    pub(crate) fn take_dials(&mut self, m: &Machine) -> Vec<ProgramDial> {
        let mut out = Vec::new();
        for d in self.net.take_dials() {
            let cell = std::net::SocketAddrV4::new(d.ip.into(), d.port);
            match m.network().route(d.ip) {
                crate::network::Route::Host(real) => out.push(ProgramDial {
                    client: ClientId(d.id),
                    cell,
                    to: std::net::SocketAddr::new(real, d.port),
                }),
                _ => {
                    self.net
                        .dial_done(d.id, Err(fs020n_as::sockets::TcpCode::Unreachable.code()));
                }
            }
        }
        out
    }

    /// The network layer's outcome of a dial; `false` when the program no longer waits for it
    /// (the layer closes the connection).
    pub(crate) fn dialed(&mut self, client: ClientId, result: Result<(), i32>) -> bool {
        self.net.dial_done(client.0, result)
    }

    /// `true` while the program listens on `port` (`None`: the served port).
    pub(crate) fn listening(&self, port: Option<u16>) -> bool {
        port.or(self.net.served_port())
            .is_some_and(|p| self.net.listening(p))
    }

    /// Breaks every client connection (fault injection: the program sees the connection
    /// broken on its next receive or send).
    pub(crate) fn close_clients(&mut self) {
        self.net.break_clients();
    }

    /// A client connects to `port` (`None`: the served port) from `ip`, refused (and counted)
    /// while the program does not listen there.
    pub(crate) fn connect(
        &mut self,
        m: &mut Machine,
        port: Option<u16>,
        ip: [u8; 4],
    ) -> Result<ClientId, Refused> {
        port.or(self.net.served_port())
            .and_then(|port| self.net.client_connect(port, ip))
            .map(ClientId)
            .ok_or_else(|| {
                m.counters_mut().refused += 1;
                Refused::ListenGap
            })
    }

    /// A client sends bytes; `false` when its connection is gone (closed by the program).
    pub(crate) fn send(&mut self, client: ClientId, bytes: &[u8]) -> bool {
        self.net.client_send(client.0, bytes)
    }

    /// What a client reads at `now`.
    pub(crate) fn recv(&mut self, now: Duration, client: ClientId) -> ClientRead {
        self.net.client_read(client.0, now)
    }

    /// The client closes its connection (the program's next receive reports it broken).
    pub(crate) fn close(&mut self, client: ClientId) {
        self.net.client_close(client.0);
    }
}
