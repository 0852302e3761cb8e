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
use fs020n_proto::{Command, ErrorCode, JointsDeg, Status, Timer, PROTOCOL_VERSION};
use serde::Serialize;

use crate::fault::{Fault, FaultQueue, ReplyFault};
use crate::motion::{LinearPath, Motion, MotionPhase, Robot, Shape};
use crate::panel::Panel;

/// Timing choices of the emulator (see docs/EMULATOR.md for the reasoning behind each).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Timing {
    /// Motion integration period.
    pub tick: Duration,
    /// Time one pass of the motion program takes besides waiting for motion (interpreting the
    /// loop and printing its terminal line).
    pub pass: Duration,
    /// Gap between two 3-second listen windows, during which connections are refused.
    pub listen_gap: Duration,
    /// Length of one listen window (`TCP_ACCEPT` timeout: 3 s). Only tests that must see a
    /// listen gap over real TCP quickly should shorten it.
    pub accept_window: Duration,
}

/// Controller tick: motion is integrated every 2 ms.
pub const TICK: Duration = Duration::from_millis(2);
/// Duration of one pass of the motion program (without waiting for motion).
pub const PASS_TIME: Duration = Duration::from_millis(10);
/// Gap between listen windows.
pub const LISTEN_GAP: Duration = Duration::from_millis(100);

impl Default for Timing {
    fn default() -> Self {
        Timing {
            tick: TICK,
            pass: PASS_TIME,
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

/// Why a session ended.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum SessionEnd {
    /// The client sent 255.
    EndCommand,
    /// No request for 5 s.
    ReceiveTimeout,
    /// A reply could not be delivered within 2 s.
    SendTimeout,
    /// The client closed or reset the connection.
    Disconnected,
    /// Closed by fault injection.
    Fault,
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

/// State of the motion program (robot task 1).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum TaskState {
    /// Not executing.
    NotRunning,
    /// Running.
    Running,
    /// Paused by HOLD.
    Paused,
}

/// Counters, for observers and tests.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize)]
pub struct Counters {
    /// Connections accepted.
    pub sessions: u64,
    /// Connections refused (gap or session open).
    pub refused: u64,
    /// Requests received.
    pub requests: u64,
    /// Requests with version 1040.
    pub effective_requests: u64,
    /// Sessions ended by the receive timeout.
    pub receive_timeouts: u64,
    /// Passes of the motion program.
    pub passes: u64,
    /// Motions started (including blended ones).
    pub motions: u64,
    /// Errors raised.
    pub errors: u64,
    /// Times command 1 was ignored because a condition was missing.
    pub starts_ignored: u64,
}

/// What one pass of the motion program decided (for observers and tests).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct PassInfo {
    /// Controller time at the start of the pass.
    #[serde(serialize_with = "ser_duration_s")]
    pub at: Duration,
    /// The server clock `tm` the pass used (TIMER(2), seconds since accept, 1 ms resolution).
    pub tm_s: f64,
    /// `step` as the pass used it (before this pass updated it), seconds.
    pub step_s: f64,
    /// The command number the pass read (0 right after accept).
    pub command: f64,
    /// The motion the pass issued, if any.
    pub motion: Option<PassMotion>,
}

/// A motion issued by a pass.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct PassMotion {
    /// The target, degrees (for command 7: the extrapolated point `pt`).
    pub target: JointsDeg,
    /// JMOVE (`joint`) or LMOVE (`linear`).
    pub kind: MoveKind,
    /// For a JMOVE, the effective speed in percent of the joints' maximum speeds; for an
    /// LMOVE, the planned duration in seconds before stretching to respect joint speeds.
    pub speed: f64,
}

/// Interpolation of a motion.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum MoveKind {
    /// Joint-interpolated (JMOVE).
    Joint,
    /// Straight tool line (LMOVE).
    Linear,
}

fn ser_duration_s<S: serde::Serializer>(d: &Duration, s: S) -> Result<S::Ok, S::Error> {
    s.serialize_f64(d.as_secs_f64())
}

#[derive(Debug, Clone)]
struct Session {
    id: SessionId,
    accepted_at: Duration,
    last_rx: Duration,
    /// A delayed or split reply is being sent: the communication task is not receiving, so its
    /// receive timeout does not run.
    replying: bool,
    ring: Vec<Command>,
    newest: usize,
}

#[derive(Debug, Clone)]
struct ProgramRun {
    next_pass_at: Duration,
    /// Start of the pass whose planned motion waits to blend in.
    blocked_since: Option<Duration>,
    step_s: f64,
    prev_pt: Option<JointsDeg>,
}

/// The emulated FS020N controller running the protocol-1040 AS server program.
#[derive(Debug, Clone)]
pub struct Controller {
    model: RobotModel,
    timing: Timing,
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
    session: Option<Session>,
    listen_since: Duration,
    next_session: u64,
    last_session_end: Option<(SessionId, SessionEnd)>,
    stop_reading_until: Option<Duration>,
    faults: FaultQueue,
    counters: Counters,
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
            now: Duration::ZERO,
            tick_time: Duration::ZERO,
            panel,
            error,
            monitor_speed: clamp_speed(config.monitor_speed_percent).unwrap_or(10.0),
            abs_speed: false,
            program: None,
            session: None,
            listen_since: Duration::ZERO,
            next_session: 1,
            last_session_end: None,
            stop_reading_until: None,
            faults: FaultQueue::default(),
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
        match &self.program {
            None => TaskState::NotRunning,
            Some(_) if !self.panel.run => TaskState::Paused,
            Some(_) => TaskState::Running,
        }
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
        self.session.as_ref().map_or(0.0, |s| {
            as_seconds_ms(self.now.saturating_sub(s.accepted_at))
        })
    }

    /// The newest command of the ring (command 0 right after accept).
    pub fn newest_command(&self) -> Option<&Command> {
        self.session.as_ref().map(|s| &s.ring[s.newest])
    }

    /// The ring index of the newest command.
    pub fn newest_index(&self) -> Option<usize> {
        self.session.as_ref().map(|s| s.newest)
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
    pub fn snapshot(&self) -> crate::snapshot::Snapshot {
        crate::snapshot::Snapshot::of(self)
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
            timer: Timer::Seconds(self.timer1_s()),
            joints: self.robot.joints(),
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
        if self.panel.run {
            // A planned motion blends in once the tool is within ACCURACY of the target.
            if let Some(run) = &self.program {
                if let Some(since) = run.blocked_since {
                    if let Some(m) = self
                        .robot
                        .take_planned_if_ready(&self.model, self.model.controller.accuracy_mm)
                    {
                        self.robot.start(m);
                        self.counters.motions += 1;
                        self.finish_pass(since, t);
                    }
                }
            }
            let due = self
                .program
                .as_ref()
                .is_some_and(|r| r.blocked_since.is_none() && t >= r.next_pass_at);
            if due {
                self.program_pass(t);
            }
        }
        self.robot.tick(&self.model, self.timing.tick.as_secs_f64());
    }

    fn finish_pass(&mut self, started: Duration, t: Duration) {
        let pass = self.timing.pass;
        if let Some(run) = &mut self.program {
            let duration = (t + pass - started).as_secs_f64();
            run.step_s = (1.0 - STEP_AVERAGE_WEIGHT) * run.step_s + STEP_AVERAGE_WEIGHT * duration;
            run.blocked_since = None;
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

    /// One pass of `ros_move`: read the newest request, execute 6 or 7.
    fn program_pass(&mut self, t: Duration) {
        self.counters.passes += 1;
        let newest = self.newest_command().cloned();
        let tm = self
            .session
            .as_ref()
            .map_or(0.0, |s| as_seconds_ms(t.saturating_sub(s.accepted_at)));
        let step = self.step_s();
        let from = self.robot.target();
        let motion = match newest {
            Some(Command::JointMove { target }) => {
                Some((target, Kind::Joint(self.speed_fraction(100.0))))
            }
            Some(Command::StreamedMove(sample)) => {
                let pt = sample.extrapolate(tm, step);
                let changed = self.program.as_ref().is_some_and(|r| r.prev_pt != Some(pt));
                if let Some(run) = &mut self.program {
                    run.prev_pt = Some(pt);
                }
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
            command: newest.as_ref().map_or(0.0, Command::number),
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
            self.finish_pass(t, t);
            return;
        };
        if !target.is_finite() || !self.model.within_limits(&target) {
            tracing::warn!(%target, "E1088: destination is out of motion range");
            self.raise(ErrorCode::DESTINATION_OUT_OF_RANGE);
            return;
        }
        let shape = match kind {
            Kind::Joint(f) => Shape::Joint(JointMove::plan(&self.model, from, target, f)),
            Kind::Linear(d) => {
                match LinearPath::plan(&self.model, from, target, d, self.timing.tick.as_secs_f64())
                {
                    Some(p) => Shape::Linear(p),
                    None => {
                        tracing::warn!(%target, "E1088: no straight-line path to the destination");
                        self.raise(ErrorCode::DESTINATION_OUT_OF_RANGE);
                        return;
                    }
                }
            }
        };
        let m = Motion {
            from,
            to: target,
            shape,
        };
        if self
            .robot
            .ready_for_next(&self.model, self.model.controller.accuracy_mm)
        {
            self.robot.start(m);
            self.counters.motions += 1;
            self.finish_pass(t, t);
        } else {
            self.robot.plan(m);
            if let Some(run) = &mut self.program {
                run.blocked_since = Some(t);
            }
        }
    }

    // ----------------------------------------------------------------- program

    fn start_program(&mut self) {
        if !self.start_blockers().is_empty() {
            self.counters.starts_ignored += 1;
            tracing::info!(blockers = ?self.start_blockers(), "command 1 ignored");
            return;
        }
        tracing::info!("motion program ros_move started");
        self.program = Some(ProgramRun {
            next_pass_at: self.tick_time + self.timing.tick,
            blocked_since: None,
            step_s: 0.0,
            // "Remember the current joints": a first 7 whose point is where the robot stands
            // issues no motion.
            prev_pt: Some(self.robot.joints()),
        });
    }

    /// Signal 2007: the robot stops at once and the program ends.
    fn stop_program(&mut self) {
        if self.program.take().is_some() {
            tracing::info!("motion program ros_move ended");
        }
        self.robot.brake(&self.model);
    }

    fn raise(&mut self, code: ErrorCode) {
        self.counters.errors += 1;
        self.error = code;
        self.stop_program();
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
            accepted_at: self.now,
            last_rx: self.now,
            replying: false,
            ring: vec![
                Command::Other {
                    number: 0.0,
                    args: Vec::new()
                };
                COMMAND_RING_LEN
            ],
            newest: 0,
        });
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
            self.stop_program();
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
            let command = req.command();
            let previous_was_cancel = matches!(session.ring[session.newest], Command::CancelMotion);
            let slot = (session.newest + 1) % COMMAND_RING_LEN;
            session.ring[slot] = command.clone();
            match command {
                Command::StartProgram => self.start_program(),
                Command::StopProgram => self.stop_program(),
                Command::SetSpeed { percent } => {
                    if let Some(p) = clamp_speed(percent) {
                        self.monitor_speed = p;
                    }
                    self.abs_speed = true;
                }
                // BRAKE, unless the previous accepted command was also 5.
                Command::CancelMotion if previous_was_cancel => {}
                Command::CancelMotion => {
                    self.robot.brake(&self.model);
                    if let Some(run) = &self.program {
                        if let Some(since) = run.blocked_since {
                            let t = self.tick_time;
                            self.finish_pass(since, t);
                        }
                    }
                }
                Command::EndSession => close = true,
                _ => {}
            }
            if let Some(s) = &mut self.session {
                s.newest = slot;
            }
        }
        let reply = self.status().encode();
        tracing::debug!(reply = %reply, "reply");
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
            reply: reply.into_bytes(),
            fault,
            close,
        })
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
            if self.program.take().is_some() {
                tracing::info!("motor power off: motion program ended");
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
            self.stop_program();
        }
    }

    /// TEACH LOCK on or off. On gives the pendant control: a running program stops (the
    /// program cannot run with the lock on, spec §4) and command 1 is refused.
    pub fn set_teach_lock(&mut self, on: bool) {
        self.panel.teach_lock = on;
        if on {
            self.stop_program();
        }
    }

    /// Presses the emergency stop: motor power is cut, the robot stops dead, the program ends
    /// and E3808 is raised.
    pub fn press_estop(&mut self) {
        self.panel.estop = true;
        self.panel.power = false;
        self.robot.halt();
        self.program = None;
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
            Fault::CloseConnection => self.end_session(SessionEnd::Fault),
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
