//! The emulated controller: a [`Machine`] and the server program that runs on it, advanced by
//! a clock it is given ([`Controller::advance_to`]). No sleeps, no wall clock: the same inputs
//! at the same times give the same result.

use std::time::Duration;

use fs020n_kin::RobotModel;
use fs020n_proto::{ErrorCode, JointsDeg, Status};

mod immediate;
mod memory;
mod native_view;
mod program_view;
mod sessions;
mod start;
mod tasks;

pub use immediate::ImmediateRefusal;
pub use memory::{Abort, MemoryLoad, MemoryMut, MemoryView, PoseValue, PowerCycle};
use memory::{Idle, MonitorState};
pub use native_view::NativeView;
pub use program_view::{ProgramMut, ProgramView};
pub(crate) use start::{split_program, split_task};
pub use start::{ProgramStart, StartSpecError};

use crate::fault::Fault;
use crate::machine::{
    Behaviour, ControllerConfig, Machine, PanelChange, PanelError, ServerPicture, Timing,
};
use crate::motion::{Arm, MotionPhase};
use crate::native::{Handled, NativeServer, SessionGone, SessionId};
use crate::network::Network;
use crate::panel::Panel;
use crate::program::{ProgramServer, ServerProgram};
use crate::snapshot::{Counters, MotionTaskState, Refused, SessionEnd, Snapshot};
use crate::store::{ProgramStore, AUTOSTART_SWITCHES};

/// The emulated FS020N controller: a machine (clock, arm, panel, error, monitor speed,
/// faults, counters) and the server program that runs on it — the native protocol-1040 server
/// ([`Controller::new`]), an AS program ([`Controller::with_program`]) or nothing yet
/// ([`Controller::bare`]).
///
/// It is a state machine in the manner of a sans-IO protocol: it never sleeps and never reads
/// a clock; a driver gives it time and input and reads its output. The controller itself holds
/// what every server shares (time, the arm, the panel, faults, the network); what belongs to
/// one part is behind a borrowing view of that part, as a QUIC connection's streams are:
/// [`native`](Controller::native) (the native server's session and motion program),
/// [`program`](Controller::program) / [`program_mut`](Controller::program_mut) (the AS
/// program: its tasks, signals, variables, clients and connections) and
/// [`memory`](Controller::memory) / [`memory_mut`](Controller::memory_mut) (the program
/// memory and switches the monitor terminal operates). The API, by concern:
///
/// - **Construction.** [`new`](Controller::new) (the native server),
///   [`with_program`](Controller::with_program) (an AS program, its autostart programs
///   started), [`bare`](Controller::bare) (nothing loaded, `fs020n sim --bare`).
/// - **Time.** [`advance_to`](Controller::advance_to) / [`advance_by`](Controller::advance_by)
///   integrate motion tick by tick and run the server up to a time; [`now`](Controller::now).
///   The next times a driver must wake up at: [`NativeView::receive_deadline`] and
///   [`NativeView::next_listen_change`] (native server), [`ProgramView::next_event`] (AS
///   program), and [`reading_paused_until`](Controller::reading_paused_until) (a fault that
///   stops reading, for both).
/// - **Input from a protocol client** (native server, one session at a time): a client
///   connects with [`try_accept`](Controller::try_accept), sends a request with
///   [`handle_request`](Controller::handle_request) (one receive call = one request; the
///   answer is the reply bytes and a fault to apply), reports a delayed reply out with
///   [`reply_sent`](Controller::reply_sent), and a lost connection with
///   [`end_session_of`](Controller::end_session_of). The session's and the motion program's
///   state: [`native`](Controller::native) ([`NativeView`]). A controller running an AS
///   program refuses these connections: its clients connect through
///   [`ProgramMut::connect`].
/// - **Input and output of an AS program** ([`program_mut`](Controller::program_mut),
///   [`ProgramMut`]): clients connect, send, read and close
///   ([`ProgramMut::connect`], [`ProgramMut::send`], [`ProgramMut::recv`],
///   [`ProgramMut::close`]); the connections the program makes to other hosts are taken with
///   [`ProgramMut::take_dials`] and reported with [`ProgramMut::dialed`]; wiring sets inputs
///   ([`ProgramMut::set_input`]); tasks start and stop as at the terminal
///   ([`ProgramMut::pc_execute`], [`ProgramMut::execute`], [`ProgramMut::pc_abort`],
///   [`ProgramMut::abort`], [`ProgramMut::kill`], [`ProgramMut::hold`]). What it shows
///   ([`program`](Controller::program), [`ProgramView`]): its tasks, terminal lines,
///   signals, variables, the ports it listens on.
/// - **The network** the AS program's connections go through: the controller's address, its
///   host map and port map ([`network`](Controller::network),
///   [`set_network`](Controller::set_network), [`Network`]).
/// - **Observers** of the machine: [`model`](Controller::model),
///   [`timing`](Controller::timing), [`behaviour`](Controller::behaviour),
///   [`panel`](Controller::panel), [`error`](Controller::error),
///   [`monitor_speed`](Controller::monitor_speed), [`abs_speed`](Controller::abs_speed),
///   [`joints`](Controller::joints), [`velocity`](Controller::velocity),
///   [`arm`](Controller::arm), [`motion_phase`](Controller::motion_phase),
///   [`task`](Controller::task), [`counters`](Controller::counters),
///   [`pending_faults`](Controller::pending_faults), [`status`](Controller::status),
///   [`start_blockers`](Controller::start_blockers), and all of it at once:
///   [`snapshot`](Controller::snapshot).
/// - **Panel and pendant.** [`set_power`](Controller::set_power),
///   [`set_run`](Controller::set_run), [`set_repeat`](Controller::set_repeat),
///   [`set_teach_lock`](Controller::set_teach_lock), [`apply_panel`](Controller::apply_panel),
///   [`set_estop`](Controller::set_estop), [`reset_error`](Controller::reset_error),
///   [`set_monitor_speed`](Controller::set_monitor_speed),
///   [`set_abs_speed`](Controller::set_abs_speed), [`power_cycle`](Controller::power_cycle);
///   fault injection: [`inject`](Controller::inject),
///   [`clear_faults`](Controller::clear_faults).
/// - **Memory and switches** (what the monitor terminal lists, loads, saves and deletes):
///   [`memory`](Controller::memory) ([`MemoryView`]: the programs, their bytes, the data
///   sections, a syntax check, the switches) and [`memory_mut`](Controller::memory_mut)
///   ([`MemoryMut`]: load, delete, define a pose, set a switch).
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
    /// AUTOSTART switch is OFF. Its programs load with `load` (`LoadOptions::new()`, or
    /// instructions declared no-ops: `fs020n sim --bare --stub …`), at every `LOAD` and
    /// rebuild.
    pub fn bare(config: ControllerConfig, load: fs020n_as::LoadOptions) -> Controller {
        Controller {
            machine: Machine::new(config),
            server: Server::Empty,
            memory: ProgramStore::new(fs020n_as::Config::default(), load),
            monitor: MonitorState::default(),
        }
    }

    fn native_server(&self) -> Option<&NativeServer> {
        match &self.server {
            Server::Native(n) => Some(n),
            Server::Program(_) | Server::Empty => None,
        }
    }

    fn server_program(&self) -> Option<&ProgramServer> {
        match &self.server {
            Server::Native(_) | Server::Empty => None,
            Server::Program(p) => Some(p),
        }
    }

    fn server_program_mut(&mut self) -> Option<&mut ProgramServer> {
        match &mut self.server {
            Server::Native(_) | Server::Empty => None,
            Server::Program(p) => Some(p),
        }
    }

    // ----------------------------------------------------------------- views

    /// The native server's session and motion program (empty answers when another server
    /// runs).
    pub fn native(&self) -> NativeView<'_> {
        NativeView { c: self }
    }

    /// What the AS program shows: its tasks, terminal, signals, variables, ports (empty
    /// answers without an AS program).
    pub fn program(&self) -> ProgramView<'_> {
        ProgramView { c: self }
    }

    /// The AS program's inputs: its clients, its connections to other hosts, its input
    /// signals, its tasks started and stopped as at the terminal.
    pub fn program_mut(&mut self) -> ProgramMut<'_> {
        ProgramMut { c: self }
    }

    /// The program memory and the switches, as the monitor terminal lists them.
    pub fn memory(&self) -> MemoryView<'_> {
        MemoryView { c: self }
    }

    /// The program memory and the switches, as the monitor terminal loads, deletes and sets
    /// them.
    pub fn memory_mut(&mut self) -> MemoryMut<'_> {
        MemoryMut { c: self }
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

    /// The errors raised since the controller started (the last 100, oldest first), with the
    /// controller time each was raised at: `ERRLOG`.
    pub fn error_log(&self) -> Vec<(Duration, ErrorCode)> {
        self.machine.error_log().copied().collect()
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
        let executes = self
            .native_server()
            .is_some_and(NativeServer::program_executes);
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

    /// Presses (`true`) or releases (`false`) the emergency stop. Pressed: motor power is
    /// cut, the robot stops dead, the program ends and E3808 is raised. Released: the error
    /// stays until reset, power stays off.
    pub fn set_estop(&mut self, pressed: bool) {
        if !pressed {
            self.machine.release_estop();
            return;
        }
        if let Server::Native(n) = &mut self.server {
            n.end_program();
        }
        self.machine.press_estop();
    }

    /// Resets the error (ERESET). Refused while the emergency stop is pressed.
    pub fn reset_error(&mut self) -> Result<(), PanelError> {
        self.machine.reset_error()
    }

    /// Switches ABS.SPEED (a system switch) on or off, as the pendant can. Command 3 switches
    /// it on; only the pendant switches it off.
    pub fn set_abs_speed(&mut self, on: bool) {
        if let Some(p) = self.server_program_mut() {
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
    /// refuses (its clients connect with [`ProgramMut::connect`]).
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

    /// Until when the communication task does not read (fault injection): the native
    /// server's session and the AS program's clients alike.
    pub fn reading_paused_until(&self) -> Option<Duration> {
        self.machine.reading_paused_until()
    }

    // ----------------------------------------------------------------- network

    /// The controller's address, host map and port map.
    pub fn network(&self) -> &Network {
        self.machine.network()
    }

    /// Replaces the controller's address, host map and port map (from the next
    /// `TCP_CONNECT`, `UDP_SENDTO` or client on).
    pub fn set_network(&mut self, network: Network) {
        self.machine.set_network(network);
    }
}
