//! The emulated controller: a [`Machine`] and the server program that runs on it, advanced by
//! a clock it is given ([`Controller::advance_to`]). No sleeps, no wall clock: the same inputs
//! at the same times give the same result.

use std::time::Duration;

use fs020n_as::{TaskInfo, TerminalLine, TraceLine};
use fs020n_kin::RobotModel;
use fs020n_proto::{Command, ErrorCode, JointsDeg, Status};

mod memory;
mod sessions;
mod tasks;

pub use memory::{Abort, MemoryLoad, PowerCycle};
use memory::{Idle, MonitorState};

use crate::fault::Fault;
use crate::machine::{
    Behaviour, ControllerConfig, Machine, PanelChange, PanelError, ServerPicture, Timing,
};
use crate::motion::{Arm, MotionPhase};
use crate::native::{Handled, NativeServer, SessionGone, SessionId};
use crate::network::Network;
use crate::panel::Panel;
use crate::program::{ClientId, ClientRead, ProgramDial, ProgramServer, ServerProgram};
use crate::snapshot::{Counters, MotionTaskState, PassInfo, Refused, SessionEnd, Snapshot};
use crate::store::{ProgramStore, AUTOSTART_SWITCHES};

/// The emulated FS020N controller: a machine (clock, arm, panel, error, monitor speed,
/// faults, counters) and the server program that runs on it — the native protocol-1040 server
/// ([`Controller::new`]) or an AS program ([`Controller::with_program`]).
///
/// It is a state machine in the manner of a sans-IO protocol: it never sleeps and never reads
/// a clock; a driver gives it time and input and reads its output. Its API, by concern:
///
/// - **Time.** [`advance_to`](Controller::advance_to) / [`advance_by`](Controller::advance_by)
///   integrate motion tick by tick and run the server up to a time. The next times a driver
///   must wake up at are [`receive_deadline`](Controller::receive_deadline),
///   [`next_listen_change`](Controller::next_listen_change) and
///   [`reading_paused_until`](Controller::reading_paused_until) (native server), and
///   [`next_program_event`](Controller::next_program_event) (AS program).
/// - **Observers.** [`now`](Controller::now), [`model`](Controller::model),
///   [`timing`](Controller::timing), [`behaviour`](Controller::behaviour),
///   [`panel`](Controller::panel), [`error`](Controller::error),
///   [`monitor_speed`](Controller::monitor_speed), [`abs_speed`](Controller::abs_speed),
///   [`joints`](Controller::joints), [`velocity`](Controller::velocity),
///   [`arm`](Controller::arm), [`motion_phase`](Controller::motion_phase),
///   [`task`](Controller::task), [`stop_signal`](Controller::stop_signal),
///   [`step_s`](Controller::step_s), [`last_pass`](Controller::last_pass),
///   [`counters`](Controller::counters), [`pending_faults`](Controller::pending_faults),
///   [`status`](Controller::status), [`start_blockers`](Controller::start_blockers), and all of
///   it at once: [`snapshot`](Controller::snapshot).
/// - **Panel and pendant.** [`set_power`](Controller::set_power),
///   [`set_run`](Controller::set_run), [`set_repeat`](Controller::set_repeat),
///   [`set_teach_lock`](Controller::set_teach_lock), [`apply_panel`](Controller::apply_panel),
///   [`press_estop`](Controller::press_estop), [`release_estop`](Controller::release_estop),
///   [`reset_error`](Controller::reset_error),
///   [`set_monitor_speed`](Controller::set_monitor_speed),
///   [`set_abs_speed`](Controller::set_abs_speed); fault injection:
///   [`inject`](Controller::inject), [`clear_faults`](Controller::clear_faults).
/// - **Session** (the native server's communication task). A client connects with
///   [`try_accept`](Controller::try_accept), sends a request with
///   [`handle_request`](Controller::handle_request) (one receive call = one request; the
///   answer is the reply bytes and a fault to apply), reports a delayed reply out with
///   [`reply_sent`](Controller::reply_sent), and a lost connection with
///   [`end_session_of`](Controller::end_session_of). Its state:
///   [`session`](Controller::session), [`is_session_open`](Controller::is_session_open),
///   [`last_session_end`](Controller::last_session_end), [`timer1_s`](Controller::timer1_s),
///   [`newest_command`](Controller::newest_command),
///   [`newest_index`](Controller::newest_index), [`is_listening`](Controller::is_listening).
///   A controller running an AS program has no native session: it refuses these connections.
/// - **Program** (an AS program instead of the native server). Its clients:
///   [`program_connect`](Controller::program_connect),
///   [`program_send`](Controller::program_send), [`program_recv`](Controller::program_recv),
///   [`program_close`](Controller::program_close),
///   [`program_listening`](Controller::program_listening),
///   [`program_served_port`](Controller::program_served_port),
///   [`program_io_generation`](Controller::program_io_generation); its connections to other
///   hosts, which a network layer makes through the host map ([`Network`]):
///   [`take_program_dials`](Controller::take_program_dials),
///   [`program_dialed`](Controller::program_dialed),
///   [`program_listening_ports`](Controller::program_listening_ports),
///   [`network`](Controller::network), [`set_network`](Controller::set_network); its state:
///   [`runs_program`](Controller::runs_program), [`program_tasks`](Controller::program_tasks),
///   [`program_terminal`](Controller::program_terminal),
///   [`program_signal`](Controller::program_signal),
///   [`set_program_input`](Controller::set_program_input),
///   [`program_real`](Controller::program_real),
///   [`set_program_trace`](Controller::set_program_trace),
///   [`take_program_trace`](Controller::take_program_trace).
/// - **Memory, tasks and power** (what the monitor terminal operates, `controller/memory.rs`):
///   [`bare`](Controller::bare), [`loaded_programs`](Controller::loaded_programs),
///   [`program_text`](Controller::program_text),
///   [`data_sections`](Controller::data_sections),
///   [`check_program_text`](Controller::check_program_text),
///   [`load_program_text`](Controller::load_program_text),
///   [`delete_program`](Controller::delete_program), [`pc_execute`](Controller::pc_execute),
///   [`pc_abort`](Controller::pc_abort), [`kill_task`](Controller::kill_task),
///   [`execute_program`](Controller::execute_program),
///   [`abort_program`](Controller::abort_program),
///   [`task_running`](Controller::task_running), [`task_program`](Controller::task_program),
///   [`switch`](Controller::switch), [`set_switch`](Controller::set_switch),
///   [`switches`](Controller::switches), [`power_cycle`](Controller::power_cycle); the
///   terminal's sessions and transfer: [`open_terminal`](Controller::open_terminal),
///   [`close_terminal`](Controller::close_terminal),
///   [`transfer_open`](Controller::transfer_open),
///   [`abandon_transfer`](Controller::abandon_transfer),
///   [`terminal_output_since`](Controller::terminal_output_since),
///   [`monitor_generation`](Controller::monitor_generation).
#[derive(Debug, Clone)]
pub struct Controller {
    machine: Machine,
    server: Server,
    /// The programs loaded, the AUTOSTART and system switches (`controller/memory.rs`).
    memory: ProgramStore,
    /// What the terminal and the task stacks need (`controller/memory.rs`).
    monitor: MonitorState,
}

/// The server program that runs on the machine. One per controller, never moved in bulk: the
/// native server stays inline (its state is touched at every tick), the AS program is boxed.
#[derive(Debug, Clone)]
#[allow(clippy::large_enum_variant)]
enum Server {
    /// No server: a new controller (`--bare`) until a program is loaded and started.
    Empty,
    /// The native protocol-1040 server.
    Native(NativeServer),
    /// An AS program.
    Program(Box<ProgramServer>),
}

impl Controller {
    /// A controller running the native server at time zero, listening.
    pub fn new(config: ControllerConfig) -> Controller {
        Controller {
            machine: Machine::new(config),
            server: Server::Native(NativeServer::new()),
            memory: ProgramStore::new(fs020n_as::Config::default(), fs020n_as::LoadOptions::new()),
            monitor: MonitorState::default(),
        }
    }

    /// A controller that runs `program` instead of the native server: its `autostart.pc`
    /// (… `autostart5.pc`) start at once, in PC tasks 1–5.
    ///
    /// Its programs are the controller's memory (the terminal lists, saves and replaces them)
    /// and the AUTOSTART switches of the autostart programs it holds are ON, so that a power
    /// cycle starts them again.
    pub fn with_program(config: ControllerConfig, program: ServerProgram) -> Controller {
        let mut machine = Machine::new(config);
        let memory = ProgramStore::seeded(
            program.bytes(),
            program.config().clone(),
            program.load_options().clone(),
        );
        let mut monitor = MonitorState::default();
        for (_, name, task) in AUTOSTART_SWITCHES {
            if memory.program(name).is_some() {
                monitor.stacks[usize::from(task)] = Some(name.to_owned());
            }
        }
        let program = ProgramServer::start(program, &mut machine);
        monitor.built = Some(memory.generation());
        Controller {
            machine,
            server: Server::Program(Box::new(program)),
            memory,
            monitor,
        }
    }

    /// A new controller with nothing loaded and no server (`fs020n sim --bare`): no protocol
    /// port answers until a program is loaded through the terminal and started; every
    /// AUTOSTART switch is OFF.
    pub fn bare(config: ControllerConfig) -> Controller {
        Controller::bare_with(config, fs020n_as::LoadOptions::new())
    }

    /// [`Controller::bare`] whose programs load with `load` (instructions declared no-ops,
    /// `fs020n sim --bare --stub …`), at every `LOAD` and rebuild.
    pub fn bare_with(config: ControllerConfig, load: fs020n_as::LoadOptions) -> Controller {
        Controller {
            machine: Machine::new(config),
            server: Server::Empty,
            memory: ProgramStore::new(fs020n_as::Config::default(), load),
            monitor: MonitorState::default(),
        }
    }

    fn native(&self) -> Option<&NativeServer> {
        match &self.server {
            Server::Native(n) => Some(n),
            Server::Program(_) | Server::Empty => None,
        }
    }

    fn program(&self) -> Option<&ProgramServer> {
        match &self.server {
            Server::Native(_) | Server::Empty => None,
            Server::Program(p) => Some(p),
        }
    }

    fn program_mut(&mut self) -> Option<&mut ProgramServer> {
        match &mut self.server {
            Server::Native(_) | Server::Empty => None,
            Server::Program(p) => Some(p),
        }
    }

    // ----------------------------------------------------------------- time

    /// Advances the controller to time `t` (no-op if `t` is not later than now): integrates
    /// motion tick by tick and runs the server (the native program's passes and receive
    /// timeout, or the AS program's steps). Idle stretches are skipped in one step.
    pub fn advance_to(&mut self, t: Duration) {
        match &mut self.server {
            Server::Native(n) => self.machine.integrate_to(t, n),
            Server::Program(p) => p.run_until(&mut self.machine, t),
            Server::Empty => self.machine.integrate_to(t, &mut Idle),
        }
    }

    /// Advances by `d`.
    pub fn advance_by(&mut self, d: Duration) {
        self.advance_to(self.machine.now() + d);
    }

    // ----------------------------------------------------------------- observers

    /// Controller time (since start).
    pub fn now(&self) -> Duration {
        self.machine.now()
    }

    /// The robot model.
    pub fn model(&self) -> &RobotModel {
        self.machine.model()
    }

    /// The timing choices.
    pub fn timing(&self) -> Timing {
        self.machine.timing()
    }

    /// The behaviour choices.
    pub fn behaviour(&self) -> Behaviour {
        self.machine.behaviour()
    }

    /// Panel switches.
    pub fn panel(&self) -> Panel {
        self.machine.panel()
    }

    /// Current error (0 = none).
    pub fn error(&self) -> ErrorCode {
        self.machine.error()
    }

    /// Monitor speed, percent.
    pub fn monitor_speed(&self) -> f64 {
        self.machine.monitor_speed()
    }

    /// `true` once command 3 has switched ABS.SPEED on.
    pub fn abs_speed(&self) -> bool {
        match &self.server {
            Server::Native(_) | Server::Empty => self.machine.abs_speed(),
            Server::Program(p) => p.abs_speed(),
        }
    }

    /// Joint angles, degrees.
    pub fn joints(&self) -> JointsDeg {
        self.machine.arm().joints()
    }

    /// Joint velocities, deg/s.
    pub fn velocity(&self) -> JointsDeg {
        self.machine.arm().velocity()
    }

    /// The robot's motion state.
    pub fn arm(&self) -> &Arm {
        self.machine.arm()
    }

    /// What the robot is doing.
    pub fn motion_phase(&self) -> MotionPhase {
        self.machine.motion_phase()
    }

    /// State of the motion program (robot task 1).
    pub fn task(&self) -> MotionTaskState {
        match &self.server {
            Server::Native(n) => n.task(&self.machine),
            Server::Program(p) => p.task(),
            Server::Empty => MotionTaskState::NotRunning,
        }
    }

    /// `true` while signal 2007 (stop the native motion program) is on.
    pub fn stop_signal(&self) -> bool {
        self.native().is_some_and(NativeServer::stop_signal)
    }

    /// The native program's average pass duration `step`, seconds (0 when not running).
    pub fn step_s(&self) -> f64 {
        self.native().map_or(0.0, NativeServer::step_s)
    }

    /// What the latest pass of the native motion program decided.
    pub fn last_pass(&self) -> Option<PassInfo> {
        self.native().and_then(NativeServer::last_pass)
    }

    /// Counters.
    pub fn counters(&self) -> Counters {
        self.machine.counters()
    }

    /// Reply faults waiting.
    pub fn pending_faults(&self) -> usize {
        self.machine.pending_faults()
    }

    /// The status reply as the native server would send it now.
    pub fn status(&self) -> Status {
        match &self.server {
            Server::Native(n) => n.status(&self.machine),
            Server::Program(p) => p.status(&self.machine),
            Server::Empty => self.machine.status(false, 0.0),
        }
    }

    /// Conditions of command 1 that are not met, as the controller would report them
    /// (P1000 power off, P1001 TEACH, P1002 lock on, P1013 in error, P1009 already running;
    /// HOLD has no code of its own).
    pub fn start_blockers(&self) -> Vec<&'static str> {
        let executes = self.native().is_some_and(NativeServer::program_executes);
        self.machine.start_blockers(executes)
    }

    /// A serializable picture of the whole state now.
    pub fn snapshot(&self) -> Snapshot {
        match &self.server {
            Server::Native(n) => n.snapshot(&self.machine),
            Server::Program(p) => p.snapshot(&self.machine),
            Server::Empty => self.machine.snapshot(ServerPicture {
                task: MotionTaskState::NotRunning,
                abs_speed: self.machine.abs_speed(),
                step_s: 0.0,
                last_pass: None,
                program_executes: false,
                session: memory::no_session(),
                program: None,
            }),
        }
    }

    // ----------------------------------------------------------------- panel and pendant

    /// Turns motor power on or off. Off stops the robot dead and ends the program. On is
    /// refused while the emergency stop is pressed.
    pub fn set_power(&mut self, on: bool) -> Result<(), PanelError> {
        self.machine.set_power(on)?;
        if let (false, Server::Native(n)) = (on, &mut self.server) {
            if n.program_executes() {
                tracing::info!("motor power off: motion program ends");
                n.end_program();
            }
        }
        Ok(())
    }

    /// RUN (true) or HOLD (false). HOLD decelerates the motion to a pause and pauses the
    /// program; RUN resumes both.
    pub fn set_run(&mut self, run: bool) {
        self.machine.set_run(run);
    }

    /// REPEAT (true) or TEACH (false). Switching to TEACH stops a running program.
    pub fn set_repeat(&mut self, repeat: bool) {
        self.machine.set_repeat(repeat);
        if let (false, Server::Native(n)) = (repeat, &mut self.server) {
            n.end_program();
        }
    }

    /// TEACH LOCK on or off. On gives the pendant control: a running program stops (the
    /// program cannot run with the lock on, spec §4) and command 1 is refused.
    pub fn set_teach_lock(&mut self, on: bool) {
        self.machine.set_teach_lock(on);
        if let (true, Server::Native(n)) = (on, &mut self.server) {
            n.end_program();
        }
    }

    /// Presses the emergency stop: motor power is cut, the robot stops dead, the program ends
    /// and E3808 is raised.
    pub fn press_estop(&mut self) {
        if let Server::Native(n) = &mut self.server {
            n.end_program();
        }
        self.machine.press_estop();
    }

    /// Releases the emergency stop (the error stays until reset, power stays off).
    pub fn release_estop(&mut self) {
        self.machine.release_estop();
    }

    /// Resets the error (ERESET). Refused while the emergency stop is pressed.
    pub fn reset_error(&mut self) -> Result<(), PanelError> {
        self.machine.reset_error()
    }

    /// Switches ABS.SPEED (a system switch) on or off, as the pendant can. Command 3 switches
    /// it on; only the pendant switches it off.
    pub fn set_abs_speed(&mut self, on: bool) {
        if let Some(p) = self.program_mut() {
            p.set_abs_speed(on);
        }
        self.machine.set_abs_speed(on);
    }

    /// Sets the monitor speed (1–100 %). It applies from the next planned motion.
    pub fn set_monitor_speed(&mut self, percent: f64) -> Result<(), PanelError> {
        self.machine.set_monitor_speed(percent)
    }

    /// Changes several panel switches at once (absent ones stay). Nothing changes when one of
    /// them is refused (power ON while the emergency stop is pressed).
    pub fn apply_panel(&mut self, change: PanelChange) -> Result<(), PanelError> {
        if change.power == Some(true) && self.machine.panel().estop {
            return Err(PanelError::EstopPressed);
        }
        if let Some(on) = change.power {
            self.set_power(on)?;
        }
        if let Some(repeat) = change.repeat {
            self.set_repeat(repeat);
        }
        if let Some(on) = change.teach_lock {
            self.set_teach_lock(on);
        }
        if let Some(run) = change.run {
            self.set_run(run);
        }
        Ok(())
    }

    /// Drops the reply faults that wait (and a reading pause).
    pub fn clear_faults(&mut self) {
        self.machine.clear_faults();
    }

    /// Injects a fault (see [`Fault`]).
    pub fn inject(&mut self, fault: Fault) {
        tracing::info!(?fault, "fault injected");
        match (&fault, &mut self.server) {
            (Fault::CloseConnection, Server::Native(n)) => {
                n.end_session(&mut self.machine, SessionEnd::Fault)
            }
            (Fault::CloseConnection, Server::Program(p)) => p.close_clients(),
            (Fault::RaiseError { code }, Server::Native(n)) => n.raise(&mut self.machine, *code),
            (Fault::RaiseError { code }, Server::Program(_) | Server::Empty) => {
                self.machine.raise(*code)
            }
            _ => self.machine.inject(&fault),
        }
    }

    // ----------------------------------------------------------------- session

    /// A client connects. Accepted only during a listen window and when no session is open.
    /// On accept the command ring and TIMER(1) are reset. A controller running an AS program
    /// refuses (its clients connect with [`Controller::program_connect`]).
    pub fn try_accept(&mut self) -> Result<SessionId, Refused> {
        match &mut self.server {
            Server::Native(n) => n.try_accept(&mut self.machine),
            Server::Program(_) | Server::Empty => {
                self.machine.counters_mut().refused += 1;
                Err(Refused::ListenGap)
            }
        }
    }

    /// The communication task receives `bytes` (one receive call = one request) on session
    /// `id`, acts on it and builds the reply with the joints of this instant.
    pub fn handle_request(&mut self, id: SessionId, bytes: &[u8]) -> Result<Handled, SessionGone> {
        match &mut self.server {
            Server::Native(n) => n.handle_request(&mut self.machine, id, bytes),
            Server::Program(_) | Server::Empty => Err(SessionGone),
        }
    }

    /// The reply of session `id` has been sent: the communication task receives again and its
    /// 5 s receive timeout starts now (spec §4: receive, act, send, receive…). Callers that
    /// apply a delayed or split reply ([`Handled::fault`]) must call it once the reply is out;
    /// until then the session cannot time out.
    pub fn reply_sent(&mut self, id: SessionId) {
        if let Server::Native(n) = &mut self.server {
            n.reply_sent(&self.machine, id);
        }
    }

    /// Ends the session `id` (connection lost, send timeout): the robot stops, the program
    /// ends, the controller listens again.
    pub fn end_session_of(&mut self, id: SessionId, why: SessionEnd) {
        if let Server::Native(n) = &mut self.server {
            if n.session() == Some(id) {
                n.end_session(&mut self.machine, why);
            }
        }
    }

    /// The open session, if any.
    pub fn session(&self) -> Option<SessionId> {
        self.native().and_then(NativeServer::session)
    }

    /// `true` while `id` is the open session.
    pub fn is_session_open(&self, id: SessionId) -> bool {
        self.session() == Some(id)
    }

    /// How the latest session ended.
    pub fn last_session_end(&self) -> Option<(SessionId, SessionEnd)> {
        self.native().and_then(NativeServer::last_session_end)
    }

    /// TIMER(1): seconds since the session was accepted (1 ms resolution), 0 without a session.
    pub fn timer1_s(&self) -> f64 {
        self.native().map_or(0.0, |n| n.timer1_s(&self.machine))
    }

    /// The newest command of the ring as the motion program reads it (command 0 right after
    /// accept), while a session is open.
    pub fn newest_command(&self) -> Option<Command> {
        self.native().and_then(NativeServer::newest_command)
    }

    /// The ring index of the newest command, while a session is open.
    pub fn newest_index(&self) -> Option<usize> {
        self.native().and_then(NativeServer::newest_index)
    }

    /// When the open session times out for lack of requests (`None` while a delayed reply is
    /// being sent).
    pub fn receive_deadline(&self) -> Option<Duration> {
        self.native().and_then(NativeServer::receive_deadline)
    }

    /// Until when the communication task does not read (fault injection).
    pub fn reading_paused_until(&self) -> Option<Duration> {
        self.machine.reading_paused_until()
    }

    /// `true` while connections are accepted now.
    pub fn is_listening(&self) -> bool {
        self.native().is_some_and(|n| n.is_listening(&self.machine))
    }

    /// When the listening state changes next (window opens or closes); `None` during a session.
    pub fn next_listen_change(&self) -> Option<Duration> {
        self.native()
            .and_then(|n| n.next_listen_change(&self.machine))
    }

    // ----------------------------------------------------------------- program

    /// `true` when the controller runs an AS program.
    pub fn runs_program(&self) -> bool {
        self.program().is_some()
    }

    /// The program's tasks (program, line, state, what they wait for).
    pub fn program_tasks(&self) -> Option<Vec<TaskInfo>> {
        self.program().map(|p| p.info(&self.machine).tasks)
    }

    /// The program's latest terminal lines (`PRINT`/`TYPE` and controller messages).
    pub fn program_terminal(&self) -> Vec<TerminalLine> {
        self.program()
            .map(ProgramServer::terminal)
            .unwrap_or_default()
    }

    /// Records every step the program executes from now on (`--trace`); see
    /// [`Controller::take_program_trace`].
    pub fn set_program_trace(&mut self, on: bool) {
        if let Some(p) = self.program_mut() {
            p.set_trace(on);
        }
    }

    /// The steps executed since the last call (empty unless tracing).
    pub fn take_program_trace(&mut self) -> Vec<TraceLine> {
        self.program_mut()
            .map(ProgramServer::take_trace)
            .unwrap_or_default()
    }

    /// When the program does something next by itself (a step, a timeout, a poll), `None`
    /// when it waits only for clients. A driver advances the controller then.
    pub fn next_program_event(&self) -> Option<Duration> {
        self.program().and_then(ProgramServer::next_event)
    }

    /// A signal of the program (outputs 1–999, inputs 1001–1999, internal 2001–2960);
    /// `None` without a program.
    pub fn program_signal(&self, n: i32) -> Option<bool> {
        self.program().map(|p| p.signal(n))
    }

    /// Sets an external input signal (1001–1999) of the program, as wiring would.
    pub fn set_program_input(&mut self, n: i32, on: bool) {
        if let Some(p) = self.program_mut() {
            p.set_input(n, on);
        }
    }

    /// A global real of the program (`None`: unknown or never assigned).
    pub fn program_real(&self, name: &str) -> Option<f32> {
        self.program().and_then(|p| p.real(name))
    }

    /// The address the AS program's UDP sockets (`UDP_SENDTO`, `UDP_RECVFROM`) bind to on
    /// this machine: 127.0.0.1 (loopback only) unless set; `None` without an AS program.
    pub fn program_udp_address(&self) -> Option<std::net::Ipv4Addr> {
        self.program().map(ProgramServer::udp_address)
    }

    /// Binds the AS program's UDP sockets to `address` from their next use on (e.g.
    /// 0.0.0.0 to let other machines reach `UDP_RECVFROM`); `false` without an AS program.
    pub fn set_program_udp_address(&mut self, address: std::net::Ipv4Addr) -> bool {
        match self.program_mut() {
            Some(p) => {
                p.set_udp_address(address);
                true
            }
            None => false,
        }
    }

    /// Counts every change a client can see (listening, data, a close): a network layer waits
    /// for it to change.
    pub fn program_io_generation(&self) -> u64 {
        self.program().map_or(0, ProgramServer::io_generation)
    }

    /// The port served at the robot's address (the first the program listened on).
    pub fn program_served_port(&self) -> Option<u16> {
        self.program().and_then(ProgramServer::served_port)
    }

    /// `true` while the program listens on `port` (`None`: the served port).
    pub fn program_listening(&self, port: Option<u16>) -> bool {
        self.program().is_some_and(|p| p.listening(port))
    }

    /// A client connects to `port` (`None`: the served port) from `ip`. Refused while the
    /// program does not listen there (its `TCP_ACCEPT` then takes the connection).
    pub fn program_connect(&mut self, port: Option<u16>, ip: [u8; 4]) -> Result<ClientId, Refused> {
        match &mut self.server {
            Server::Program(p) => p.connect(&mut self.machine, port, ip),
            Server::Native(_) | Server::Empty => {
                self.machine.counters_mut().refused += 1;
                Err(Refused::ListenGap)
            }
        }
    }

    /// A client sends bytes; `false` when its connection is gone (closed by the program).
    pub fn program_send(&mut self, client: ClientId, bytes: &[u8]) -> bool {
        self.program_mut().is_some_and(|p| p.send(client, bytes))
    }

    /// What a client reads now: the bytes due, whether the program closed the connection, and
    /// when more bytes become due.
    pub fn program_recv(&mut self, client: ClientId) -> ClientRead {
        let now = self.machine.now();
        match self.program_mut() {
            Some(p) => p.recv(now, client),
            None => ClientRead {
                closed: true,
                ..ClientRead::default()
            },
        }
    }

    /// The client closes its connection (the program's next receive reports it broken).
    pub fn program_close(&mut self, client: ClientId) {
        if let Some(p) = self.program_mut() {
            p.close(client);
        }
    }

    /// The controller's address and host map.
    pub fn network(&self) -> &Network {
        self.machine.network()
    }

    /// Replaces the controller's address and host map (from the next `TCP_CONNECT`,
    /// `UDP_SENDTO` or client on).
    pub fn set_network(&mut self, network: Network) {
        self.machine.set_network(network);
    }

    /// The ports the program listens on now (each served on the host through the port map).
    pub fn program_listening_ports(&self) -> Vec<u16> {
        self.program()
            .map(ProgramServer::listening_ports)
            .unwrap_or_default()
    }

    /// Takes the connections the program asked for (`TCP_CONNECT` to mapped hosts) for the
    /// network layer to make; it reports each with [`Controller::program_dialed`], then moves
    /// its bytes as a client's ([`Controller::program_send`], [`Controller::program_recv`]).
    pub fn take_program_dials(&mut self) -> Vec<ProgramDial> {
        match &mut self.server {
            Server::Program(p) => p.take_dials(&self.machine),
            Server::Native(_) | Server::Empty => Vec::new(),
        }
    }

    /// How a dial went: connected, or the code the program's `TCP_CONNECT` gets (−34025 when
    /// the host refused). `false` when the program no longer waits for it: close it.
    pub fn program_dialed(&mut self, client: ClientId, result: Result<(), i32>) -> bool {
        self.program_mut().is_some_and(|p| p.dialed(client, result))
    }
}
