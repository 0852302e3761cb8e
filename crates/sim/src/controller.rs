//! The emulated controller: panel, error, the communication task, the motion program and the
//! robot, advanced by a clock it is given ([`Controller::advance_to`]). No sleeps, no wall clock:
//! the same inputs at the same times give the same result.

use std::time::Duration;

use fs020n_kin::{JointMove, RobotModel};
use fs020n_proto::server::ServerRequest;
use fs020n_proto::session::{
    ACCEPT_WINDOW, COMMAND_RING_LEN, RECEIVE_TIMEOUT, SINGULAR_JMOVE_SPEED_PERCENT,
    SINGULAR_ZONE_DEG, STEP_AVERAGE_WEIGHT, STREAM_LMOVE_TIME_S,
};
use fs020n_proto::{
    Command, ErrorCode, JointsDeg, Status, StreamSample, Timer, JOINT_COUNT, PROTOCOL_VERSION,
};
use serde::Serialize;

use crate::fault::{Fault, FaultQueue, ReplyFault};
use crate::motion::{LinearPath, Motion, MotionPhase, Robot, Shape};
use crate::panel::Panel;
use crate::snapshot::{CommandInfo, LastEnd, SessionInfo, Snapshot};
pub use crate::snapshot::{Counters, MoveKind, PassInfo, PassMotion, SessionEnd, TaskState};

/// Timing choices of the emulator (see docs/EMULATOR.md for the reasoning behind each).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Timing {
    /// Motion integration period.
    pub tick: Duration,
    /// The motion program's loop overhead: the time from the end of one pass (its motion
    /// instruction accepted, `last_tm := TIMER(2)`) to the start of the next (`tm := TIMER(2)`):
    /// the loop's own statements and its terminal `PRINT`. `step` converges to it (spec §2.4),
    /// so command 7 extrapolates `ARG2 × pass` beyond the controller's "now".
    pub pass: Duration,
    /// How long signal 2007 must stay on before the motion program's `ONI 2007` fires (AS: an
    /// interrupt signal must be stable for at least 50 ms). Command 2, 255, a timeout or a lost
    /// connection raise the signal; the program stops that much later.
    pub signal_edge: Duration,
    /// Gap between two 3-second listen windows, during which connections are refused.
    pub listen_gap: Duration,
    /// Length of one listen window (`TCP_ACCEPT` timeout: 3 s). Only tests that must see a
    /// listen gap over real TCP quickly should shorten it.
    pub accept_window: Duration,
}

/// Controller tick: motion is integrated every 2 ms.
pub const TICK: Duration = Duration::from_millis(2);
/// The motion program's loop overhead (one pass without waiting for motion): a few interpreted
/// statements and a terminal `PRINT`. Medium confidence; see docs/EMULATOR.md.
pub const PASS_TIME: Duration = Duration::from_millis(4);
/// How long signal 2007 must be stable before `ONI 2007` fires.
pub const SIGNAL_EDGE: Duration = Duration::from_millis(50);
/// Gap between listen windows.
pub const LISTEN_GAP: Duration = Duration::from_millis(100);

impl Default for Timing {
    fn default() -> Self {
        Timing {
            tick: TICK,
            pass: PASS_TIME,
            signal_edge: SIGNAL_EDGE,
            listen_gap: LISTEN_GAP,
            accept_window: ACCEPT_WINDOW,
        }
    }
}

/// How a controller starts.
#[derive(Debug, Clone)]
pub struct ControllerConfig {
    /// The robot model (ranges, speeds, geometry, defaults).
    pub model: RobotModel,
    /// Initial panel switches.
    pub panel: Panel,
    /// Initial monitor speed, percent (default: the model's, 10 %).
    pub monitor_speed_percent: f64,
    /// Initial joints (default: the model's home pose).
    pub joints: JointsDeg,
    /// Initial error (default none).
    pub error: ErrorCode,
    /// Timing choices.
    pub timing: Timing,
    /// Behaviours the manuals leave open (documented choices).
    pub behaviour: Behaviour,
}

/// What happens to a motion already planned by look-ahead when command 5's `BRAKE` stops the
/// current one. Kawasaki does not document it; the spec's medium-confidence reading is that it
/// is then executed, so that is the default. A client must not rely on either (send 2 to be
/// sure the arm stays still).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum PlannedAfterBrake {
    /// The planned motion starts once the brake has stopped the arm (default).
    #[default]
    Execute,
    /// The planned motion is dropped with the current one.
    Drop,
}

/// Behaviours of the controller that the manuals leave open, each a documented choice
/// (docs/EMULATOR.md, fidelity table).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, serde::Deserialize)]
pub struct Behaviour {
    /// A motion planned by look-ahead when `BRAKE` (command 5) arrives.
    pub planned_after_brake: PlannedAfterBrake,
    /// `true`: the motion program's local argument array keeps its values when the program is
    /// started again by command 1 (stale arguments survive a restart). Default `false`: the
    /// locals of a new execution start undefined (medium confidence).
    pub locals_survive_restart: bool,
}

impl ControllerConfig {
    /// A ready-to-run controller of `model`: power ON, RUN, REPEAT, lock OFF, no error, at
    /// home, with the model's monitor speed.
    pub fn new(model: RobotModel) -> ControllerConfig {
        ControllerConfig {
            panel: Panel::default(),
            monitor_speed_percent: model.controller.monitor_speed_percent,
            joints: model.home,
            error: ErrorCode::NONE,
            timing: Timing::default(),
            behaviour: Behaviour::default(),
            model,
        }
    }
}

impl Default for ControllerConfig {
    fn default() -> Self {
        ControllerConfig::new(RobotModel::fs020n())
    }
}

/// Identifies one session (one accepted connection).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize)]
pub struct SessionId(pub u64);

/// Why a connection was refused.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum Refused {
    /// Between two listen windows.
    #[error("connection refused: the controller is between two listen windows")]
    ListenGap,
    /// Another client holds the session.
    #[error("connection refused: another client holds the session")]
    SessionOpen,
}

/// The request was for a session that has ended.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
#[error("the session has ended")]
pub struct SessionGone;

/// What the communication task does with one received request.
#[derive(Debug, Clone, PartialEq)]
pub struct Handled {
    /// The reply bytes, exactly as the controller formats them.
    pub reply: Vec<u8>,
    /// A fault to apply to this reply.
    pub fault: Option<ReplyFault>,
    /// After sending the reply, close the connection (command 255).
    pub close: bool,
}

#[derive(Debug, Clone)]
struct Session {
    id: SessionId,
    last_rx: Duration,
    /// A delayed or split reply is being sent: the communication task is not receiving, so its
    /// receive timeout does not run.
    replying: bool,
}

/// One row of the command ring (`ros_cmd[ind, …]`), a global array that is never cleared: the
/// parser writes the command, COUNT and COUNT arguments; entries beyond COUNT keep the values
/// of the row's earlier uses. Arguments are always assigned from the first on, so the assigned
/// ones are a prefix: `args.len()` is how many were ever assigned.
#[derive(Debug, Clone, Default)]
struct RingRow {
    number: f64,
    count: usize,
    args: Vec<f64>,
}

impl RingRow {
    fn command(&self) -> Command {
        ServerRequest {
            version: PROTOCOL_VERSION as f64,
            command_number: self.number,
            count: self.count,
            args: self.args.iter().copied().take(self.count).collect(),
        }
        .command()
    }
}

/// The motion instruction a pass waits to have accepted (look-ahead).
#[derive(Debug, Clone, Copy)]
struct Blocked {
    /// The pass's `tm` (TIMER(2) at its start), seconds.
    tm_s: f64,
    target: JointsDeg,
    kind: Kind,
}

#[derive(Debug, Clone)]
struct ProgramRun {
    next_pass_at: Duration,
    /// The pass whose planned motion waits to blend in.
    blocked: Option<Blocked>,
    step_s: f64,
    /// TIMER(2) when the previous pass's motion instruction was accepted (or the program
    /// started), seconds.
    last_tm_s: f64,
    prev_pt: Option<[f32; JOINT_COUNT]>,
    /// The program's local argument array: COUNT arguments are copied in per pass, the others
    /// keep earlier passes' values; `args.len()` of them have ever been assigned.
    args: Vec<f64>,
    /// `ros_move_run`: the loop runs while it is set; command 2 clears it.
    run_flag: bool,
    /// The loop has ended; the task waits for the last motion (TASK(1) = 3).
    finishing: bool,
    /// The `ONI 2007` has fired (it fires once): the program has ended and the arm brakes.
    interrupted: bool,
}

/// The emulated FS020N controller running the protocol-1040 AS server program.
#[derive(Debug, Clone)]
pub struct Controller {
    model: RobotModel,
    timing: Timing,
    behaviour: Behaviour,
    /// Time of the latest event.
    now: Duration,
    /// Time up to which motion has been integrated (a multiple of the tick).
    tick_time: Duration,
    panel: Panel,
    error: ErrorCode,
    monitor_speed: f64,
    abs_speed: bool,
    robot: Robot,
    program: Option<ProgramRun>,
    /// The local argument array of the last execution (kept only with
    /// [`Behaviour::locals_survive_restart`]).
    kept_args: Vec<f64>,
    /// Since when signal 2007 (stop the motion program) has been on.
    signal_2007_since: Option<Duration>,
    session: Option<Session>,
    /// The command ring: never cleared, survives sessions.
    ring: Vec<RingRow>,
    /// Index of the newest request in the ring (reset to 0 on accept).
    newest: usize,
    /// When TIMER(1) and TIMER(2) were last reset (the latest accept).
    timer_epoch: Duration,
    listen_since: Duration,
    next_session: u64,
    last_session_end: Option<(SessionId, SessionEnd)>,
    stop_reading_until: Option<Duration>,
    faults: FaultQueue,
    counters: Counters,
    /// An AS program run instead of the native server (`crate::as_host`).
    pub(crate) as_runtime: Option<Box<crate::as_host::AsRuntime>>,
    /// What the motion tick needs from the AS program (inactive without one).
    pub(crate) as_link: crate::as_host::Link,
    last_pass: Option<PassInfo>,
}

fn as_seconds_ms(d: Duration) -> f64 {
    // TIMER has a 1 ms resolution.
    (d.as_millis() as f64) / 1000.0
}

impl Controller {
    /// A controller at time zero, listening.
    pub fn new(config: ControllerConfig) -> Controller {
        let mut config = config;
        // Zero periods would stall time or divide by zero: keep the defaults instead.
        let defaults = Timing::default();
        if config.timing.tick.is_zero() {
            config.timing.tick = defaults.tick;
        }
        if (config.timing.accept_window + config.timing.listen_gap).is_zero() {
            config.timing.accept_window = defaults.accept_window;
        }
        let mut panel = config.panel;
        if panel.estop {
            panel.power = false;
        }
        let error = if config.panel.estop && config.error.is_none() {
            ErrorCode::EMERGENCY_STOP
        } else {
            config.error
        };
        Controller {
            robot: Robot::new(config.joints),
            model: config.model,
            timing: config.timing,
            behaviour: config.behaviour,
            now: Duration::ZERO,
            tick_time: Duration::ZERO,
            panel,
            error,
            monitor_speed: clamp_speed(config.monitor_speed_percent).unwrap_or(10.0),
            abs_speed: false,
            program: None,
            kept_args: Vec::new(),
            signal_2007_since: None,
            session: None,
            ring: vec![RingRow::default(); COMMAND_RING_LEN],
            newest: 0,
            timer_epoch: Duration::ZERO,
            listen_since: Duration::ZERO,
            next_session: 1,
            last_session_end: None,
            stop_reading_until: None,
            faults: FaultQueue::default(),
            as_runtime: None,
            as_link: crate::as_host::Link::default(),
            counters: Counters::default(),
            last_pass: None,
        }
    }

    // ----------------------------------------------------------------- observers

    /// Controller time (since start).
    pub fn now(&self) -> Duration {
        self.now
    }

    /// The robot model.
    pub fn model(&self) -> &RobotModel {
        &self.model
    }

    /// The timing choices.
    pub fn timing(&self) -> Timing {
        self.timing
    }

    /// The behaviour choices.
    pub fn behaviour(&self) -> Behaviour {
        self.behaviour
    }

    /// Panel switches.
    pub fn panel(&self) -> Panel {
        self.panel
    }

    /// Current error (0 = none).
    pub fn error(&self) -> ErrorCode {
        self.error
    }

    /// Monitor speed, percent.
    pub fn monitor_speed(&self) -> f64 {
        self.monitor_speed
    }

    /// `true` once command 3 has switched ABS.SPEED on.
    pub fn abs_speed(&self) -> bool {
        if let Some(rt) = &self.as_runtime {
            return rt.abs_speed();
        }
        self.abs_speed
    }

    /// Joint angles, degrees.
    pub fn joints(&self) -> JointsDeg {
        self.robot.joints()
    }

    /// Joint velocities, deg/s.
    pub fn velocity(&self) -> JointsDeg {
        self.robot.velocity()
    }

    /// The robot's motion state.
    pub fn robot(&self) -> &Robot {
        &self.robot
    }

    /// What the robot is doing.
    pub fn motion_phase(&self) -> MotionPhase {
        self.robot.phase()
    }

    /// State of the motion program.
    pub fn task(&self) -> TaskState {
        if self.as_link.active {
            return self.as_link.task;
        }
        match &self.program {
            None => TaskState::NotRunning,
            Some(run) if run.finishing => TaskState::Finishing,
            Some(_) if !self.panel.run => TaskState::Paused,
            Some(_) => TaskState::Running,
        }
    }

    /// `true` while signal 2007 (stop the motion program) is on.
    pub fn stop_signal(&self) -> bool {
        self.signal_2007_since.is_some()
    }

    /// The program's average pass duration `step`, seconds (0 when not running).
    pub fn step_s(&self) -> f64 {
        self.program.as_ref().map_or(0.0, |p| p.step_s)
    }

    /// The open session, if any.
    pub fn session(&self) -> Option<SessionId> {
        self.session.as_ref().map(|s| s.id)
    }

    /// `true` while `id` is the open session.
    pub fn is_session_open(&self, id: SessionId) -> bool {
        self.session() == Some(id)
    }

    /// How the latest session ended.
    pub fn last_session_end(&self) -> Option<(SessionId, SessionEnd)> {
        self.last_session_end
    }

    /// TIMER(1): seconds since the session was accepted (1 ms resolution), 0 without a session.
    pub fn timer1_s(&self) -> f64 {
        if self.session.is_some() {
            self.timer_s(self.now)
        } else {
            0.0
        }
    }

    /// TIMER(1)/TIMER(2) at controller time `t`: seconds since the latest accept, 1 ms
    /// resolution (they keep counting after the session ends).
    fn timer_s(&self, t: Duration) -> f64 {
        as_seconds_ms(t.saturating_sub(self.timer_epoch))
    }

    /// The newest command of the ring as the motion program reads it (command 0 right after
    /// accept), while a session is open.
    pub fn newest_command(&self) -> Option<Command> {
        self.session
            .as_ref()
            .map(|_| self.ring[self.newest].command())
    }

    /// The ring index of the newest command, while a session is open.
    pub fn newest_index(&self) -> Option<usize> {
        self.session.as_ref().map(|_| self.newest)
    }

    /// The reply of session `id` has been sent: the communication task receives again and its
    /// 5 s receive timeout starts now (spec §4: receive, act, send, receive…). Callers that
    /// apply a delayed or split reply ([`Handled::fault`]) must call it once the reply is out;
    /// until then the session cannot time out.
    pub fn reply_sent(&mut self, id: SessionId) {
        let now = self.now;
        if let Some(s) = self.session.as_mut().filter(|s| s.id == id) {
            s.replying = false;
            s.last_rx = now;
        }
    }

    /// When the open session times out for lack of requests (`None` while a delayed reply is
    /// being sent).
    pub fn receive_deadline(&self) -> Option<Duration> {
        self.session
            .as_ref()
            .filter(|s| !s.replying)
            .map(|s| s.last_rx + RECEIVE_TIMEOUT)
    }

    /// Until when the communication task does not read (fault injection).
    pub fn reading_paused_until(&self) -> Option<Duration> {
        self.stop_reading_until.filter(|&t| t > self.now)
    }

    /// Counters.
    pub fn counters(&self) -> Counters {
        self.counters
    }

    /// What the latest pass of the motion program decided.
    pub fn last_pass(&self) -> Option<PassInfo> {
        self.last_pass
    }

    /// A serializable picture of the whole state now.
    pub fn snapshot(&self) -> Snapshot {
        let model = self.model();
        let joints = self.joints();
        let x = model.forward(&joints.to_rad()).to_xyzoat();
        let session_open = self.session().is_some();
        Snapshot {
            time_s: self.now().as_secs_f64(),
            model: model.name().to_owned(),
            panel: self.panel(),
            error: self.error().into(),
            joints_deg: joints,
            velocities_deg_s: self.velocity(),
            tool: x,
            task: self.task(),
            motion: self.motion_phase(),
            motion_planned: self.robot().has_planned(),
            motion_target_deg: self.robot().target(),
            monitor_speed_percent: self.monitor_speed(),
            abs_speed: self.abs_speed(),
            step_s: self.step_s(),
            last_pass: self.last_pass(),
            start_blockers: self
                .start_blockers()
                .into_iter()
                .map(str::to_owned)
                .collect(),
            session: match &self.as_runtime {
                Some(rt) => rt.session_info(self),
                None => SessionInfo {
                    open: session_open,
                    id: self.session().map(|s| s.0),
                    timer1_s: session_open.then(|| self.timer1_s()),
                    newest_command: self.newest_command().map(|cmd| CommandInfo {
                        number: cmd.number(),
                        command: cmd,
                    }),
                    newest_index: self.newest_index(),
                    listening: self.is_listening(),
                    reading_paused: self.reading_paused_until().is_some(),
                    last_end: self
                        .last_session_end()
                        .map(|(id, reason)| LastEnd { id: id.0, reason }),
                },
            },
            pending_faults: self.pending_faults(),
            counters: self.counters(),
            program: self.as_runtime.as_ref().map(|rt| rt.info(self)),
        }
    }

    /// The fault for the next reply, if any (an AS program's replies: `crate::as_host`).
    pub(crate) fn next_reply_fault(&mut self) -> Option<ReplyFault> {
        self.faults.next_reply()
    }

    /// Starts a motion now (an AS program's motions: `crate::as_host`).
    pub(crate) fn robot_start(&mut self, m: Motion) {
        self.robot.start(m);
        self.counters.motions += 1;
    }

    /// Plans a motion to blend in (an AS program's look-ahead).
    pub(crate) fn robot_plan(&mut self, m: Motion) {
        self.robot.plan(m);
    }

    /// `true` when a new motion may start now (the tool within `accuracy_mm` of the target).
    pub(crate) fn robot_ready_for_next(&mut self, accuracy_mm: f64) -> bool {
        self.robot.ready_for_next(&self.model, accuracy_mm)
    }

    /// BRAKE: stops the motion at once and drops the planned one.
    pub(crate) fn robot_brake(&mut self) {
        self.robot.brake(&self.model);
    }

    /// Pauses (HOLD) or resumes the motion.
    pub(crate) fn robot_set_hold(&mut self, held: bool) {
        self.robot.set_hold(held);
    }

    /// Counters, to count an AS program's sessions and motions.
    pub(crate) fn counters_mut(&mut self) -> &mut Counters {
        &mut self.counters
    }

    /// Reply faults waiting.
    pub fn pending_faults(&self) -> usize {
        self.faults.pending()
    }

    /// The status reply as it would be sent now.
    pub fn status(&self) -> Status {
        Status {
            version: PROTOCOL_VERSION,
            error: self.error,
            run: self.panel.run,
            repeat: self.panel.repeat,
            teach_lock: self.panel.teach_lock,
            power: self.panel.power,
            task_running: self.task() == TaskState::Running,
            // The server builds the reply from AS reals (32-bit): `TIMER(1)` and the joints
            // `DECOMPOSE`d from `#HERE` pass through them before `$ENCODE` prints them.
            timer: Timer::Seconds(f64::from(self.timer1_s() as f32)),
            joints: self.robot.joints().map(|v| f64::from(v as f32)),
        }
    }

    /// `true` while connections are accepted now.
    pub fn is_listening(&self) -> bool {
        self.session.is_none() && self.listen_phase() < self.timing.accept_window
    }

    fn listen_phase(&self) -> Duration {
        let cycle = self.timing.accept_window + self.timing.listen_gap;
        let since = self.now.saturating_sub(self.listen_since);
        Duration::from_nanos((since.as_nanos() % cycle.as_nanos()) as u64)
    }

    /// When the listening state changes next (window opens or closes); `None` during a session.
    pub fn next_listen_change(&self) -> Option<Duration> {
        if self.session.is_some() {
            return None;
        }
        let phase = self.listen_phase();
        let window = self.timing.accept_window;
        let rest = if phase < window {
            window - phase
        } else {
            window + self.timing.listen_gap - phase
        };
        Some(self.now + rest)
    }

    /// Conditions of command 1 that are not met, as the controller would report them
    /// (P1000 power off, P1001 TEACH, P1002 lock on, P1013 in error, P1009 already running;
    /// HOLD has no code of its own).
    pub fn start_blockers(&self) -> Vec<&'static str> {
        let mut v = Vec::new();
        if !self.panel.power {
            v.push("motor power is OFF (P1000)");
        }
        if !self.panel.run {
            v.push("RUN/HOLD is on HOLD");
        }
        if !self.panel.repeat {
            v.push("TEACH/REPEAT is on TEACH (P1001)");
        }
        if self.panel.teach_lock {
            v.push("TEACH LOCK is ON (P1002)");
        }
        if !self.error.is_none() {
            v.push("the controller is in error (P1013)");
        }
        if self.program.is_some() {
            v.push("the program is already running (P1009)");
        }
        v
    }

    // ----------------------------------------------------------------- time

    fn is_quiescent(&self) -> bool {
        self.program.is_none() && self.robot.is_still()
    }

    /// Advances the controller to time `t` (no-op if `t` is not later than now): integrates
    /// motion tick by tick, runs program passes, and ends the session on the receive timeout.
    /// Idle stretches are skipped in one step.
    pub fn advance_to(&mut self, t: Duration) {
        // With an AS program, its interpreter drives: it integrates motion up to each of its
        // steps (`integrate_to`).
        if let Some(mut rt) = self.as_runtime.take() {
            rt.run_until(self, t);
            self.as_runtime = Some(rt);
            return;
        }
        self.integrate_to(t);
    }

    /// Integrates motion (and runs the native program) up to `t`.
    pub(crate) fn integrate_to(&mut self, t: Duration) {
        if t <= self.now {
            return;
        }
        let tick = self.timing.tick;
        while self.tick_time + tick <= t {
            if self.is_quiescent() {
                let limit = match self.receive_deadline() {
                    Some(d) if d <= t => d.max(self.tick_time + tick),
                    _ => t,
                };
                let n = ((limit - self.tick_time).as_nanos() / tick.as_nanos()).max(1) as u32;
                self.tick_time += tick * n;
                self.now = self.now.max(self.tick_time);
                self.check_receive_timeout();
                continue;
            }
            self.tick_time += tick;
            self.now = self.now.max(self.tick_time);
            self.tick();
        }
        self.now = t;
        self.check_receive_timeout();
    }

    /// Advances by `d`.
    pub fn advance_by(&mut self, d: Duration) {
        self.advance_to(self.now + d);
    }

    fn check_receive_timeout(&mut self) {
        if let Some(deadline) = self.receive_deadline() {
            if self.now >= deadline {
                self.counters.receive_timeouts += 1;
                tracing::info!("receive timeout: no request for 5 s, ending the session");
                self.end_session(SessionEnd::ReceiveTimeout);
            }
        }
    }

    fn tick(&mut self) {
        let t = self.tick_time;
        self.check_receive_timeout();
        // `ONI 2007`: once the signal has been stable for the edge time, the motion stops at
        // once and the program ends; the brake is its last motion (TASK(1) = 3 until the arm
        // stands, below).
        if let Some(since) = self.signal_2007_since {
            let armed = self.program.as_ref().is_some_and(|r| !r.interrupted);
            if armed && t >= since + self.timing.signal_edge {
                tracing::info!("signal 2007: motion program ros_move interrupted");
                self.interrupt_program();
            }
        }
        if self.panel.run {
            // A planned motion blends in once the tool is within ACCURACY of the target.
            if let Some(blocked) = self.program.as_ref().and_then(|r| r.blocked) {
                if let Some(m) = self
                    .robot
                    .take_planned_if_ready(&self.model, self.model.controller.accuracy_mm)
                {
                    self.robot.start(m);
                    self.counters.motions += 1;
                    self.finish_pass(blocked.tm_s, t);
                }
            }
            // An AS program's planned motion blends in once the tool is within its ACCURACY.
            if self.as_link.active {
                if let Some(m) = self
                    .robot
                    .take_planned_if_ready(&self.model, self.as_link.accuracy_mm)
                {
                    self.as_link.accuracy_mm = self.as_link.planned_accuracy_mm;
                    self.robot.start(m);
                    self.counters.motions += 1;
                }
            }
            let due = self
                .program
                .as_ref()
                .is_some_and(|r| r.blocked.is_none() && !r.finishing && t >= r.next_pass_at);
            if due {
                self.program_pass(t);
            }
        }
        self.robot.tick(&self.model, self.timing.tick.as_secs_f64());
        // TASK(1) = 3 ends when the last motion has: in the tick the arm comes to rest (as
        // the interpreter's finishing task sees it on its poll at this instant).
        if self.program.as_ref().is_some_and(|r| r.finishing) && self.robot.is_still() {
            self.end_program();
        }
    }

    /// The end of a pass whose motion instruction was accepted at `t` (or that issued none):
    /// `step = 0.9 step + 0.1 (tm − last_tm)`, `last_tm := TIMER(2)`, and the next pass starts
    /// after the loop overhead. `tm − last_tm` is the time from the previous pass's end to this
    /// pass's start — the overhead only, never the motion wait (spec §2.4).
    fn finish_pass(&mut self, tm_s: f64, t: Duration) {
        let pass = self.timing.pass;
        let timer_now = self.timer_s(t);
        if let Some(run) = &mut self.program {
            run.step_s = (1.0 - STEP_AVERAGE_WEIGHT) * run.step_s
                + STEP_AVERAGE_WEIGHT * (tm_s - run.last_tm_s);
            run.last_tm_s = timer_now;
            run.blocked = None;
            run.next_pass_at = t + pass;
        }
    }

    fn speed_fraction(&self, program_percent: f64) -> f64 {
        let eff = if self.abs_speed {
            program_percent.min(self.monitor_speed)
        } else {
            program_percent * self.monitor_speed / 100.0
        };
        eff / 100.0
    }

    /// One pass of `ros_move`: check the running flag, read the newest request (copying its
    /// COUNT arguments into the local array), execute 6 or 7.
    fn program_pass(&mut self, t: Duration) {
        let tm = self.timer_s(t);
        let Some(run) = &mut self.program else {
            return;
        };
        if !run.run_flag {
            // `WHILE ros_move_run == 1` fails: the steps are done, the last motion finishes.
            run.finishing = true;
            return;
        }
        self.counters.passes += 1;
        let step = run.step_s;
        let row = &self.ring[self.newest];
        let count = row.count.min(row.args.len());
        if run.args.len() < count {
            run.args.resize(count, 0.0);
        }
        run.args[..count].copy_from_slice(&row.args[..count]);
        let number = row.number;
        let args = &run.args;
        // Command 6 reads ARG4–ARG9, command 7 ARG1, ARG2 and ARG4–ARG21 (ARG3 is never read).
        let needed = match number {
            6.0 => 9,
            7.0 => 21,
            _ => 0,
        };
        if args.len() < needed {
            tracing::warn!(
                command = number,
                assigned = args.len(),
                "E0102: the motion program read an argument never assigned since the controller started"
            );
            self.counters.undefined_arguments += 1;
            self.raise(ErrorCode::VARIABLE_NOT_DEFINED);
            return;
        }
        let joints_at = |first: usize| {
            let mut j = [0.0; JOINT_COUNT];
            j.copy_from_slice(&args[first..first + JOINT_COUNT]);
            JointsDeg(j)
        };
        let motion = match number {
            6.0 => Some((joints_at(3), Kind::Joint(self.speed_fraction(100.0)))),
            7.0 => {
                let sample = StreamSample {
                    t0_s: args[0],
                    lookahead_passes: args[1],
                    position: joints_at(3),
                    velocity: joints_at(9),
                    acceleration: joints_at(15),
                };
                let pt = sample.extrapolate(tm, step);
                // AS reals: the program compares 32-bit values.
                let pt32 = pt.0.map(|v| v as f32);
                let changed = run.prev_pt != Some(pt32);
                run.prev_pt = Some(pt32);
                if !changed {
                    None
                } else if pt[2].abs() < SINGULAR_ZONE_DEG || pt[4].abs() < SINGULAR_ZONE_DEG {
                    Some((
                        pt,
                        Kind::Joint(self.speed_fraction(SINGULAR_JMOVE_SPEED_PERCENT)),
                    ))
                } else {
                    // Time-based speed, scaled by the monitor speed.
                    Some((
                        pt,
                        Kind::Linear(STREAM_LMOVE_TIME_S * 100.0 / self.monitor_speed),
                    ))
                }
            }
            _ => None,
        };
        self.last_pass = Some(PassInfo {
            at: t,
            tm_s: tm,
            step_s: step,
            command: number,
            motion: motion.map(|(target, kind)| match kind {
                Kind::Joint(f) => PassMotion {
                    target,
                    kind: MoveKind::Joint,
                    speed: f * 100.0,
                },
                Kind::Linear(d) => PassMotion {
                    target,
                    kind: MoveKind::Linear,
                    speed: d,
                },
            }),
        });
        let Some((target, kind)) = motion else {
            self.finish_pass(tm, t);
            return;
        };
        let from = self.robot.target();
        let Some(m) = self.plan_motion(from, target, kind) else {
            return;
        };
        if self
            .robot
            .ready_for_next(&self.model, self.model.controller.accuracy_mm)
        {
            self.robot.start(m);
            self.counters.motions += 1;
            self.finish_pass(tm, t);
        } else {
            self.robot.plan(m);
            if let Some(run) = &mut self.program {
                run.blocked = Some(Blocked {
                    tm_s: tm,
                    target,
                    kind,
                });
            }
        }
    }

    /// Plans a motion from `from` to `target`; raises E1088 (and stops the program) when the
    /// target is outside the ranges or has no straight-line path.
    fn plan_motion(&mut self, from: JointsDeg, target: JointsDeg, kind: Kind) -> Option<Motion> {
        if !target.is_finite() || !self.model.within_limits(&target) {
            tracing::warn!(%target, "E1088: destination is out of motion range");
            self.raise(ErrorCode::DESTINATION_OUT_OF_RANGE);
            return None;
        }
        let shape = match kind {
            Kind::Joint(f) => Shape::Joint(JointMove::plan(&self.model, from, target, f)),
            Kind::Linear(d) => {
                let from_pose = if crate::motion::same_bits(&from, &self.robot.target()) {
                    self.robot.target_pose(&self.model)
                } else {
                    self.model.forward(&from.to_rad())
                };
                match LinearPath::plan_from_pose(&self.model, from, from_pose, target, d) {
                    Some(p) => Shape::Linear(p),
                    None => {
                        tracing::warn!(%target, "E1088: no straight-line path to the destination");
                        self.raise(ErrorCode::DESTINATION_OUT_OF_RANGE);
                        return None;
                    }
                }
            }
        };
        Some(Motion {
            from,
            to: target,
            shape,
        })
    }

    // ----------------------------------------------------------------- program

    /// Command 1, exactly as the server tests it: the switches (power, RUN, REPEAT, lock off),
    /// then `TASK(1) <> 1 AND ERROR == 0`; then `ros_move_run = 1` and `MC EXECUTE ros_move`,
    /// which the controller refuses (P1009) while the program still executes (TASK 2 or 3).
    fn start_program(&mut self) {
        let switches =
            self.panel.power && self.panel.run && self.panel.repeat && !self.panel.teach_lock;
        if !switches || self.task() == TaskState::Running || !self.error.is_none() {
            self.counters.starts_ignored += 1;
            tracing::info!(blockers = ?self.start_blockers(), "command 1 ignored");
            return;
        }
        if let Some(run) = &mut self.program {
            run.run_flag = true;
            self.counters.starts_refused += 1;
            tracing::info!("command 1: MC EXECUTE refused, the program still executes (P1009)");
            return;
        }
        tracing::info!("motion program ros_move started");
        // `SIGNAL -2007`, then `ONI 2007 GOTO exit`.
        self.signal_2007_since = None;
        let args = if self.behaviour.locals_survive_restart {
            std::mem::take(&mut self.kept_args)
        } else {
            Vec::new()
        };
        self.program = Some(ProgramRun {
            next_pass_at: self.tick_time + self.timing.tick,
            blocked: None,
            step_s: 0.0,
            last_tm_s: self.timer_s(self.now),
            // "Remember the current joints": a first 7 whose point is where the robot stands
            // issues no motion.
            prev_pt: Some(self.robot.joints().0.map(|v| v as f32)),
            args,
            run_flag: true,
            finishing: false,
            interrupted: false,
        });
    }

    /// `SIGNAL 2007`: the program's `ONI` stops it once the signal has been stable for
    /// [`Timing::signal_edge`].
    fn raise_stop_signal(&mut self) {
        if self.signal_2007_since.is_none() {
            self.signal_2007_since = Some(self.now);
        }
    }

    /// `ONI 2007 GOTO stopped` fired: the motion stops at once (a planned one is dropped) and
    /// the program runs to its end. The brake is still its motion, so the task is finishing
    /// (TASK(1) = 3) until the arm stands: a command 1 meanwhile passes the server's own test
    /// and reaches `MC EXECUTE`, which refuses it (P1009) — as the AS text behaves.
    fn interrupt_program(&mut self) {
        self.robot.brake(&self.model);
        if let Some(run) = &mut self.program {
            run.interrupted = true;
            run.finishing = true;
            run.blocked = None;
        }
    }

    /// The program ends at once and the robot brakes (the controller stopped it: TEACH, the
    /// teach lock, an error).
    fn stop_program_now(&mut self) {
        self.end_program();
        self.robot.brake(&self.model);
    }

    fn end_program(&mut self) {
        if let Some(run) = self.program.take() {
            tracing::info!("motion program ros_move ended");
            self.kept_args = run.args;
        }
    }

    pub(crate) fn raise(&mut self, code: ErrorCode) {
        self.counters.errors += 1;
        self.error = code;
        self.stop_program_now();
    }

    // ----------------------------------------------------------------- communication task

    /// A client connects. Accepted only during a listen window and when no session is open.
    /// On accept the command ring and TIMER(1) are reset.
    pub fn try_accept(&mut self) -> Result<SessionId, Refused> {
        if self.session.is_some() {
            self.counters.refused += 1;
            tracing::info!("{}", Refused::SessionOpen);
            return Err(Refused::SessionOpen);
        }
        if !self.is_listening() {
            self.counters.refused += 1;
            tracing::info!("{}", Refused::ListenGap);
            return Err(Refused::ListenGap);
        }
        let id = SessionId(self.next_session);
        self.next_session += 1;
        self.counters.sessions += 1;
        self.stop_reading_until = None;
        self.session = Some(Session {
            id,
            last_rx: self.now,
            replying: false,
        });
        // `ros_cmd_ind = 0` and row 0's command := 0; the ring itself is never cleared.
        self.newest = 0;
        self.ring[0].number = 0.0;
        // TIMER(1) = 0, TIMER(2) = 0.
        self.timer_epoch = self.now;
        tracing::info!(session = id.0, "session accepted");
        Ok(id)
    }

    /// Ends the session `id` (connection lost, send timeout): the robot stops, the program
    /// ends, the controller listens again.
    pub fn end_session_of(&mut self, id: SessionId, why: SessionEnd) {
        if self.is_session_open(id) {
            self.end_session(why);
        }
    }

    fn end_session(&mut self, why: SessionEnd) {
        if let Some(s) = self.session.take() {
            tracing::info!(session = s.id.0, reason = ?why, "session ended");
            self.last_session_end = Some((s.id, why));
            // The communication task's exit: `SIGNAL 2007` (the program's ONI stops it after
            // the signal edge), close the socket, listen again.
            self.raise_stop_signal();
            self.listen_since = self.now;
            self.stop_reading_until = None;
            self.faults.clear();
        }
    }

    /// The communication task receives `bytes` (one receive call = one request) on session
    /// `id`, acts on it and builds the reply with the joints of this instant.
    pub fn handle_request(&mut self, id: SessionId, bytes: &[u8]) -> Result<Handled, SessionGone> {
        let now = self.now;
        let session = match &mut self.session {
            Some(s) if s.id == id => s,
            _ => return Err(SessionGone),
        };
        session.last_rx = now;
        self.counters.requests += 1;
        let req = ServerRequest::parse(bytes);
        let mut close = false;
        tracing::debug!(request = %String::from_utf8_lossy(bytes), "request");
        if req.version_matches() {
            self.counters.effective_requests += 1;
            let previous_was_cancel = self.ring[self.newest].number == 5.0;
            let slot = (self.newest + 1) % COMMAND_RING_LEN;
            // Store the request in the row after the newest: command, COUNT and COUNT
            // arguments; the row's other arguments keep their values.
            let row = &mut self.ring[slot];
            row.number = req.command_number;
            row.count = req.count;
            if row.args.len() < req.count {
                row.args.resize(req.count, 0.0);
            }
            row.args[..req.count].copy_from_slice(&req.args);
            match req.command() {
                Command::StartProgram => self.start_program(),
                Command::StopProgram => {
                    // `SIGNAL 2007` (the ONI fires after the edge) and `ros_move_run = 0`.
                    self.raise_stop_signal();
                    if let Some(run) = &mut self.program {
                        run.run_flag = false;
                    }
                }
                Command::SetSpeed { percent } => {
                    if let Some(p) = clamp_speed(percent) {
                        self.monitor_speed = p;
                    }
                    self.abs_speed = true;
                }
                // Published as newest first, then BRAKE — unless the newest was already a 5.
                Command::CancelMotion if previous_was_cancel => {}
                Command::CancelMotion => {
                    self.newest = slot;
                    self.brake_for_cancel();
                }
                Command::EndSession => close = true,
                _ => {}
            }
            self.newest = slot;
        }
        let reply = self.status().encode_bytes();
        tracing::debug!(reply = %String::from_utf8_lossy(&reply), "reply");
        let fault = self.faults.next_reply();
        if let Some(s) = &mut self.session {
            // A delayed or split reply takes time to send; the receive timeout waits for it
            // (see `reply_sent`).
            s.replying = matches!(fault, Some(ReplyFault::Delay(_) | ReplyFault::Split { .. }));
        }
        if close {
            self.end_session(SessionEnd::EndCommand);
        }
        Ok(Handled {
            reply,
            fault,
            close,
        })
    }

    /// Command 5's `BRAKE`: the current motion stops at once and the motion program goes on
    /// to the next step. A motion the program had planned by look-ahead is then executed from
    /// where the brake stops the arm, or dropped ([`Behaviour::planned_after_brake`]).
    fn brake_for_cancel(&mut self) {
        self.robot.brake(&self.model);
        let Some(blocked) = self.program.as_ref().and_then(|r| r.blocked) else {
            return;
        };
        match self.behaviour.planned_after_brake {
            PlannedAfterBrake::Drop => {
                let t = self.tick_time;
                self.finish_pass(blocked.tm_s, t);
            }
            PlannedAfterBrake::Execute => {
                let from = self.robot.target();
                if let Some(m) = self.plan_motion(from, blocked.target, blocked.kind) {
                    // Starts when the brake has stopped the arm; the pass stays blocked.
                    self.robot.plan(m);
                }
            }
        }
    }

    // ----------------------------------------------------------------- panel and pendant

    /// Turns motor power on or off. Off stops the robot dead and ends the program. On is
    /// refused while the emergency stop is pressed.
    pub fn set_power(&mut self, on: bool) -> Result<(), PanelError> {
        if on && self.panel.estop {
            return Err(PanelError::EstopPressed);
        }
        self.panel.power = on;
        if !on {
            self.robot.halt();
            if self.program.is_some() {
                tracing::info!("motor power off: motion program ends");
                self.end_program();
            }
        }
        Ok(())
    }

    /// RUN (true) or HOLD (false). HOLD decelerates the motion to a pause and pauses the
    /// program; RUN resumes both.
    pub fn set_run(&mut self, run: bool) {
        self.panel.run = run;
        self.robot.set_hold(!run);
    }

    /// REPEAT (true) or TEACH (false). Switching to TEACH stops a running program.
    pub fn set_repeat(&mut self, repeat: bool) {
        self.panel.repeat = repeat;
        if !repeat {
            self.stop_program_now();
        }
    }

    /// TEACH LOCK on or off. On gives the pendant control: a running program stops (the
    /// program cannot run with the lock on, spec §4) and command 1 is refused.
    pub fn set_teach_lock(&mut self, on: bool) {
        self.panel.teach_lock = on;
        if on {
            self.stop_program_now();
        }
    }

    /// Presses the emergency stop: motor power is cut, the robot stops dead, the program ends
    /// and E3808 is raised.
    pub fn press_estop(&mut self) {
        self.panel.estop = true;
        self.panel.power = false;
        self.robot.halt();
        self.end_program();
        self.error = ErrorCode::EMERGENCY_STOP;
        self.counters.errors += 1;
        tracing::warn!("emergency stop pressed");
    }

    /// Releases the emergency stop (the error stays until reset, power stays off).
    pub fn release_estop(&mut self) {
        self.panel.estop = false;
    }

    /// Resets the error (ERESET). Refused while the emergency stop is pressed.
    pub fn reset_error(&mut self) -> Result<(), PanelError> {
        if self.panel.estop {
            return Err(PanelError::EstopPressed);
        }
        self.error = ErrorCode::NONE;
        Ok(())
    }

    /// Switches ABS.SPEED (a system switch) on or off, as the pendant can. Command 3 switches
    /// it on; only the pendant switches it off.
    pub fn set_abs_speed(&mut self, on: bool) {
        if let Some(rt) = &mut self.as_runtime {
            rt.set_abs_speed(on);
        }
        self.abs_speed = on;
    }

    /// Sets the monitor speed (1–100 %). It applies from the next planned motion.
    pub fn set_monitor_speed(&mut self, percent: f64) -> Result<(), PanelError> {
        if percent > 100.0 {
            return Err(PanelError::Speed(percent));
        }
        self.monitor_speed = clamp_speed(percent).ok_or(PanelError::Speed(percent))?;
        Ok(())
    }

    /// Changes several panel switches at once (absent ones stay). Nothing changes when one of
    /// them is refused (power ON while the emergency stop is pressed).
    pub fn apply_panel(&mut self, change: PanelChange) -> Result<(), PanelError> {
        if change.power == Some(true) && self.panel.estop {
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
        self.faults.clear();
        self.stop_reading_until = None;
    }

    /// Injects a fault (see [`Fault`]).
    pub fn inject(&mut self, fault: Fault) {
        tracing::info!(?fault, "fault injected");
        match &fault {
            Fault::CloseConnection => {
                if let Some(rt) = &mut self.as_runtime {
                    rt.close_clients();
                }
                self.end_session(SessionEnd::Fault)
            }
            Fault::StopReading { duration_ms } => {
                let ms = (*duration_ms).min(crate::fault::MAX_FAULT_MS);
                self.stop_reading_until = Some(self.now + Duration::from_millis(ms));
            }
            Fault::RaiseError { code } => self.raise(*code),
            _ => self.faults.push(&fault),
        }
    }
}

#[derive(Debug, Clone, Copy)]
enum Kind {
    Joint(f64),
    Linear(f64),
}

/// Panel switches to change at once ([`Controller::apply_panel`]); `None` leaves one as it is.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PanelChange {
    /// Motor power.
    pub power: Option<bool>,
    /// RUN (true) / HOLD (false).
    pub run: Option<bool>,
    /// REPEAT (true) / TEACH (false).
    pub repeat: Option<bool>,
    /// TEACH LOCK.
    pub teach_lock: Option<bool>,
}

/// A pendant operation that the controller refuses.
#[derive(Debug, Clone, Copy, PartialEq, thiserror::Error)]
pub enum PanelError {
    /// The emergency stop is pressed.
    #[error("the emergency stop is pressed: release it first")]
    EstopPressed,
    /// A monitor speed outside (0, 100].
    #[error("monitor speed {0} is outside 0 < speed <= 100 %")]
    Speed(f64),
}

/// Monitor speeds above 100 % are taken as 100 %; zero, negative and non-finite ones are
/// refused (`None`).
fn clamp_speed(percent: f64) -> Option<f64> {
    (percent.is_finite() && percent > 0.0).then(|| percent.min(100.0))
}
