//! Running an AS program instead of the native server: the controller as the
//! [`fs020n_as::System`] of an [`fs020n_as::Interpreter`].
//!
//! [`Controller::with_program`] loads a program (e.g. this project's protocol-1040 server text,
//! [`ServerProgram::server_1040`], or a user's modified copy): the interpreter runs its tasks
//! on the controller's clock, its motions go to the emulator's own motion planner (the same
//! joint moves, straight lines, blending, braking and limits as the native server), its
//! `SWITCH(…)`, `ERROR` and `MC …` read and operate the same panel, and its `TCP_…`
//! instructions use an in-controller TCP stack whose clients are the network layer
//! ([`crate::Emulator::serve_program_tcp`], [`crate::Emulator::connect_program`]) or a test
//! ([`Controller::program_connect`]). The pendant and fault injection work as with the native
//! server: reply faults apply to what the program sends to a client, `close_connection` breaks
//! the client connections, `stop_reading` stops delivering the client's bytes.
//!
//! Choices (docs/AS.md, "In the emulator"):
//! - the first port the program listens on is the one served at the robot's address;
//! - `ACCURACY` is the distance of the flange to the target, as for the native server; FINE or
//!   CP OFF blend only once the motion is done;
//! - `SPEED … S` on an LMOVE is the motion time at monitor 100 % (scaled by the monitor speed),
//!   exactly as the native server's 0.1 s LMOVE; percent and mm/s speeds of an LMOVE are
//!   relative to [`MAX_TOOL_SPEED_MM_S`]; ACCEL/DECEL below 100 % are not modelled (the
//!   planner always uses the joints' full acceleration);
//! - `BRAKE` follows [`crate::Behaviour::planned_after_brake`] like command 5 of the native
//!   server; an `ONI` drops the planned motion.

use std::collections::{BTreeMap, VecDeque};
use std::path::Path;
use std::time::Duration;

use fs020n_as::{
    Config, Interpreter, Issued, Joints, LoadError, MotionKind, MotionRequest, PanelState,
    SockPoll, Speed, System, Target, TaskId, TaskInfo, TerminalLine, TraceLine, Trans,
};
use fs020n_kin::{JointMove, Pose, Xyzoat};
use fs020n_proto::server::ServerRequest;
use fs020n_proto::{ErrorCode, JointsDeg, PROTOCOL_VERSION};
use serde::Serialize;

use crate::controller::{Controller, ControllerConfig, PlannedAfterBrake, Refused};
use crate::fault::ReplyFault;
use crate::motion::{LinearPath, Motion, Shape};
use crate::snapshot::{CommandInfo, SessionInfo, TaskState};

/// Tool speed that percent and mm/s speeds of an `LMOVE` refer to, mm/s (an assumption: the
/// FS020N's maximum TCP speed is not published; the protocol-1040 server uses time-based
/// LMOVEs, which do not depend on it).
pub const MAX_TOOL_SPEED_MM_S: f64 = 2000.0;

/// Bytes a client's outgoing queue holds before the program's `TCP_SEND` waits (like a socket
/// send buffer: a client that stops reading makes the program's send time out).
pub const CLIENT_BUFFER: usize = 4096;

/// Terminal lines shown in the snapshot.
pub const SNAPSHOT_TERMINAL_LINES: usize = 50;

/// An AS program loaded and compiled, ready to run in a controller.
#[derive(Debug, Clone)]
pub struct ServerProgram {
    interp: Interpreter,
    name: String,
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

/// What the motion tick needs from the program (kept in the controller).
#[derive(Debug, Clone, Copy)]
pub(crate) struct Link {
    /// A program runs.
    pub(crate) active: bool,
    /// ACCURACY of the motion in progress, mm (the next one blends in within it).
    pub(crate) accuracy_mm: f64,
    /// ACCURACY of the planned motion (it becomes the current one's when it starts).
    pub(crate) planned_accuracy_mm: f64,
    /// The robot task's state after the latest step.
    pub(crate) task: TaskState,
}

impl Default for Link {
    fn default() -> Self {
        Link {
            active: false,
            accuracy_mm: 0.0,
            planned_accuracy_mm: 0.0,
            task: TaskState::NotRunning,
        }
    }
}

/// A client of the program's TCP stack (a connection to the controller).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize)]
pub struct ClientId(pub i32);

/// What a client reads ([`Controller::program_recv`]).
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct ClientRead {
    /// The bytes due now.
    pub bytes: Vec<u8>,
    /// The program closed the connection (and everything it sent has been read), or it is
    /// gone: the client sees the end of the stream.
    pub closed: bool,
    /// When more bytes become due (a delayed or split reply).
    pub next_at: Option<Duration>,
}

#[derive(Debug, Clone)]
struct Chunk {
    at: Duration,
    bytes: Vec<u8>,
}

#[derive(Debug, Clone)]
enum Peer {
    /// A client of the controller ([`ClientId`] = this socket's id).
    Client,
    /// Another of the program's sockets (`TCP_CONNECT` to its own listener).
    Socket(i32),
}

#[derive(Debug, Clone)]
struct Sock {
    /// What the program reads.
    inbox: VecDeque<u8>,
    /// What the program sent to a client, with when each piece is due.
    outbox: VecDeque<Chunk>,
    outbox_bytes: usize,
    /// The other end closed.
    peer_closed: bool,
    /// The program closed this socket (a client reads what is left, then the end).
    program_closed: bool,
    peer: Peer,
    /// The port it was accepted on (0 for TCP_CONNECT sockets).
    port: u16,
    ip: [u8; 4],
}

impl Sock {
    fn new(peer: Peer, port: u16, ip: [u8; 4]) -> Sock {
        Sock {
            inbox: VecDeque::new(),
            outbox: VecDeque::new(),
            outbox_bytes: 0,
            peer_closed: false,
            program_closed: false,
            peer,
            port,
            ip,
        }
    }
}

#[derive(Debug, Clone, Default)]
struct Net {
    listeners: BTreeMap<u16, VecDeque<i32>>,
    sockets: BTreeMap<i32, Sock>,
    next_id: i32,
    served_port: Option<u16>,
    /// Bumped on every change a client can see (listening, data, close).
    generation: u64,
}

/// The program inside a controller: the interpreter and its TCP stack.
#[derive(Debug, Clone)]
pub(crate) struct AsRuntime {
    interp: Interpreter,
    name: String,
    net: Net,
    /// The planned motion (re-planned after a BRAKE when the behaviour is to execute it).
    planned: Option<(MotionRequest, JointsDeg)>,
}

/// The program as the pendant shows it.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ProgramInfo {
    /// The program file.
    pub name: String,
    /// The port served at the robot's address (the first the program listened on).
    pub served_port: Option<u16>,
    /// Every task: program, line, state, what it waits for.
    pub tasks: Vec<TaskInfo>,
    /// The latest terminal lines.
    pub terminal: Vec<TerminalLine>,
}

impl AsRuntime {
    fn new(program: ServerProgram) -> AsRuntime {
        AsRuntime {
            interp: program.interp,
            name: program.name,
            net: Net {
                next_id: 1,
                ..Net::default()
            },
            planned: None,
        }
    }

    pub(crate) fn run_until(&mut self, c: &mut Controller, t: Duration) {
        let mut host = Host {
            c,
            net: &mut self.net,
            planned: &mut self.planned,
        };
        self.interp.run_until(&mut host, t);
        let task = self.interp.task_state(TaskId::Robot, &host);
        host.c.as_link.task = match task {
            fs020n_as::TaskState::Idle => TaskState::NotRunning,
            fs020n_as::TaskState::Running => TaskState::Running,
            fs020n_as::TaskState::Paused => TaskState::Paused,
            fs020n_as::TaskState::WaitingMotion => TaskState::Finishing,
        };
    }

    fn start(&mut self, c: &mut Controller) {
        let mut host = Host {
            c,
            net: &mut self.net,
            planned: &mut self.planned,
        };
        self.interp.start(&mut host);
    }

    pub(crate) fn abs_speed(&self) -> bool {
        self.interp.system_switch("abs.speed").unwrap_or(false)
    }

    pub(crate) fn set_abs_speed(&mut self, on: bool) {
        self.interp.set_system_switch("abs.speed", on);
    }

    /// Breaks every client connection (fault injection: the program sees the connection
    /// broken on its next receive or send).
    pub(crate) fn close_clients(&mut self) {
        for s in self.net.sockets.values_mut() {
            if matches!(s.peer, Peer::Client) {
                s.peer_closed = true;
                s.program_closed = true;
                s.outbox.clear();
                s.outbox_bytes = 0;
            }
        }
        self.net.generation += 1;
    }

    fn panel_of(c: &Controller) -> PanelState {
        let p = c.panel();
        PanelState {
            power: p.power,
            run: p.run,
            repeat: p.repeat,
            teach_lock: p.teach_lock,
        }
    }

    pub(crate) fn info(&self, c: &Controller) -> ProgramInfo {
        let moving = !c.robot().is_still();
        let terminal: Vec<TerminalLine> = self.interp.terminal().cloned().collect();
        let skip = terminal.len().saturating_sub(SNAPSHOT_TERMINAL_LINES);
        ProgramInfo {
            name: self.name.clone(),
            served_port: self.net.served_port,
            tasks: self.interp.tasks_at(Self::panel_of(c), moving),
            terminal: terminal[skip..].to_vec(),
        }
    }

    /// The session part of the snapshot: a client of the served port, and the newest request
    /// when the program keeps the protocol-1040 ring (`ros_cmd_ind`, `ros_cmd[…]`).
    pub(crate) fn session_info(&self, c: &Controller) -> SessionInfo {
        // An accepted client of the served port (not one still waiting in a backlog).
        let waiting = |id: &i32| self.net.listeners.values().any(|b| b.contains(id));
        let client = self
            .net
            .sockets
            .iter()
            .find(|(id, s)| {
                matches!(s.peer, Peer::Client)
                    && Some(s.port) == self.net.served_port
                    && !s.program_closed
                    && !waiting(id)
            })
            .map(|(id, _)| *id);
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
            listening: self
                .net
                .served_port
                .is_some_and(|p| self.net.listeners.contains_key(&p)),
            reading_paused: c.reading_paused_until().is_some(),
            last_end: None,
        }
    }
}

/// The controller as the interpreter's system, for one `run_until`.
struct Host<'a> {
    c: &'a mut Controller,
    net: &'a mut Net,
    planned: &'a mut Option<(MotionRequest, JointsDeg)>,
}

fn xyzoat(p: &Trans) -> Xyzoat {
    Xyzoat {
        x_mm: p[0],
        y_mm: p[1],
        z_mm: p[2],
        o_deg: p[3],
        a_deg: p[4],
        t_deg: p[5],
    }
}

impl Host<'_> {
    /// The program speed as a fraction of the joints' maximum speeds, with the monitor speed
    /// (product, or minimum with ABS.SPEED).
    fn joint_fraction(&self, req: &MotionRequest, from: JointsDeg, to: JointsDeg) -> f64 {
        let monitor = self.c.monitor_speed();
        let program = match req.speed {
            Speed::Percent(p) => p,
            Speed::MmPerS(v) => 100.0 * v / MAX_TOOL_SPEED_MM_S,
            Speed::Seconds(s) => {
                // A time for a joint move: the percentage that takes that long at 100 %.
                let full = JointMove::plan(self.c.model(), from, to, 1.0).duration_s();
                if s > 0.0 {
                    100.0 * full / s
                } else {
                    100.0
                }
            }
        }
        .clamp(0.01, 100.0);
        let eff = if req.abs_speed {
            program.min(monitor)
        } else {
            program * monitor / 100.0
        };
        (eff / 100.0).clamp(1.0e-4, 1.0)
    }

    /// The duration asked of a straight-line move, seconds (the planner stretches it when a
    /// joint would exceed its speed).
    fn linear_duration(&self, req: &MotionRequest, from: JointsDeg, to: JointsDeg) -> f64 {
        let monitor = self.c.monitor_speed().max(0.01);
        let model = self.c.model();
        let dist_mm = model
            .forward(&from.to_rad())
            .distance_m(&model.forward(&to.to_rad()))
            * 1000.0;
        let tool_speed = |program_mm_s: f64| {
            let v = if req.abs_speed {
                program_mm_s.min(MAX_TOOL_SPEED_MM_S * monitor / 100.0)
            } else {
                program_mm_s * monitor / 100.0
            };
            dist_mm / v.max(1.0e-3)
        };
        match req.speed {
            // Time and absolute speeds are defined at monitor 100 % (the native server's rule).
            Speed::Seconds(s) => s * 100.0 / monitor,
            Speed::MmPerS(v) => tool_speed(v),
            Speed::Percent(p) => tool_speed(MAX_TOOL_SPEED_MM_S * p.clamp(0.01, 100.0) / 100.0),
        }
    }

    fn build(
        &self,
        req: &MotionRequest,
        from: JointsDeg,
    ) -> Result<(Motion, JointsDeg), ErrorCode> {
        let model = self.c.model();
        let target = match (req.kind, req.target) {
            (MotionKind::Delay, _) => from,
            (_, Target::Joints(j)) => JointsDeg(j),
            (_, Target::Pose(p)) => model
                .inverse_nearest(&Pose::from_xyzoat(xyzoat(&p)), &from.to_rad())
                .map(|q| q.to_deg())
                .map_err(|_| ErrorCode::DESTINATION_OUT_OF_RANGE)?,
        };
        if !target.is_finite() || !model.within_limits(&target) {
            tracing::warn!(%target, "E1088: destination is out of motion range");
            return Err(ErrorCode::DESTINATION_OUT_OF_RANGE);
        }
        let tick = self.c.timing().tick.as_secs_f64();
        let shape = match req.kind {
            MotionKind::Joint => Shape::Joint(JointMove::plan(
                model,
                from,
                target,
                self.joint_fraction(req, from, target),
            )),
            MotionKind::Linear => {
                let d = self.linear_duration(req, from, target);
                match LinearPath::plan(model, from, target, d, tick) {
                    Some(p) => Shape::Linear(p),
                    None => {
                        tracing::warn!(%target, "E1088: no straight-line path to the destination");
                        return Err(ErrorCode::DESTINATION_OUT_OF_RANGE);
                    }
                }
            }
            MotionKind::Delay => {
                match LinearPath::plan(model, from, from, req.delay_s.max(0.0), tick) {
                    Some(p) => Shape::Linear(p),
                    None => return Err(ErrorCode::DESTINATION_OUT_OF_RANGE),
                }
            }
        };
        Ok((
            Motion {
                from,
                to: target,
                shape,
            },
            target,
        ))
    }

    fn accuracy_of(req: &MotionRequest) -> f64 {
        if req.fine || !req.cp {
            0.0
        } else {
            req.accuracy_mm
        }
    }

    fn sock(&mut self, id: i32) -> Option<&mut Sock> {
        self.net.sockets.get_mut(&id).filter(|s| !s.program_closed)
    }
}

impl System for Host<'_> {
    fn advance_to(&mut self, t: Duration) {
        self.c.integrate_to(t);
    }

    fn joints(&self) -> Joints {
        self.c.joints().0
    }

    fn pose(&self) -> Option<Trans> {
        let x = self
            .c
            .model()
            .forward(&self.c.joints().to_rad())
            .to_xyzoat();
        Some([x.x_mm, x.y_mm, x.z_mm, x.o_deg, x.a_deg, x.t_deg])
    }

    fn home(&self) -> Joints {
        self.c.model().home.0
    }

    fn issue_motion(&mut self, req: &MotionRequest) -> Result<Issued, ErrorCode> {
        let from = self.c.robot().target();
        let (m, target) = self.build(req, from)?;
        let accuracy = Host::accuracy_of(req);
        if !self.c.robot().has_planned() && self.c.robot_ready_for_next(self.c.as_link.accuracy_mm)
        {
            self.c.as_link.accuracy_mm = accuracy;
            self.c.robot_start(m);
            *self.planned = None;
            Ok(Issued::Started)
        } else {
            self.c.as_link.planned_accuracy_mm = accuracy;
            self.c.robot_plan(m);
            *self.planned = Some((*req, target));
            Ok(Issued::Planned)
        }
    }

    fn motion_planned(&self) -> bool {
        self.c.robot().has_planned()
    }

    fn motion_in_progress(&self) -> bool {
        !self.c.robot().is_still()
    }

    fn brake(&mut self) {
        let had_planned = self.c.robot().has_planned();
        self.c.robot_brake();
        let planned = self.planned.take();
        if self.c.behaviour().planned_after_brake == PlannedAfterBrake::Execute && had_planned {
            // The planned motion starts from where the brake stops the arm.
            if let Some((req, _)) = planned {
                let from = self.c.robot().target();
                match self.build(&req, from) {
                    Ok((m, target)) => {
                        self.c.robot_plan(m);
                        *self.planned = Some((req, target));
                    }
                    Err(code) => self.c.raise(code),
                }
            }
        }
    }

    fn cut_motion(&mut self) {
        self.c.robot_brake();
        *self.planned = None;
    }

    fn set_program_hold(&mut self, held: bool) {
        let run = self.c.panel().run;
        self.c.robot_set_hold(held || !run);
    }

    fn panel(&self) -> PanelState {
        AsRuntime::panel_of(self.c)
    }

    fn error(&self) -> ErrorCode {
        self.c.error()
    }

    fn raise_error(&mut self, code: ErrorCode) {
        tracing::warn!(%code, "AS program error");
        self.c.raise(code);
    }

    fn reset_error(&mut self) -> Result<(), String> {
        self.c.reset_error().map_err(|e| e.to_string())
    }

    fn monitor_speed(&self) -> f64 {
        self.c.monitor_speed()
    }

    fn set_monitor_speed(&mut self, percent: f64) -> Result<(), String> {
        if !(percent.is_finite() && percent > 0.0) {
            return Err(format!("monitor speed {percent} % is not above 0"));
        }
        self.c
            .set_monitor_speed(percent.min(100.0))
            .map_err(|e| e.to_string())
    }

    fn tcp_listen(&mut self, port: u16) -> i32 {
        if self.net.listeners.contains_key(&port) {
            return -34055;
        }
        self.net.listeners.insert(port, VecDeque::new());
        self.net.served_port.get_or_insert(port);
        self.net.generation += 1;
        0
    }

    fn tcp_end_listen(&mut self, port: u16) -> i32 {
        match self.net.listeners.remove(&port) {
            Some(backlog) => {
                // Connections never accepted are reset.
                for id in backlog {
                    close_socket(self.net, id);
                }
                self.net.generation += 1;
                0
            }
            None => -34056,
        }
    }

    fn tcp_accept(&mut self, port: u16) -> SockPoll<(i32, [u8; 4])> {
        let Some(backlog) = self.net.listeners.get_mut(&port) else {
            return SockPoll::Ready(Err(-34056));
        };
        match backlog.pop_front() {
            Some(id) => {
                let ip = self.net.sockets.get(&id).map_or([0; 4], |s| s.ip);
                if self.net.served_port == Some(port) {
                    self.c.counters_mut().sessions += 1;
                }
                tracing::info!(port, socket = id, "AS program accepted a connection");
                SockPoll::Ready(Ok((id, ip)))
            }
            None => SockPoll::Pending,
        }
    }

    fn tcp_connect(&mut self, _ip: [u8; 4], port: u16) -> SockPoll<i32> {
        // The program's own listeners (a controller talking to itself); nothing else is
        // reachable from the emulator.
        if !self.net.listeners.contains_key(&port) {
            return SockPoll::Ready(Err(-34025));
        }
        let a = self.net.next_id;
        let b = a + 1;
        self.net.next_id += 2;
        self.net
            .sockets
            .insert(a, Sock::new(Peer::Socket(b), 0, [127, 0, 0, 1]));
        self.net
            .sockets
            .insert(b, Sock::new(Peer::Socket(a), port, [127, 0, 0, 1]));
        if let Some(backlog) = self.net.listeners.get_mut(&port) {
            backlog.push_back(b);
        }
        SockPoll::Ready(Ok(a))
    }

    fn tcp_recv(&mut self, sock: i32, max: usize) -> SockPoll<Vec<u8>> {
        let paused = self.c.reading_paused_until().is_some();
        let Some(s) = self.sock(sock) else {
            return SockPoll::Ready(Err(-34057));
        };
        if matches!(s.peer, Peer::Client) && paused {
            return SockPoll::Pending;
        }
        if s.inbox.is_empty() {
            return if s.peer_closed {
                SockPoll::Ready(Err(-34025))
            } else {
                SockPoll::Pending
            };
        }
        let n = s.inbox.len().min(max);
        // Copied slice by slice (the ring's two halves), not byte by byte.
        let mut out = Vec::with_capacity(n);
        let (a, b) = s.inbox.as_slices();
        let from_a = a.len().min(n);
        out.extend_from_slice(&a[..from_a]);
        out.extend_from_slice(&b[..(n - from_a).min(b.len())]);
        s.inbox.drain(..n);
        SockPoll::Ready(Ok(out))
    }

    fn tcp_send(&mut self, sock: i32, data: &[u8]) -> SockPoll<()> {
        let now = self.c.now();
        let Some(s) = self.sock(sock) else {
            return SockPoll::Ready(Err(-34057));
        };
        if s.peer_closed {
            return SockPoll::Ready(Err(-34025));
        }
        match s.peer.clone() {
            Peer::Socket(p) => match self.net.sockets.get_mut(&p) {
                Some(peer) if peer.inbox.len() + data.len() <= CLIENT_BUFFER * 16 => {
                    peer.inbox.extend(data);
                    SockPoll::Ready(Ok(()))
                }
                Some(_) => SockPoll::Pending,
                None => SockPoll::Ready(Err(-34025)),
            },
            Peer::Client => {
                if s.outbox_bytes > 0 && s.outbox_bytes + data.len() > CLIENT_BUFFER {
                    return SockPoll::Pending;
                }
                let fault = self.c.next_reply_fault();
                let Some(s) = self.sock(sock) else {
                    return SockPoll::Ready(Err(-34057));
                };
                let mut push = |at: Duration, bytes: Vec<u8>| {
                    s.outbox_bytes += bytes.len();
                    s.outbox.push_back(Chunk { at, bytes });
                };
                match fault {
                    None => push(now, data.to_vec()),
                    Some(ReplyFault::Withhold) => {}
                    Some(ReplyFault::Garbage(b)) => push(now, b),
                    Some(ReplyFault::Delay(d)) => push(now + d, data.to_vec()),
                    Some(ReplyFault::Split { parts, gap }) => {
                        let size = data.len().div_ceil(parts.max(1)).max(1);
                        for (k, piece) in data.chunks(size).enumerate() {
                            push(now + gap * k as u32, piece.to_vec());
                        }
                    }
                }
                self.net.generation += 1;
                SockPoll::Ready(Ok(()))
            }
        }
    }

    fn tcp_close(&mut self, sock: i32) -> i32 {
        if self.sock(sock).is_none() {
            return -34057;
        }
        close_socket(self.net, sock);
        self.net.generation += 1;
        0
    }

    fn terminal(&mut self, task: TaskId, line: &str) {
        tracing::debug!(%task, line, "AS terminal");
    }
}

/// The program closes socket `id`: a socket peer sees the connection closed; a client reads
/// what is left, then the end of the stream.
fn close_socket(net: &mut Net, id: i32) {
    let Some(s) = net.sockets.get_mut(&id) else {
        return;
    };
    s.program_closed = true;
    match s.peer.clone() {
        Peer::Socket(p) => {
            net.sockets.remove(&id);
            if let Some(peer) = net.sockets.get_mut(&p) {
                peer.peer_closed = true;
            }
        }
        Peer::Client => {
            if s.outbox.is_empty() && s.peer_closed {
                net.sockets.remove(&id);
            }
        }
    }
}

// ------------------------------------------------------------------------- the controller

impl Controller {
    /// A controller that runs `program` instead of the native server: its `autostart.pc`
    /// (… `autostart5.pc`) start at once, in PC tasks 1–5.
    pub fn with_program(config: ControllerConfig, program: ServerProgram) -> Controller {
        let mut c = Controller::new(config);
        let mut rt = AsRuntime::new(program);
        c.as_link.active = true;
        rt.start(&mut c);
        c.as_runtime = Some(Box::new(rt));
        c
    }

    /// `true` when the controller runs an AS program.
    pub fn runs_program(&self) -> bool {
        self.as_runtime.is_some()
    }

    /// The program's tasks (program, line, state, what they wait for).
    pub fn program_tasks(&self) -> Option<Vec<TaskInfo>> {
        self.as_runtime.as_ref().map(|rt| rt.info(self).tasks)
    }

    /// The program's latest terminal lines (`PRINT`/`TYPE` and controller messages).
    pub fn program_terminal(&self) -> Vec<TerminalLine> {
        self.as_runtime
            .as_ref()
            .map(|rt| rt.interp.terminal().cloned().collect())
            .unwrap_or_default()
    }

    /// Records every step the program executes from now on (`--trace`); see
    /// [`Controller::take_program_trace`].
    pub fn set_program_trace(&mut self, on: bool) {
        if let Some(rt) = &mut self.as_runtime {
            rt.interp.set_trace(on);
        }
    }

    /// The steps executed since the last call (empty unless tracing).
    pub fn take_program_trace(&mut self) -> Vec<TraceLine> {
        self.as_runtime
            .as_mut()
            .map(|rt| rt.interp.take_trace())
            .unwrap_or_default()
    }

    /// When the program does something next by itself (a step, a timeout, a poll), `None`
    /// when it waits only for clients. A driver advances the controller then.
    pub fn next_program_event(&self) -> Option<Duration> {
        self.as_runtime
            .as_ref()
            .and_then(|rt| rt.interp.next_event())
    }

    /// A signal of the program (outputs 1–999, inputs 1001–1999, internal 2001–2960);
    /// `None` without a program.
    pub fn program_signal(&self, n: i32) -> Option<bool> {
        self.as_runtime.as_ref().map(|rt| rt.interp.signal(n))
    }

    /// Sets an external input signal (1001–1999) of the program, as wiring would.
    pub fn set_program_input(&mut self, n: i32, on: bool) {
        if let Some(rt) = &mut self.as_runtime {
            rt.interp.set_signal(n, on);
        }
    }

    /// A global real of the program (`None`: unknown or never assigned).
    pub fn program_real(&self, name: &str) -> Option<f32> {
        self.as_runtime.as_ref().and_then(|rt| rt.interp.real(name))
    }

    /// Counts every change a client can see (listening, data, a close): a network layer waits
    /// for it to change.
    pub fn program_io_generation(&self) -> u64 {
        self.as_runtime.as_ref().map_or(0, |rt| rt.net.generation)
    }

    /// The port served at the robot's address (the first the program listened on).
    pub fn program_served_port(&self) -> Option<u16> {
        self.as_runtime.as_ref().and_then(|rt| rt.net.served_port)
    }

    /// `true` while the program listens on `port` (`None`: the served port).
    pub fn program_listening(&self, port: Option<u16>) -> bool {
        self.as_runtime.as_ref().is_some_and(|rt| {
            port.or(rt.net.served_port)
                .is_some_and(|p| rt.net.listeners.contains_key(&p))
        })
    }

    /// A client connects to `port` (`None`: the served port) from `ip`. Refused while the
    /// program does not listen there (its `TCP_ACCEPT` then takes the connection).
    pub fn program_connect(&mut self, port: Option<u16>, ip: [u8; 4]) -> Result<ClientId, Refused> {
        let refused = |c: &mut Controller| {
            c.counters_mut().refused += 1;
            Err(Refused::ListenGap)
        };
        let Some(rt) = self.as_runtime.as_mut() else {
            return refused(self);
        };
        let Some(port) = port.or(rt.net.served_port) else {
            return refused(self);
        };
        let net = &mut rt.net;
        let Some(backlog) = net.listeners.get_mut(&port) else {
            return refused(self);
        };
        let id = net.next_id;
        net.next_id += 1;
        backlog.push_back(id);
        net.sockets.insert(id, Sock::new(Peer::Client, port, ip));
        net.generation += 1;
        Ok(ClientId(id))
    }

    /// A client sends bytes; `false` when its connection is gone (closed by the program).
    pub fn program_send(&mut self, client: ClientId, bytes: &[u8]) -> bool {
        let Some(rt) = self.as_runtime.as_mut() else {
            return false;
        };
        match rt.net.sockets.get_mut(&client.0) {
            Some(s) if !s.program_closed => {
                s.inbox.extend(bytes);
                rt.net.generation += 1;
                true
            }
            _ => false,
        }
    }

    /// What a client reads now: the bytes due, whether the program closed the connection, and
    /// when more bytes become due.
    pub fn program_recv(&mut self, client: ClientId) -> ClientRead {
        let now = self.now();
        let Some(rt) = self.as_runtime.as_mut() else {
            return ClientRead {
                closed: true,
                ..ClientRead::default()
            };
        };
        let Some(s) = rt.net.sockets.get_mut(&client.0) else {
            return ClientRead {
                closed: true,
                ..ClientRead::default()
            };
        };
        let mut out = ClientRead::default();
        while let Some(c) = s.outbox.front() {
            if c.at > now {
                out.next_at = Some(c.at);
                break;
            }
            if let Some(c) = s.outbox.pop_front() {
                s.outbox_bytes -= c.bytes.len();
                out.bytes.extend_from_slice(&c.bytes);
            }
        }
        if !out.bytes.is_empty() {
            rt.net.generation += 1;
        }
        out.closed = s.program_closed && s.outbox.is_empty();
        out
    }

    /// The client closes its connection (the program's next receive reports it broken).
    pub fn program_close(&mut self, client: ClientId) {
        let Some(rt) = self.as_runtime.as_mut() else {
            return;
        };
        if let Some(s) = rt.net.sockets.get_mut(&client.0) {
            s.peer_closed = true;
            if s.program_closed {
                rt.net.sockets.remove(&client.0);
            }
            rt.net.generation += 1;
        }
    }
}

// ------------------------------------------------------------------------- on a runtime

impl crate::server::Emulator {
    /// An emulator whose controller runs `program` (see [`Controller::with_program`]), started
    /// now. Create it inside a tokio runtime: a background task advances the program at its
    /// own events (timeouts, polls, steps) even when nobody observes the controller.
    pub fn with_program(
        config: ControllerConfig,
        program: ServerProgram,
    ) -> crate::server::Emulator {
        let emu =
            crate::server::Emulator::from_controller(Controller::with_program(config, program));
        if let Ok(rt) = tokio::runtime::Handle::try_current() {
            rt.spawn(drive(emu.downgrade()));
        }
        emu
    }

    /// Serves the program's port on `addr` (e.g. `127.0.0.1:10050`; port 0 picks one): the
    /// first port the program listens on. The real port listens exactly while the program
    /// does (between its `TCP_LISTEN` and `TCP_END_LISTEN`); a connection then waits for its
    /// `TCP_ACCEPT`.
    pub async fn serve_program_tcp(
        &self,
        addr: std::net::SocketAddr,
    ) -> std::io::Result<crate::server::TcpServer> {
        let listener = crate::server::bind_robot_port(addr)?;
        let local = listener.local_addr()?;
        let this = self.clone();
        let task =
            tokio::spawn(async move { this.program_accept_loop(local, Some(listener)).await });
        Ok(crate::server::TcpServer::new(local, task))
    }

    /// Connects an in-memory client to the program's served port (refused while the program
    /// does not listen).
    pub fn connect_program(&self) -> std::io::Result<tokio::io::DuplexStream> {
        let id = self
            .with(|c| c.program_connect(None, [127, 0, 0, 1]))
            .map_err(|e| std::io::Error::new(std::io::ErrorKind::ConnectionRefused, e))?;
        let (client, server) = tokio::io::duplex(crate::server::PIPE_CAPACITY);
        tokio::spawn(pump(self.clone(), id, server));
        Ok(client)
    }

    async fn program_accept_loop(
        self,
        addr: std::net::SocketAddr,
        mut listener: Option<tokio::net::TcpListener>,
    ) {
        let mut changes = self.changes();
        loop {
            if !self.with(|c| c.program_listening(None)) {
                // Not listening: connections are refused.
                listener = None;
                if changes.changed().await.is_err() {
                    return;
                }
                continue;
            }
            let l = match listener.take() {
                Some(l) => l,
                None => match crate::server::bind_robot_port(addr) {
                    Ok(l) => l,
                    Err(e) => {
                        tracing::warn!(%addr, error = %e, "cannot listen; retrying");
                        tokio::time::sleep(Duration::from_millis(100)).await;
                        continue;
                    }
                },
            };
            tokio::select! {
                accepted = l.accept() => {
                    if let Ok((stream, peer)) = accepted {
                        let ip = match peer.ip() {
                            std::net::IpAddr::V4(v4) => v4.octets(),
                            std::net::IpAddr::V6(v6) => v6.to_ipv4_mapped().map_or([0; 4], |v| v.octets()),
                        };
                        match self.with(|c| c.program_connect(None, ip)) {
                            Ok(id) => {
                                let _ = stream.set_nodelay(true);
                                tracing::info!(%peer, client = id.0, "client connected to the AS program");
                                tokio::spawn(pump(self.clone(), id, stream));
                            }
                            Err(e) => tracing::info!(%peer, "{e}"),
                        }
                    }
                    listener = Some(l);
                }
                r = changes.changed() => {
                    if r.is_err() {
                        return;
                    }
                    listener = Some(l);
                }
            }
        }
    }
}

/// Advances the program at its own events while the emulator lives.
async fn drive(weak: crate::server::WeakEmulator) {
    loop {
        let Some(emu) = weak.upgrade() else { return };
        let next = emu.with(|c| c.next_program_event());
        let mut changes = emu.changes();
        // Without an event of its own the program only waits for clients; look again now and
        // then to notice that the emulator is gone.
        let at = match next {
            Some(t) => emu.instant_of(t),
            None => tokio::time::Instant::now() + Duration::from_secs(1),
        };
        drop(emu);
        tokio::select! {
            _ = tokio::time::sleep_until(at) => {}
            _ = changes.changed() => {}
        }
    }
}

/// Moves bytes between a client connection and the program's socket `id`.
async fn pump<S>(emu: crate::server::Emulator, id: ClientId, stream: S)
where
    S: tokio::io::AsyncRead + tokio::io::AsyncWrite + Unpin,
{
    use tokio::io::{AsyncReadExt, AsyncWriteExt};
    let (mut rd, mut wr) = tokio::io::split(stream);
    let reader = {
        let emu = emu.clone();
        async move {
            let mut buf = vec![0u8; crate::server::RECEIVE_BUFFER];
            loop {
                // Fault injection: the controller stops reading for a while.
                if let Some(until) = emu.with(|c| c.reading_paused_until()) {
                    tokio::time::sleep_until(emu.instant_of(until)).await;
                    continue;
                }
                match rd.read(&mut buf).await {
                    Ok(0) | Err(_) => {
                        emu.with(|c| c.program_close(id));
                        return;
                    }
                    Ok(n) => {
                        if !emu.with(|c| c.program_send(id, &buf[..n])) {
                            return;
                        }
                    }
                }
            }
        }
    };
    let writer = async move {
        let mut changes = emu.changes();
        loop {
            let r = emu.with(|c| c.program_recv(id));
            if !r.bytes.is_empty() {
                let sent = async {
                    wr.write_all(&r.bytes).await?;
                    wr.flush().await
                };
                if sent.await.is_err() {
                    emu.with(|c| c.program_close(id));
                    return;
                }
                continue;
            }
            if r.closed {
                let _ = wr.shutdown().await;
                return;
            }
            let at = r.next_at.map(|t| emu.instant_of(t));
            tokio::select! {
                c = changes.changed() => if c.is_err() { return },
                _ = crate::server::sleep_until_opt(at) => {}
            }
        }
    };
    // The connection ends when either side does.
    tokio::select! {
        _ = reader => {}
        _ = writer => {}
    }
}
