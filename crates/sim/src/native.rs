//! The native protocol-1040 server: the AS server program's two tasks, rule for rule, as Rust
//! (docs/EMULATOR.md). The communication task (listen windows, one session, the command ring,
//! the 5 s receive timeout, `SIGNAL 2007` on its exit) and the motion program `ros_move` (its
//! passes, `step`, look-ahead, `ONI 2007`), running on a [`Machine`].

use std::time::Duration;

use fs020n_kin::JointMove;
use fs020n_proto::{
    Command, ErrorCode, JointsDeg, Status, StreamSample, JOINT_COUNT, PROTOCOL_VERSION,
};
use fs020n_proto::{ReplyEncoder, ServerRequest};
use fs020n_proto::{
    COMMAND_RING_LEN, RECEIVE_TIMEOUT, SINGULAR_JMOVE_SPEED_PERCENT, SINGULAR_ZONE_DEG,
    STEP_AVERAGE_WEIGHT, STREAM_LMOVE_TIME_S,
};
use serde::Serialize;

use crate::fault::ReplyFault;
use crate::machine::{Machine, OnTick, PlannedAfterBrake, ServerPicture};
use crate::motion::{LinearPath, Motion, Shape};
use crate::snapshot::{
    CommandInfo, LastEnd, MotionTaskState, MoveKind, PassInfo, PassMotion, Refused, SessionEnd,
    SessionInfo, Snapshot,
};

/// Identifies one session (one accepted connection).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize)]
pub struct SessionId(pub u64);

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

#[derive(Debug, Clone, Copy)]
enum Kind {
    Joint(f64),
    Linear(f64),
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

/// The native server program: its communication task and its motion program.
#[derive(Debug, Clone)]
pub(crate) struct NativeServer {
    program: Option<ProgramRun>,
    /// The local argument array of the last execution (kept only with
    /// [`crate::Behaviour::locals_survive_restart`]).
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
    /// What the timers read at the accept ([`crate::Timing::session_timer_start`]).
    timer_start: Duration,
    listen_since: Duration,
    next_session: u64,
    last_session_end: Option<(SessionId, SessionEnd)>,
    last_pass: Option<PassInfo>,
    /// Formats replies, the joint fields once while the arm stands still.
    reply_encoder: ReplyEncoder,
}

/// Below this many seconds a 32-bit AS real holds every millisecond of a timer.
const AS_REAL_HOLDS_MS_UNTIL_S: f64 = 8_192.0;

fn as_seconds_ms(d: Duration) -> f64 {
    // TIMER has a 1 ms resolution.
    (d.as_millis() as f64) / 1000.0
}

impl NativeServer {
    /// The server at time zero, listening.
    pub(crate) fn new() -> NativeServer {
        NativeServer {
            program: None,
            kept_args: Vec::new(),
            signal_2007_since: None,
            session: None,
            ring: vec![RingRow::default(); COMMAND_RING_LEN],
            newest: 0,
            timer_epoch: Duration::ZERO,
            timer_start: Duration::ZERO,
            listen_since: Duration::ZERO,
            next_session: 1,
            last_session_end: None,
            last_pass: None,
            reply_encoder: ReplyEncoder::default(),
        }
    }

    // ----------------------------------------------------------------- observers

    /// State of the motion program.
    pub(crate) fn task(&self, m: &Machine) -> MotionTaskState {
        match &self.program {
            None => MotionTaskState::NotRunning,
            Some(run) if run.finishing => MotionTaskState::Finishing,
            Some(_) if !m.panel().run => MotionTaskState::Paused,
            Some(_) => MotionTaskState::Running,
        }
    }

    /// `true` while signal 2007 (stop the motion program) is on.
    pub(crate) fn stop_signal(&self) -> bool {
        self.signal_2007_since.is_some()
    }

    /// The program's average pass duration `step`, seconds (0 when not running).
    pub(crate) fn step_s(&self) -> f64 {
        self.program.as_ref().map_or(0.0, |p| p.step_s)
    }

    /// `true` while the motion program executes (TASK(1) = 1, 2 or 3).
    pub(crate) fn program_executes(&self) -> bool {
        self.program.is_some()
    }

    pub(crate) fn session(&self) -> Option<SessionId> {
        self.session.as_ref().map(|s| s.id)
    }

    pub(crate) fn last_session_end(&self) -> Option<(SessionId, SessionEnd)> {
        self.last_session_end
    }

    pub(crate) fn last_pass(&self) -> Option<PassInfo> {
        self.last_pass
    }

    /// TIMER(1): seconds since the session was accepted (1 ms resolution), 0 without a session.
    pub(crate) fn timer1_s(&self, m: &Machine) -> f64 {
        if self.session.is_some() {
            self.timer_s(m.now())
        } else {
            0.0
        }
    }

    /// TIMER(1)/TIMER(2) at controller time `t`: seconds since the latest accept (plus the
    /// configured start), 1 ms resolution (they keep counting after the session ends). From
    /// 2¹³ s on, the value is rounded to a 32-bit AS real as the controller holds it, whose step
    /// is then a millisecond or more; below, every millisecond is kept exactly (a 32-bit real
    /// holds it to better than 0.25 ms, which neither the wire nor the motion program sees).
    fn timer_s(&self, t: Duration) -> f64 {
        let s = as_seconds_ms(self.timer_start + t.saturating_sub(self.timer_epoch));
        if s >= AS_REAL_HOLDS_MS_UNTIL_S {
            f64::from(s as f32)
        } else {
            s
        }
    }

    /// The newest command of the ring as the motion program reads it, while a session is open.
    pub(crate) fn newest_command(&self) -> Option<Command> {
        self.session
            .as_ref()
            .map(|_| self.ring[self.newest].command())
    }

    /// The ring index of the newest command, while a session is open.
    pub(crate) fn newest_index(&self) -> Option<usize> {
        self.session.as_ref().map(|_| self.newest)
    }

    /// When the open session times out for lack of requests (`None` while a delayed reply is
    /// being sent).
    pub(crate) fn receive_deadline(&self) -> Option<Duration> {
        self.session
            .as_ref()
            .filter(|s| !s.replying)
            .map(|s| s.last_rx + RECEIVE_TIMEOUT)
    }

    /// The status reply as it would be sent now.
    pub(crate) fn status(&self, m: &Machine) -> Status {
        m.status(self.task(m) == MotionTaskState::Running, self.timer1_s(m))
    }

    /// `true` while connections are accepted now.
    pub(crate) fn is_listening(&self, m: &Machine) -> bool {
        self.session.is_none() && self.listen_phase(m) < m.timing().accept_window
    }

    fn listen_phase(&self, m: &Machine) -> Duration {
        let cycle = m.timing().accept_window + m.timing().listen_gap;
        let since = m.now().saturating_sub(self.listen_since);
        Duration::from_nanos((since.as_nanos() % cycle.as_nanos()) as u64)
    }

    /// When the listening state changes next (window opens or closes); `None` during a session.
    pub(crate) fn next_listen_change(&self, m: &Machine) -> Option<Duration> {
        if self.session.is_some() {
            return None;
        }
        let phase = self.listen_phase(m);
        let window = m.timing().accept_window;
        let rest = if phase < window {
            window - phase
        } else {
            window + m.timing().listen_gap - phase
        };
        Some(m.now() + rest)
    }

    /// A serializable picture of the machine and this server now.
    pub(crate) fn snapshot(&self, m: &Machine) -> Snapshot {
        let session_open = self.session().is_some();
        m.snapshot(ServerPicture {
            task: self.task(m),
            abs_speed: m.abs_speed(),
            step_s: self.step_s(),
            last_pass: self.last_pass,
            program_executes: self.program_executes(),
            session: SessionInfo {
                open: session_open,
                id: self.session().map(|s| s.0),
                timer1_s: session_open.then(|| self.timer1_s(m)),
                newest_command: self.newest_command().map(|cmd| CommandInfo {
                    number: cmd.number(),
                    command: cmd,
                }),
                newest_index: self.newest_index(),
                listening: self.is_listening(m),
                reading_paused: m.reading_paused_until().is_some(),
                last_end: self
                    .last_session_end
                    .map(|(id, reason)| LastEnd { id: id.0, reason }),
            },
            program: None,
        })
    }

    // ----------------------------------------------------------------- program

    /// Command 1, exactly as the server tests it: the switches (power, RUN, REPEAT, lock off),
    /// then `TASK(1) <> 1 AND ERROR == 0`; then `ros_move_run = 1` and `MC EXECUTE ros_move`,
    /// which the controller refuses (P1009) while the program still executes (TASK 2 or 3).
    fn start_program(&mut self, m: &mut Machine) {
        let panel = m.panel();
        let switches = panel.power && panel.run && panel.repeat && !panel.teach_lock;
        if !switches || self.task(m) == MotionTaskState::Running || !m.error().is_none() {
            m.counters_mut().starts_ignored += 1;
            let blockers = m.start_blockers(self.program_executes());
            tracing::info!(?blockers, "command 1 ignored");
            return;
        }
        if let Some(run) = &mut self.program {
            run.run_flag = true;
            m.counters_mut().starts_refused += 1;
            tracing::info!("command 1: MC EXECUTE refused, the program still executes (P1009)");
            return;
        }
        tracing::info!("motion program ros_move started");
        // `SIGNAL -2007`, then `ONI 2007 GOTO exit`.
        self.signal_2007_since = None;
        let args = if m.behaviour().locals_survive_restart {
            std::mem::take(&mut self.kept_args)
        } else {
            Vec::new()
        };
        self.program = Some(ProgramRun {
            next_pass_at: m.tick_time() + m.timing().tick,
            blocked: None,
            step_s: 0.0,
            last_tm_s: self.timer_s(m.now()),
            // "Remember the current joints": a first 7 whose point is where the robot stands
            // issues no motion.
            prev_pt: Some(m.arm().joints().0.map(|v| v as f32)),
            args,
            run_flag: true,
            finishing: false,
            interrupted: false,
        });
    }

    /// `SIGNAL 2007`: the program's `ONI` stops it once the signal has been stable for
    /// [`crate::Timing::signal_edge`].
    fn raise_stop_signal(&mut self, m: &Machine) {
        if self.signal_2007_since.is_none() {
            self.signal_2007_since = Some(m.now());
        }
    }

    /// `ONI 2007 GOTO stopped` fired: the motion stops at once (a planned one is dropped) and
    /// the program runs to its end. The brake is still its motion, so the task is finishing
    /// (TASK(1) = 3) until the arm stands: a command 1 meanwhile passes the server's own test
    /// and reaches `MC EXECUTE`, which refuses it (P1009) — as the AS text behaves.
    fn interrupt_program(&mut self, m: &mut Machine) {
        m.brake();
        if let Some(run) = &mut self.program {
            run.interrupted = true;
            run.finishing = true;
            run.blocked = None;
        }
    }

    /// The program ends (the controller stopped it: TEACH, the teach lock, an error, the
    /// emergency stop, motor power off).
    pub(crate) fn end_program(&mut self) {
        if let Some(run) = self.program.take() {
            tracing::info!("motion program ros_move ended");
            self.kept_args = run.args;
        }
    }

    /// Raises `code`: the program ends and the arm brakes.
    pub(crate) fn raise(&mut self, m: &mut Machine, code: ErrorCode) {
        self.end_program();
        m.raise(code);
    }

    // ----------------------------------------------------------------- communication task

    /// A client connects. Accepted only during a listen window and when no session is open.
    /// On accept the command ring and TIMER(1) are reset.
    pub(crate) fn try_accept(&mut self, m: &mut Machine) -> Result<SessionId, Refused> {
        if self.session.is_some() {
            m.counters_mut().refused += 1;
            tracing::info!("{}", Refused::SessionOpen);
            return Err(Refused::SessionOpen);
        }
        if !self.is_listening(m) {
            m.counters_mut().refused += 1;
            tracing::info!("{}", Refused::ListenGap);
            return Err(Refused::ListenGap);
        }
        let id = SessionId(self.next_session);
        self.next_session += 1;
        m.counters_mut().sessions += 1;
        m.resume_reading();
        self.session = Some(Session {
            id,
            last_rx: m.now(),
            replying: false,
        });
        // `ros_cmd_ind = 0` and row 0's command := 0; the ring itself is never cleared.
        self.newest = 0;
        self.ring[0].number = 0.0;
        // TIMER(1) = 0, TIMER(2) = 0.
        self.timer_epoch = m.now();
        self.timer_start = m.timing().session_timer_start;
        tracing::info!(session = id.0, "session accepted");
        Ok(id)
    }

    /// Ends the session (connection lost, send timeout, fault): the communication task's exit.
    pub(crate) fn end_session(&mut self, m: &mut Machine, why: SessionEnd) {
        if let Some(s) = self.session.take() {
            tracing::info!(session = s.id.0, reason = ?why, "session ended");
            self.last_session_end = Some((s.id, why));
            // The communication task's exit: `SIGNAL 2007` (the program's ONI stops it after
            // the signal edge), close the socket, listen again.
            self.raise_stop_signal(m);
            self.listen_since = m.now();
            m.clear_faults();
        }
    }

    /// The communication task receives `bytes` (one receive call = one request) on session
    /// `id`, acts on it and builds the reply with the joints of this instant.
    pub(crate) fn handle_request(
        &mut self,
        m: &mut Machine,
        id: SessionId,
        bytes: &[u8],
    ) -> Result<Handled, SessionGone> {
        let now = m.now();
        let session = match &mut self.session {
            Some(s) if s.id == id => s,
            _ => return Err(SessionGone),
        };
        session.last_rx = now;
        m.counters_mut().requests += 1;
        let req = ServerRequest::parse(bytes);
        let mut close = false;
        tracing::debug!(request = %String::from_utf8_lossy(bytes), "request");
        if req.version_matches() {
            m.counters_mut().effective_requests += 1;
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
                Command::StartProgram => self.start_program(m),
                Command::StopProgram => {
                    // `SIGNAL 2007` (the ONI fires after the edge) and `ros_move_run = 0`.
                    self.raise_stop_signal(m);
                    if let Some(run) = &mut self.program {
                        run.run_flag = false;
                    }
                }
                Command::SetSpeed { percent } => m.command_speed(percent),
                // Published as newest first, then BRAKE — unless the newest was already a 5.
                Command::CancelMotion if previous_was_cancel => {}
                Command::CancelMotion => {
                    self.newest = slot;
                    self.brake_for_cancel(m);
                }
                Command::EndSession => close = true,
                _ => {}
            }
            self.newest = slot;
        }
        let reply = self.reply_encoder.encode(&self.status(m));
        tracing::debug!(reply = %String::from_utf8_lossy(&reply), "reply");
        let fault = m.next_reply_fault();
        if let Some(s) = &mut self.session {
            // A delayed or split reply takes time to send; the receive timeout waits for it
            // (see `reply_sent`).
            s.replying = matches!(fault, Some(ReplyFault::Delay(_) | ReplyFault::Split { .. }));
        }
        if close {
            self.end_session(m, SessionEnd::EndCommand);
        }
        Ok(Handled {
            reply,
            fault,
            close,
        })
    }

    /// The reply of session `id` has been sent: the communication task receives again and its
    /// 5 s receive timeout starts now.
    pub(crate) fn reply_sent(&mut self, m: &Machine, id: SessionId) {
        let now = m.now();
        if let Some(s) = self.session.as_mut().filter(|s| s.id == id) {
            s.replying = false;
            s.last_rx = now;
        }
    }

    /// Command 5's `BRAKE`: the current motion stops at once and the motion program goes on
    /// to the next step. A motion the program had planned by look-ahead is then executed from
    /// where the brake stops the arm, or dropped ([`crate::Behaviour::planned_after_brake`]).
    fn brake_for_cancel(&mut self, m: &mut Machine) {
        m.brake();
        let Some(blocked) = self.program.as_ref().and_then(|r| r.blocked) else {
            return;
        };
        match m.behaviour().planned_after_brake {
            PlannedAfterBrake::Drop => {
                let t = m.tick_time();
                self.finish_pass(blocked.tm_s, t, m.timing().pass);
            }
            PlannedAfterBrake::Execute => {
                let from = m.arm().target();
                if let Some(motion) = self.plan_motion(m, from, blocked.target, blocked.kind) {
                    // Starts when the brake has stopped the arm; the pass stays blocked.
                    m.plan_motion(motion);
                }
            }
        }
    }

    fn check_receive_timeout(&mut self, m: &mut Machine) {
        if let Some(deadline) = self.receive_deadline() {
            if m.now() >= deadline {
                m.counters_mut().receive_timeouts += 1;
                tracing::info!("receive timeout: no request for 5 s, ending the session");
                self.end_session(m, SessionEnd::ReceiveTimeout);
            }
        }
    }

    // ----------------------------------------------------------------- the motion program

    /// The end of a pass whose motion instruction was accepted at `t` (or that issued none):
    /// `step = 0.9 step + 0.1 (tm − last_tm)`, `last_tm := TIMER(2)`, and the next pass starts
    /// after the loop overhead. `tm − last_tm` is the time from the previous pass's end to this
    /// pass's start — the overhead only, never the motion wait (spec §2.4).
    fn finish_pass(&mut self, tm_s: f64, t: Duration, pass: Duration) {
        let timer_now = self.timer_s(t);
        if let Some(run) = &mut self.program {
            run.step_s = (1.0 - STEP_AVERAGE_WEIGHT) * run.step_s
                + STEP_AVERAGE_WEIGHT * (tm_s - run.last_tm_s);
            run.last_tm_s = timer_now;
            run.blocked = None;
            run.next_pass_at = t + pass;
        }
    }

    fn speed_fraction(m: &Machine, program_percent: f64) -> f64 {
        let eff = if m.abs_speed() {
            program_percent.min(m.monitor_speed())
        } else {
            program_percent * m.monitor_speed() / 100.0
        };
        eff / 100.0
    }

    /// One pass of `ros_move`: check the running flag, read the newest request (copying its
    /// COUNT arguments into the local array), execute 6 or 7.
    fn program_pass(&mut self, m: &mut Machine, t: Duration) {
        let tm = self.timer_s(t);
        let Some(run) = &mut self.program else {
            return;
        };
        if !run.run_flag {
            // `WHILE ros_move_run == 1` fails: the steps are done, the last motion finishes.
            run.finishing = true;
            return;
        }
        m.counters_mut().passes += 1;
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
            m.counters_mut().undefined_arguments += 1;
            self.raise(m, ErrorCode::VARIABLE_NOT_DEFINED);
            return;
        }
        let joints_at = |first: usize| {
            let mut j = [0.0; JOINT_COUNT];
            j.copy_from_slice(&args[first..first + JOINT_COUNT]);
            JointsDeg(j)
        };
        let motion = match number {
            6.0 => Some((joints_at(3), Kind::Joint(Self::speed_fraction(m, 100.0)))),
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
                        Kind::Joint(Self::speed_fraction(m, SINGULAR_JMOVE_SPEED_PERCENT)),
                    ))
                } else {
                    // Time-based speed, scaled by the monitor speed.
                    Some((
                        pt,
                        Kind::Linear(STREAM_LMOVE_TIME_S * 100.0 / m.monitor_speed()),
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
        let pass = m.timing().pass;
        let Some((target, kind)) = motion else {
            self.finish_pass(tm, t, pass);
            return;
        };
        let from = m.arm().target();
        let Some(motion) = self.plan_motion(m, from, target, kind) else {
            return;
        };
        let accuracy_mm = m.model().controller.accuracy_mm;
        if m.ready_for_next(accuracy_mm) {
            m.start_motion(motion);
            self.finish_pass(tm, t, pass);
        } else {
            m.plan_motion(motion);
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
    fn plan_motion(
        &mut self,
        m: &mut Machine,
        from: JointsDeg,
        target: JointsDeg,
        kind: Kind,
    ) -> Option<Motion> {
        let model = m.model();
        if !target.is_finite() || !model.within_limits(&target) {
            tracing::warn!(%target, "E1088: destination is out of motion range");
            self.raise(m, ErrorCode::DESTINATION_OUT_OF_RANGE);
            return None;
        }
        let shape = match kind {
            Kind::Joint(f) => Shape::Joint(JointMove::plan(model, from, target, f)),
            Kind::Linear(d) => {
                let from_pose = if crate::motion::same_bits(&from, &m.arm().target()) {
                    m.arm().target_pose(model)
                } else {
                    model.forward(&from.to_rad())
                };
                match LinearPath::plan_from_pose(model, from, from_pose, target, d) {
                    Some(p) => Shape::Linear(p),
                    None => {
                        tracing::warn!(%target, "E1088: no straight-line path to the destination");
                        self.raise(m, ErrorCode::DESTINATION_OUT_OF_RANGE);
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
}

/// The server's work as the machine's time passes: the receive timeout, `ONI 2007`, the
/// look-ahead blending in and the motion program's passes.
impl OnTick for NativeServer {
    fn is_idle(&self) -> bool {
        self.program.is_none()
    }

    fn deadline(&self) -> Option<Duration> {
        self.receive_deadline()
    }

    fn on_time(&mut self, m: &mut Machine) {
        self.check_receive_timeout(m);
    }

    fn before_motion(&mut self, m: &mut Machine) {
        let t = m.tick_time();
        self.check_receive_timeout(m);
        // `ONI 2007`: once the signal has been stable for the edge time, the motion stops at
        // once and the program ends; the brake is its last motion (TASK(1) = 3 until the arm
        // stands, below).
        if let Some(since) = self.signal_2007_since {
            let armed = self.program.as_ref().is_some_and(|r| !r.interrupted);
            if armed && t >= since + m.timing().signal_edge {
                tracing::info!("signal 2007: motion program ros_move interrupted");
                self.interrupt_program(m);
            }
        }
        if m.panel().run {
            // A planned motion blends in once the tool is within ACCURACY of the target.
            if let Some(blocked) = self.program.as_ref().and_then(|r| r.blocked) {
                let accuracy_mm = m.model().controller.accuracy_mm;
                if let Some(motion) = m.take_planned_if_ready(accuracy_mm) {
                    m.start_motion(motion);
                    self.finish_pass(blocked.tm_s, t, m.timing().pass);
                }
            }
            let due = self
                .program
                .as_ref()
                .is_some_and(|r| r.blocked.is_none() && !r.finishing && t >= r.next_pass_at);
            if due {
                self.program_pass(m, t);
            }
        }
    }

    fn after_motion(&mut self, m: &mut Machine) {
        // TASK(1) = 3 ends when the last motion has: in the tick the arm comes to rest (as
        // the interpreter's finishing task sees it on its poll at this instant).
        if self.program.as_ref().is_some_and(|r| r.finishing) && m.arm().is_still() {
            self.end_program();
        }
    }
}
