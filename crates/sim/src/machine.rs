//! The machine a server program runs on: the clock and its 2 ms tick, the arm and its motion
//! planner, the panel, the error, the monitor speed and ABS.SPEED, the fault queue, the counters
//! and the timing and behaviour choices. It knows nothing of protocol 1040: the native server
//! ([`crate::native`]) and an AS program ([`crate::program`]) both drive it through the same
//! operations, and advance it with [`Machine::integrate_to`], giving their own work at each tick
//! as an [`OnTick`].

use std::time::Duration;

use fs020n_kin::RobotModel;
use fs020n_proto::ACCEPT_WINDOW;
use fs020n_proto::{ErrorCode, JointsDeg, Status, Timer, PROTOCOL_VERSION};
use serde::Serialize;

use crate::fault::{Fault, FaultQueue, ReplyFault};
use crate::motion::{Arm, Motion, MotionPhase};
use crate::panel::Panel;
use crate::snapshot::{Counters, MotionTaskState, PassInfo, ProgramInfo, SessionInfo, Snapshot};

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
    /// What TIMER(1) and TIMER(2) read when a session is accepted (0 on a controller). An
    /// aged start shows what a long session does to them: they are 32-bit AS reals, whose
    /// step grows with their value (1.95 ms after 4.6 h, 7.8 ms after 18.2 h). Native server
    /// only (an AS program sets its timers itself).
    pub session_timer_start: Duration,
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
            session_timer_start: Duration::ZERO,
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
    /// The controller's address and the hosts its programs reach (`crate::Network`).
    pub network: crate::network::Network,
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
            network: crate::network::Network::default(),
            model,
        }
    }
}

impl Default for ControllerConfig {
    fn default() -> Self {
        ControllerConfig::new(RobotModel::fs020n())
    }
}

/// Panel switches to change at once ([`crate::Controller::apply_panel`]); `None` leaves one as
/// it is.
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

/// What a server program does as the machine's time passes ([`Machine::integrate_to`]).
pub(crate) trait OnTick {
    /// `true` while the program has nothing to do at ticks: a still arm's idle stretch is then
    /// skipped in one step (up to [`OnTick::deadline`]).
    fn is_idle(&self) -> bool;
    /// A time the machine must stop at while skipping (a receive timeout).
    fn deadline(&self) -> Option<Duration>;
    /// Time has reached the machine's `now` (after a skip, and at the end of an advance).
    fn on_time(&mut self, m: &mut Machine);
    /// One tick at [`Machine::tick_time`], before motion is integrated over it.
    fn before_motion(&mut self, m: &mut Machine);
    /// The same tick, after motion has been integrated.
    fn after_motion(&mut self, m: &mut Machine);
}

/// The parts of a [`Snapshot`] that the server program knows.
pub(crate) struct ServerPicture {
    pub(crate) task: MotionTaskState,
    pub(crate) abs_speed: bool,
    pub(crate) step_s: f64,
    pub(crate) last_pass: Option<PassInfo>,
    /// The motion program still executes (command 1 would be refused, P1009).
    pub(crate) program_executes: bool,
    pub(crate) session: SessionInfo,
    pub(crate) program: Option<ProgramInfo>,
}

/// The emulated controller's machine (see the module doc).
#[derive(Debug, Clone)]
pub(crate) struct Machine {
    model: RobotModel,
    timing: Timing,
    behaviour: Behaviour,
    /// The controller's address and host map.
    network: crate::network::Network,
    /// Time of the latest event.
    now: Duration,
    /// Time up to which motion has been integrated (a multiple of the tick).
    tick_time: Duration,
    panel: Panel,
    error: ErrorCode,
    monitor_speed: f64,
    /// The ABS.SPEED system switch (command 3 switches it on).
    abs_speed: bool,
    robot: Arm,
    stop_reading_until: Option<Duration>,
    faults: FaultQueue,
    counters: Counters,
    /// The errors raised, oldest first, at most [`ERROR_LOG_LENGTH`]: `ERRLOG`.
    error_log: std::collections::VecDeque<(Duration, ErrorCode)>,
}

/// How many errors the error log keeps (AS-E p.5-69: "the last one hundred errors").
pub(crate) const ERROR_LOG_LENGTH: usize = 100;

impl Machine {
    /// A machine at time zero.
    pub(crate) fn new(config: ControllerConfig) -> Machine {
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
        Machine {
            robot: Arm::new(config.joints),
            model: config.model,
            timing: config.timing,
            behaviour: config.behaviour,
            network: config.network,
            now: Duration::ZERO,
            tick_time: Duration::ZERO,
            panel,
            error,
            monitor_speed: clamp_speed(config.monitor_speed_percent).unwrap_or(10.0),
            abs_speed: false,
            stop_reading_until: None,
            faults: FaultQueue::default(),
            counters: Counters::default(),
            error_log: std::collections::VecDeque::new(),
        }
    }

    // ----------------------------------------------------------------- observers

    /// The errors raised, oldest first (the last [`ERROR_LOG_LENGTH`]), with when.
    pub(crate) fn error_log(&self) -> impl Iterator<Item = &(Duration, ErrorCode)> {
        self.error_log.iter()
    }

    fn log_error(&mut self, code: ErrorCode) {
        if self.error_log.len() == ERROR_LOG_LENGTH {
            self.error_log.pop_front();
        }
        self.error_log.push_back((self.now, code));
    }

    pub(crate) fn now(&self) -> Duration {
        self.now
    }

    /// The controller's address and host map.
    pub(crate) fn network(&self) -> &crate::network::Network {
        &self.network
    }

    /// Replaces the controller's address and host map (from the next connection on).
    pub(crate) fn set_network(&mut self, network: crate::network::Network) {
        self.network = network;
    }

    /// Time up to which motion has been integrated (a multiple of the tick).
    pub(crate) fn tick_time(&self) -> Duration {
        self.tick_time
    }

    pub(crate) fn model(&self) -> &RobotModel {
        &self.model
    }

    pub(crate) fn timing(&self) -> Timing {
        self.timing
    }

    pub(crate) fn behaviour(&self) -> Behaviour {
        self.behaviour
    }

    pub(crate) fn panel(&self) -> Panel {
        self.panel
    }

    pub(crate) fn error(&self) -> ErrorCode {
        self.error
    }

    pub(crate) fn monitor_speed(&self) -> f64 {
        self.monitor_speed
    }

    /// The ABS.SPEED system switch.
    pub(crate) fn abs_speed(&self) -> bool {
        self.abs_speed
    }

    pub(crate) fn arm(&self) -> &Arm {
        &self.robot
    }

    pub(crate) fn counters(&self) -> Counters {
        self.counters
    }

    /// Counters, to count a server's sessions, requests, passes and motions.
    pub(crate) fn counters_mut(&mut self) -> &mut Counters {
        &mut self.counters
    }

    /// Until when the communication task does not read (fault injection).
    pub(crate) fn reading_paused_until(&self) -> Option<Duration> {
        self.stop_reading_until.filter(|&t| t > self.now)
    }

    /// Reply faults waiting.
    pub(crate) fn pending_faults(&self) -> usize {
        self.faults.pending()
    }

    /// The fault for the next reply, if any.
    pub(crate) fn next_reply_fault(&mut self) -> Option<ReplyFault> {
        self.faults.next_reply()
    }

    /// The status reply as a server would send it now, with the server's `TASK(1) == 1` and
    /// `TIMER(1)`.
    pub(crate) fn status(&self, task_running: bool, timer1_s: f64) -> Status {
        Status {
            version: PROTOCOL_VERSION,
            error: self.error,
            run: self.panel.run,
            repeat: self.panel.repeat,
            teach_lock: self.panel.teach_lock,
            power: self.panel.power,
            task_running,
            // The server builds the reply from AS reals (32-bit): `TIMER(1)` and the joints
            // `DECOMPOSE`d from `#HERE` pass through them before `$ENCODE` prints them.
            timer: Timer::Seconds(f64::from(timer1_s as f32)),
            joints: self.robot.joints().map(|v| f64::from(v as f32)),
        }
    }

    /// Conditions of command 1 that are not met, as the controller would report them
    /// (P1000 power off, P1001 TEACH, P1002 lock on, P1013 in error, P1009 already running;
    /// HOLD has no code of its own).
    pub(crate) fn start_blockers(&self, program_executes: bool) -> Vec<&'static str> {
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
        if program_executes {
            v.push("the program is already running (P1009)");
        }
        v
    }

    /// A serializable picture of the machine and its server now.
    pub(crate) fn snapshot(&self, server: ServerPicture) -> Snapshot {
        let model = &self.model;
        let joints = self.robot.joints();
        let x = model.forward(&joints.to_rad()).to_xyzoat();
        Snapshot {
            time_s: self.now.as_secs_f64(),
            model: model.name().to_owned(),
            panel: self.panel,
            error: self.error.into(),
            joints_deg: joints,
            velocities_deg_s: self.robot.velocity(),
            tool: x,
            task: server.task,
            motion: self.motion_phase(),
            motion_planned: self.robot.has_planned(),
            motion_target_deg: self.robot.target(),
            monitor_speed_percent: self.monitor_speed,
            abs_speed: server.abs_speed,
            step_s: server.step_s,
            last_pass: server.last_pass,
            start_blockers: self
                .start_blockers(server.program_executes)
                .into_iter()
                .map(str::to_owned)
                .collect(),
            session: server.session,
            pending_faults: self.pending_faults(),
            counters: self.counters,
            program: server.program,
        }
    }

    pub(crate) fn motion_phase(&self) -> MotionPhase {
        self.robot.phase()
    }

    // ----------------------------------------------------------------- the arm

    /// Starts a motion now.
    pub(crate) fn start_motion(&mut self, m: Motion) {
        self.robot.start(m);
        self.counters.motions += 1;
    }

    /// Plans a motion to blend in (look-ahead).
    pub(crate) fn plan_motion(&mut self, m: Motion) {
        self.robot.plan(m);
    }

    /// `true` when a new motion may start now (the tool within `accuracy_mm` of the target).
    pub(crate) fn ready_for_next(&mut self, accuracy_mm: f64) -> bool {
        self.robot.ready_for_next(&self.model, accuracy_mm)
    }

    /// The planned motion, once the tool is within `accuracy_mm` of the current target.
    pub(crate) fn take_planned_if_ready(&mut self, accuracy_mm: f64) -> Option<Motion> {
        self.robot.take_planned_if_ready(&self.model, accuracy_mm)
    }

    /// BRAKE: stops the motion at once and drops the planned one.
    pub(crate) fn brake(&mut self) {
        self.robot.brake(&self.model);
    }

    /// Pauses (HOLD) or resumes the motion.
    pub(crate) fn set_hold(&mut self, held: bool) {
        self.robot.set_hold(held);
    }

    // ----------------------------------------------------------------- error

    /// Raises `code`: the arm brakes (the server ends its program).
    pub(crate) fn raise(&mut self, code: ErrorCode) {
        self.counters.errors += 1;
        self.error = code;
        self.log_error(code);
        self.robot.brake(&self.model);
    }

    /// Resets the error (ERESET). Refused while the emergency stop is pressed.
    pub(crate) fn reset_error(&mut self) -> Result<(), PanelError> {
        if self.panel.estop {
            return Err(PanelError::EstopPressed);
        }
        self.error = ErrorCode::NONE;
        Ok(())
    }

    // ----------------------------------------------------------------- panel

    /// Motor power: off stops the arm dead. On is refused while the emergency stop is pressed.
    pub(crate) fn set_power(&mut self, on: bool) -> Result<(), PanelError> {
        if on && self.panel.estop {
            return Err(PanelError::EstopPressed);
        }
        self.panel.power = on;
        if !on {
            self.robot.halt();
        }
        Ok(())
    }

    /// RUN (true) or HOLD (false): HOLD decelerates the motion to a pause.
    pub(crate) fn set_run(&mut self, run: bool) {
        self.panel.run = run;
        self.robot.set_hold(!run);
    }

    /// REPEAT (true) or TEACH (false): TEACH brakes the arm.
    pub(crate) fn set_repeat(&mut self, repeat: bool) {
        self.panel.repeat = repeat;
        if !repeat {
            self.robot.brake(&self.model);
        }
    }

    /// TEACH LOCK: on brakes the arm.
    pub(crate) fn set_teach_lock(&mut self, on: bool) {
        self.panel.teach_lock = on;
        if on {
            self.robot.brake(&self.model);
        }
    }

    /// The emergency stop: motor power is cut, the arm stops dead, E3808 is raised.
    pub(crate) fn press_estop(&mut self) {
        self.panel.estop = true;
        self.panel.power = false;
        self.robot.halt();
        self.error = ErrorCode::EMERGENCY_STOP;
        self.counters.errors += 1;
        self.log_error(ErrorCode::EMERGENCY_STOP);
        tracing::warn!("emergency stop pressed");
    }

    pub(crate) fn release_estop(&mut self) {
        self.panel.estop = false;
    }

    pub(crate) fn set_abs_speed(&mut self, on: bool) {
        self.abs_speed = on;
    }

    /// The pendant's monitor speed (1–100 %).
    pub(crate) fn set_monitor_speed(&mut self, percent: f64) -> Result<(), PanelError> {
        if percent > 100.0 {
            return Err(PanelError::Speed(percent));
        }
        self.monitor_speed = clamp_speed(percent).ok_or(PanelError::Speed(percent))?;
        Ok(())
    }

    /// Command 3: the monitor speed (above 100 % taken as 100 %, not positive ignored), and
    /// ABS.SPEED on.
    pub(crate) fn command_speed(&mut self, percent: f64) {
        if let Some(p) = clamp_speed(percent) {
            self.monitor_speed = p;
        }
        self.abs_speed = true;
    }

    // ----------------------------------------------------------------- faults

    /// Drops the reply faults that wait (and a reading pause).
    pub(crate) fn clear_faults(&mut self) {
        self.faults.clear();
        self.stop_reading_until = None;
    }

    /// Ends a reading pause.
    pub(crate) fn resume_reading(&mut self) {
        self.stop_reading_until = None;
    }

    /// Keeps a fault of the communication: a reading pause or a reply fault (closing the
    /// connection and raising an error are the server's and the controller's).
    pub(crate) fn inject(&mut self, fault: &Fault) {
        match fault {
            Fault::StopReading { duration_ms } => {
                let ms = (*duration_ms).min(crate::fault::MAX_FAULT_MS);
                self.stop_reading_until = Some(self.now + Duration::from_millis(ms));
            }
            _ => self.faults.push(fault),
        }
    }

    // ----------------------------------------------------------------- time

    /// Integrates motion up to `t` (no-op if `t` is not later than now), tick by tick, with
    /// the server's work at each tick; idle stretches are skipped in one step.
    pub(crate) fn integrate_to(&mut self, t: Duration, server: &mut impl OnTick) {
        if t <= self.now {
            return;
        }
        let tick = self.timing.tick;
        while self.tick_time + tick <= t {
            if server.is_idle() && self.robot.is_still() {
                let limit = match server.deadline() {
                    Some(d) if d <= t => d.max(self.tick_time + tick),
                    _ => t,
                };
                // u64 nanoseconds (584 years): a 128-bit division per idle skip was measurable
                // on a polled fleet.
                let span_ns =
                    u64::try_from((limit - self.tick_time).as_nanos()).unwrap_or(u64::MAX);
                let tick_ns = u64::try_from(tick.as_nanos()).unwrap_or(u64::MAX).max(1);
                let n = u32::try_from((span_ns / tick_ns).max(1)).unwrap_or(u32::MAX);
                self.tick_time += tick * n;
                self.now = self.now.max(self.tick_time);
                server.on_time(self);
                continue;
            }
            self.tick_time += tick;
            self.now = self.now.max(self.tick_time);
            server.before_motion(self);
            self.robot.tick(&self.model, self.timing.tick.as_secs_f64());
            server.after_motion(self);
        }
        self.now = t;
        server.on_time(self);
    }
}
