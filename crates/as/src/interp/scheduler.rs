//! The scheduler: which task runs next, waits, polls, interrupts, errors.

use std::sync::Arc;
use std::time::Duration;

use crate::compile::{Code, Op};
use crate::error::RuntimeError;
use crate::sockets::TcpCode;
use crate::system::{SockPoll, System, TaskId};

use super::arith::{ns, truthy, Ns, NOT_PURE, R};
use super::report::TerminalLine;
use super::task::{Flow, Interrupt, Run, Task, TaskSlot, Wait};
use super::Interpreter;
use super::MAX_TRANSFER;

impl Interpreter {
    pub(super) fn next_tick(&self, after: Ns) -> Ns {
        let p = self.poll_ns.max(1);
        (after / p + 1).saturating_mul(p)
    }

    pub(super) fn task_wake(&self, i: TaskSlot) -> Option<Ns> {
        self.wake_time(i, &self.tasks[i])
    }

    /// [`Self::task_wake`] of task `i`, given.
    #[inline]
    pub(super) fn wake_time(&self, i: TaskSlot, t: &Task) -> Option<Ns> {
        if t.run == Run::Ending {
            return Some(t.poll_at);
        }
        if t.run != Run::Running {
            return None;
        }
        let Some(w) = &t.wait else {
            return Some(t.ready_at.max(self.now));
        };
        if t.kick && w.socket() {
            return Some(self.now);
        }
        let own = match w {
            Wait::Until(d) => Some((*d).max(t.ready_at)),
            Wait::Accept { deadline, .. }
            | Wait::Connect { deadline, .. }
            | Wait::Recv { deadline, .. }
            | Wait::Send { deadline, .. }
            | Wait::UdpRecv { deadline, .. } => Some((*deadline).max(t.ready_at)),
            _ => None,
        };
        // The robot task also watches the panel and the error while it waits.
        let poll = (i.is_robot() || w.polled()).then_some(t.poll_at);
        match (own, poll) {
            (Some(a), Some(b)) => Some(a.min(b)),
            (a, b) => a.or(b),
        }
    }

    /// Stores a wait of task `i` and schedules its next poll.
    pub(super) fn set_wait(&mut self, i: TaskSlot, w: Wait) {
        let base = self.now.max(self.tasks[i].ready_at.saturating_sub(1));
        let at = self.next_tick(base);
        let t = &mut self.tasks[i];
        t.poll_at = at;
        t.wait = Some(w);
    }

    /// When each task's earliest armed interrupt fires (idle tasks: never).
    pub(super) fn interrupt_times(&self) -> [Option<Ns>; 6] {
        let mut times = self.interrupt_times_cached();
        for (k, t) in self.tasks.iter().enumerate().take(6) {
            if t.run == Run::Idle {
                times[k] = None;
            }
        }
        times
    }

    /// [`Self::interrupt_times`] without idle tasks set to `None` (the same for every task
    /// that is not idle).
    pub(super) fn interrupt_times_cached(&self) -> [Option<Ns>; 6] {
        self.refresh_int_cache();
        std::array::from_fn(|k| self.int_cache[k].get())
    }

    /// Task `k`'s entry of [`Self::interrupt_times_cached`].
    #[inline]
    pub(super) fn interrupt_time_cached(&self, k: TaskSlot) -> Option<Ns> {
        self.refresh_int_cache();
        self.int_cache.get(k.index()).and_then(std::cell::Cell::get)
    }

    /// Recomputes the cached interrupt times when a signal or an armed interrupt changed.
    #[inline]
    pub(super) fn refresh_int_cache(&self) {
        if self.int_cache_epoch.get() == self.int_epoch {
            return;
        }
        let debounce = ns(self.cfg.signal_debounce);
        for (k, t) in self.tasks.iter().enumerate().take(6) {
            let time = t
                .interrupts
                .iter()
                .filter_map(|int| {
                    let n = int.signal.abs();
                    let want = int.signal > 0;
                    let s = self.signals.get(&n)?;
                    (s.on == want && s.changed > int.armed_at)
                        .then(|| s.changed.saturating_add(debounce))
                })
                .min();
            self.int_cache[k].set(time);
        }
        self.int_cache_epoch.set(self.int_epoch);
    }

    /// Sets task `k`'s run state (and its bit in [`Self::active`]).
    pub(super) fn set_run(&mut self, k: TaskSlot, run: Run) {
        if let Some(t) = self.tasks.get_mut(k.index()) {
            // A task that stops or starts has no abort left to do.
            if run == Run::Idle || t.run == Run::Idle {
                t.abort_after_step = false;
            }
            t.run = run;
            let bit = 1u8 << (k.index() & 7);
            if run == Run::Idle {
                self.active &= !bit;
            } else {
                self.active |= bit;
            }
        }
    }

    /// `ABORT` (robot task) or `PCABORT n:` as the controller plays them: the task stops
    /// "after the current step is completed" (AS-E p.5-42; PCABORT is identical, p.10-4). A
    /// task between steps, or in a wait that `ABORT` ends (`WAIT` condition, `HOLD`, `PAUSE`),
    /// stops now; a task in a step that completes by itself (`TWAIT`, `TCP_ACCEPT`/`TCP_RECV`
    /// and the other socket calls with their timeouts, a PC task's motion wait) stops when
    /// that step completes: until then it runs (`TASK` reads 1) and [`Self::abort_pending`]
    /// is `true`. A robot task waiting to plan its next motion plans it and stops after it
    /// (AS-E p.5-42: the robot may perform one more motion after the current one); the
    /// motions already planned complete. Returns `true` when the task stopped now (or did not
    /// run).
    pub fn abort_after_step(&mut self, task: TaskId) -> bool {
        let i = TaskSlot::of(task);
        let Some(t) = self.tasks.get_mut(i.index()) else {
            return true;
        };
        if t.run == Run::Idle {
            return true;
        }
        let waits = t.run == Run::Running && t.wait.as_ref().is_some_and(|w| w.completes());
        if waits {
            t.abort_after_step = true;
            false
        } else {
            self.abort(task);
            true
        }
    }

    /// `true` while `task` runs the step it stops after (see [`Self::abort_after_step`]).
    pub fn abort_pending(&self, task: TaskId) -> bool {
        self.tasks
            .get(TaskSlot::of(task).index())
            .is_some_and(|t| t.run != Run::Idle && t.abort_after_step)
    }

    pub(super) fn interrupt_time(&self, i: TaskSlot) -> Option<Ns> {
        self.interrupt_times().get(i.index()).copied().flatten()
    }

    /// Earliest event, skipping task `skip`'s own steps; ties go to the lower task.
    pub(super) fn next_event_from(&self, skip: Option<TaskSlot>) -> Option<(Ns, TaskSlot)> {
        // A signal a PULSE or DLYSIG changes later (it may fire an interrupt, end an SWAIT).
        let mut best: Option<(Ns, TaskSlot)> = self.timed_next().map(|t| (t, TaskSlot::ROBOT));
        let ints = if self.tasks.iter().any(|t| !t.interrupts.is_empty()) {
            self.interrupt_times()
        } else {
            [None; 6]
        };
        for i in 0..self.tasks.len() {
            let slot = TaskSlot::at(i);
            let mut cands = [ints.get(i).copied().flatten(), None];
            if skip != Some(slot) {
                cands[1] = self.task_wake(slot);
            }
            for t in cands.into_iter().flatten() {
                if best.is_none_or(|(b, _)| t < b) {
                    best = Some((t, slot));
                }
            }
        }
        best
    }

    /// The next event in one pass over the tasks: its time, its task, whether it is that
    /// task's interrupt, and the horizon — what [`Self::next_event_from`] gives with that task's
    /// own steps skipped (where a run of its steps must stop).
    pub(super) fn next_event_and_horizon(&self) -> Option<(Ns, TaskSlot, bool, Option<Ns>)> {
        fn earlier(a: Option<Ns>, b: Option<Ns>) -> Option<Ns> {
            match (a, b) {
                (Some(x), Some(y)) => Some(x.min(y)),
                (x, y) => x.or(y),
            }
        }
        // Only tasks that are not idle (an idle task has no step and no armed interrupt);
        // interrupt times only for tasks with armed interrupts (a task without any has none).
        let mut best: Option<(Ns, TaskSlot, Option<Ns>)> = None;
        let mut others: Option<Ns> = None;
        let mut mask = self.active;
        while mask != 0 {
            let k = mask.trailing_zeros() as usize;
            mask &= mask - 1;
            let Some(t) = self.tasks.get(k) else { break };
            let slot = TaskSlot::at(k);
            let int = if t.interrupts.is_empty() {
                None
            } else {
                self.interrupt_time_cached(slot)
            };
            let Some(c) = earlier(int, self.wake_time(slot, t)) else {
                continue;
            };
            match best {
                Some((b, _, _)) if c >= b => others = earlier(others, Some(c)),
                _ => {
                    others = earlier(others, best.map(|(b, _, _)| b));
                    best = Some((c, slot, int));
                }
            }
        }
        let (at, i, int) = best?;
        let interrupt = int.is_some_and(|it| it <= at);
        Some((at, i, interrupt, earlier(others, int)))
    }

    /// Runs every task up to `until` (statements, timeouts, waits, interrupts), calling
    /// [`System::advance_to`] before each step. Events at exactly `until` run.
    pub fn run_until(&mut self, sys: &mut dyn System, until: Duration) {
        let until = ns(until);
        if until < self.now {
            return;
        }
        // Something outside may have changed since the last call (a client connected, data
        // arrived, a switch moved): look at every waiting task now.
        for t in &mut self.tasks {
            if t.wait.as_ref().is_some_and(Wait::socket) {
                t.kick = true;
            }
        }
        self.sys_at = None;
        // The code never changes once loaded: one handle for the whole run.
        let code = Arc::clone(&self.code);
        let mut guard: u64 = 0;
        loop {
            let next = self.next_event_and_horizon();
            let timed = self.timed_next();
            if let Some(ts) = timed.filter(|&ts| ts <= until) {
                if next.is_none_or(|(t, ..)| ts <= t) {
                    // A signal PULSE or DLYSIG changes now, before any step at this time.
                    if ts > self.now {
                        self.now = ts;
                        self.advance_sys(sys, ts);
                    }
                    self.apply_timed_signals();
                    continue;
                }
            }
            let Some((t, i, interrupt, horizon)) = next else {
                break;
            };
            let horizon = match (horizon, timed) {
                (Some(h), Some(ts)) => Some(h.min(ts)),
                (h, ts) => h.or(ts),
            };
            if t > until {
                break;
            }
            guard += 1;
            if guard > 50_000_000 {
                break;
            }
            if t > self.now {
                self.now = t;
                self.advance_sys(sys, t);
            }
            // The system cannot change the interpreter's signals: the interrupt due at `t` is
            // still due now.
            if interrupt {
                self.fire_interrupt(i, sys);
                continue;
            }
            self.wake(i, sys, until, horizon, &code);
        }
        if until > self.now {
            self.now = until;
            self.advance_sys(sys, until);
        }
        self.close_left_udp_ports(sys);
    }

    /// Brings the system to `t` (once: a second call for the same time does nothing).
    #[inline]
    pub(super) fn advance_sys(&mut self, sys: &mut dyn System, t: Ns) {
        if self.sys_at != Some(t) {
            sys.advance_to(Duration::from_nanos(t));
            self.sys_at = Some(t);
        }
    }

    /// Task `i` is due: poll its wait, then run its steps until another event is due
    /// (`horizon`: the earliest event other than this task's steps, as found before the poll).
    pub(super) fn wake(
        &mut self,
        i: TaskSlot,
        sys: &mut dyn System,
        until: Ns,
        horizon: Option<Ns>,
        code: &Arc<Code>,
    ) {
        let epoch = self.int_epoch;
        // The robot task's poll without a wait checks the panel and the error (at `self.now`,
        // with the system there) and changes nothing in the system: its first step at that
        // time need not check them again.
        let t = &self.tasks[i];
        let plain = t.run == Run::Running && t.wait.is_none() && t.pending_on.is_none();
        let checked_at =
            (i.is_robot() && plain && self.sys_at == Some(self.now)).then_some(self.now);
        if plain {
            // The poll of a task without a wait or a pending ON, in place.
            if i.is_robot() && !self.robot_allowed(sys) {
                return;
            }
            self.tasks[i].kick = false;
        } else if !self.poll(i, sys) {
            return;
        }
        // The poll changes only this task (its steps are not in the horizon) — unless it
        // changed a signal or an interrupt.
        let mut horizon = if self.int_epoch == epoch {
            horizon.map_or(until, |t| t.min(until))
        } else {
            self.next_event_from(Some(i))
                .map_or(until, |(t, _)| t.min(until))
        };
        let poll = self.poll_ns;
        // The system is brought to a step's time only when the step touches it, or once per
        // poll period (pure computation does not need the arm's state).
        let mut synced = self.now;
        let mut first = true;
        let mut epoch = self.int_epoch;
        loop {
            let now = self.now;
            let t = &self.tasks[i];
            // The step an ABORT waited for has completed: the task stops here.
            if t.abort_after_step && t.run == Run::Running && t.wait.is_none() {
                let id = t.id;
                self.abort(id);
                return;
            }
            // (A pending ON is delivered at the next wake: the poll above took any earlier
            // one.)
            if t.run != Run::Running || t.wait.is_some() || t.pending_on.is_some() {
                return;
            }
            let at = t.ready_at.max(now);
            if at > now {
                // Another task (or the same instant of a lower task) goes first.
                if at >= horizon || at > until {
                    return;
                }
                self.now = at;
            }
            let (prog, pc) = t.frames.last().map_or((usize::MAX, 0), |f| (f.prog, f.pc));
            let p = code.programs.get(prog);
            let touches = p.and_then(|p| p.touches.get(pc).copied()).unwrap_or(true);
            let sync = first || touches || at >= synced.saturating_add(poll);
            let checked = first && checked_at == Some(at);
            if sync {
                self.advance_sys(sys, at);
                synced = at;
                first = false;
            }
            // A PC task's step that meets the system needs nothing more than the system at
            // its time; the robot task's checks the panel, the error and HOLD (in `step`).
            if (!sync || !i.is_robot()) && self.trace.is_none() {
                if let Some(p) = p {
                    // A run of pure computation between two syncs: the ops run here, with the
                    // pc, the time and the step count in locals (written back when the run
                    // ends), without the checks of a step that meets the system. Each op
                    // sees what a step would give it (its time in `self.now`).
                    let (mut pc, mut at, mut steps) = (pc, at, 0u64);
                    let mut ready = at;
                    let cost = self.stmt_ns;
                    let poll_end = synced.saturating_add(poll);
                    let failed = loop {
                        let Some(op) = p.ops.get(pc) else { break None };
                        match self.exec_hot(i, sys, op, pc) {
                            // Not pure computation: a step below runs it.
                            Ok(NOT_PURE) => break None,
                            Ok(next) => pc = next,
                            Err(e) => {
                                steps += 1;
                                break Some(e);
                            }
                        }
                        steps += 1;
                        ready = at.saturating_add(cost);
                        if ready >= horizon
                            || ready > until
                            || ready >= poll_end
                            || p.touches.get(pc).copied().unwrap_or(true)
                        {
                            break None;
                        }
                        self.now = ready;
                        at = ready;
                    };
                    if steps > 0 {
                        let t = &mut self.tasks[i];
                        t.steps += steps;
                        if let Some(f) = t.frames.last_mut() {
                            f.pc = pc;
                        }
                        // A failed step leaves the time where the previous one put it.
                        if failed.is_none() || steps > 1 {
                            t.ready_at = ready;
                        }
                        if let Some(e) = failed {
                            self.fail(i, e, sys);
                            return;
                        }
                        continue;
                    }
                }
            }
            match self.step(i, sys, code, sync, checked, p, pc) {
                Ok(Flow::Next) => {}
                Ok(Flow::Shared) => {
                    for (k, t) in self.tasks.iter_mut().enumerate() {
                        if TaskSlot::at(k) != i && t.wait.as_ref().is_some_and(Wait::socket) {
                            t.kick = true;
                        }
                    }
                    horizon = self
                        .next_event_from(Some(i))
                        .map_or(until, |(t, _)| t.min(until));
                }
                Ok(Flow::Wait(w)) => {
                    self.set_wait(i, *w);
                    return;
                }
                Err(e) => {
                    self.fail(i, e, sys);
                    return;
                }
            }
            if self.int_epoch != epoch {
                // A signal or an interrupt changed: an interrupt may be due, others may run.
                epoch = self.int_epoch;
                if self.interrupt_time(i).is_some_and(|it| it <= self.now) {
                    return;
                }
                horizon = self
                    .next_event_from(Some(i))
                    .map_or(until, |(t, _)| t.min(until));
            }
        }
    }

    /// Robot task: stop it when the controller cannot run a program (error, power off, TEACH,
    /// teach lock); `true` when it may go on.
    pub(super) fn robot_allowed(&mut self, sys: &mut dyn System) -> bool {
        let panel = sys.panel();
        // The robot task's own error program (ONE) runs while the controller is in error.
        let err = if self.in_error_program(TaskSlot::ROBOT) {
            fs020n_proto::ErrorCode::NONE
        } else {
            sys.error()
        };
        if !err.is_none() || !panel.power || !panel.repeat || panel.teach_lock {
            let why = if !err.is_none() {
                format!("program stopped: controller error {err}")
            } else if !panel.power {
                "program stopped: motor power OFF".into()
            } else if !panel.repeat {
                "program stopped: TEACH mode".into()
            } else {
                "program stopped: TEACH LOCK ON".into()
            };
            self.abort(TaskId::Robot);
            self.message(sys, TaskId::Robot, why);
            return false;
        }
        true
    }

    /// Polls task `i`'s wait; `true` when it may run steps now.
    #[inline(never)]
    pub(super) fn poll(&mut self, i: TaskSlot, sys: &mut dyn System) -> bool {
        if self.tasks[i].run == Run::Ending {
            // TASK(1) = 3 until the last motion is done.
            if !self.robot_allowed(sys) {
                return false;
            }
            if sys.motion_in_progress() {
                self.tasks[i].poll_at = self.next_tick(self.now);
            } else {
                self.abort(TaskId::Robot);
            }
            return false;
        }
        if self.tasks[i].run != Run::Running {
            return false;
        }
        if i.is_robot() && !self.robot_allowed(sys) {
            return false;
        }
        self.tasks[i].kick = false;
        let now = self.now;
        let Some(wait) = self.tasks[i].wait.take() else {
            return self.deliver_on(i, sys);
        };
        let done: R<Option<Wait>> = (|| -> R<Option<Wait>> {
            Ok(match wait {
                Wait::Until(t) => (now < t).then_some(Wait::Until(t)),
                Wait::Cond => {
                    let e = match self.current_op(i) {
                        Some(Op::Wait(e)) => e.clone(),
                        _ => return Ok(None),
                    };
                    if truthy(self.eval_r(i, &e, sys)?) {
                        self.advance_pc(i);
                        None
                    } else {
                        Some(Wait::Cond)
                    }
                }
                Wait::MotionPlanned => sys.motion_planned().then_some(Wait::MotionPlanned),
                Wait::MotionDone => sys.motion_in_progress().then_some(Wait::MotionDone),
                Wait::Till => self.poll_till(i, sys)?,
                Wait::Held => (self.mc_hold || !sys.panel().run).then_some(Wait::Held),
                Wait::Paused => Some(Wait::Paused),
                Wait::Accept { port, deadline } => match sys.tcp_accept(port) {
                    SockPoll::Ready(r) => {
                        self.finish_accept(i, r, sys)?;
                        None
                    }
                    SockPoll::Pending if now >= deadline => {
                        self.finish_accept(i, Err(TcpCode::Timeout.code()), sys)?;
                        None
                    }
                    SockPoll::Pending => Some(Wait::Accept { port, deadline }),
                },
                Wait::Connect { ip, port, deadline } => match sys.tcp_connect(ip, port) {
                    SockPoll::Ready(r) => {
                        self.finish_ret(i, r.unwrap_or_else(|e| e) as f32, sys)?;
                        None
                    }
                    SockPoll::Pending if now >= deadline => {
                        sys.tcp_connect_abandon(ip, port);
                        self.finish_ret(i, TcpCode::Timeout.code() as f32, sys)?;
                        None
                    }
                    SockPoll::Pending => Some(Wait::Connect { ip, port, deadline }),
                },
                Wait::Recv {
                    sock,
                    max,
                    deadline,
                } => match sys.tcp_recv(sock, MAX_TRANSFER) {
                    SockPoll::Ready(r) => {
                        self.finish_recv(i, r, max, sys)?;
                        None
                    }
                    SockPoll::Pending if now >= deadline => {
                        self.finish_recv(i, Err(TcpCode::Timeout.code()), max, sys)?;
                        None
                    }
                    SockPoll::Pending => Some(Wait::Recv {
                        sock,
                        max,
                        deadline,
                    }),
                },
                Wait::Send {
                    sock,
                    data,
                    deadline,
                } => match sys.tcp_send(sock, &data) {
                    SockPoll::Ready(r) => {
                        self.finish_ret(i, r.map_or_else(|e| e as f32, |()| 0.0), sys)?;
                        None
                    }
                    SockPoll::Pending if now >= deadline => {
                        self.finish_ret(i, TcpCode::Timeout.code() as f32, sys)?;
                        None
                    }
                    SockPoll::Pending => Some(Wait::Send {
                        sock,
                        data,
                        deadline,
                    }),
                },
                Wait::UdpRecv {
                    port,
                    max,
                    deadline,
                } => match sys.udp_recv(port) {
                    SockPoll::Ready(r) => {
                        self.finish_udp_recv(i, r, max, sys)?;
                        None
                    }
                    SockPoll::Pending if now >= deadline => {
                        self.finish_udp_recv(i, Err(TcpCode::Timeout.code()), max, sys)?;
                        None
                    }
                    SockPoll::Pending => Some(Wait::UdpRecv {
                        port,
                        max,
                        deadline,
                    }),
                },
            })
        })();
        match done {
            Ok(Some(w)) => {
                self.set_wait(i, w);
                false
            }
            Ok(None) => {
                let t = &mut self.tasks[i];
                t.ready_at = t.ready_at.max(now);
                self.deliver_on(i, sys)
            }
            Err(e) => {
                self.fail(i, e, sys);
                false
            }
        }
    }

    /// Delivers a pending `ON` interrupt at a step boundary; `true` when the task may run.
    pub(super) fn deliver_on(&mut self, i: TaskSlot, sys: &mut dyn System) -> bool {
        if let Some(int) = self.tasks[i].pending_on.take() {
            self.branch(i, int, sys);
        }
        self.tasks[i].run == Run::Running && self.tasks[i].wait.is_none()
    }

    pub(super) fn fire_interrupt(&mut self, i: TaskSlot, sys: &mut dyn System) {
        let now = self.now;
        let debounce = ns(self.cfg.signal_debounce);
        let signals = &self.signals;
        let pos = self.tasks[i].interrupts.iter().position(|int| {
            let n = int.signal.abs();
            signals.get(&n).is_some_and(|s| {
                s.on == (int.signal > 0)
                    && s.changed > int.armed_at
                    && s.changed.saturating_add(debounce) <= now
            })
        });
        let Some(pos) = pos else { return };
        let int = self.tasks[i].interrupts.remove(pos);
        self.int_epoch += 1;
        if int.immediate {
            // ONI: the motion stops at once (the planned one is dropped), the program
            // branches now — also while it was finishing (TASK(1) = 3).
            sys.cut_motion();
            self.tasks[i].wait = None;
            self.set_run(i, Run::Running);
            self.branch(i, int, sys);
        } else if self.tasks[i].run == Run::Ending {
            // ON while finishing: the program branches after the last motion is done…
            // which ends it first: the interrupt is lost.
        } else if self.tasks[i].wait.is_some() {
            // ON: after the current wait (a motion in progress completes first).
            self.tasks[i].pending_on = Some(int);
        } else {
            self.branch(i, int, sys);
        }
    }

    pub(super) fn branch(&mut self, i: TaskSlot, int: Interrupt, sys: &mut dyn System) {
        self.release_frames(i, int.depth.max(1));
        let t = &mut self.tasks[i];
        t.ready_at = self.now;
        if let Some(target) = int.goto {
            if let Some(f) = t.frames.last_mut() {
                f.pc = target;
            }
        } else if let Some(p) = int.call {
            if let Err(e) = self.push_frame(i, p, &[]) {
                self.fail(i, e, sys);
            }
        }
    }

    pub(super) fn current_op(&self, i: TaskSlot) -> Option<&Op> {
        let f = self.tasks[i].frames.last()?;
        self.code.programs.get(f.prog)?.ops.get(f.pc)
    }

    pub(super) fn advance_pc(&mut self, i: TaskSlot) {
        if let Some(f) = self.tasks[i].frames.last_mut() {
            f.pc += 1;
        }
    }

    pub(super) fn fail(&mut self, i: TaskSlot, e: Box<RuntimeError>, sys: &mut dyn System) {
        self.advance_sys(sys, self.now);
        let id = self.tasks[i].id;
        let where_ = self.tasks[i].frames.last().map(|f| {
            let p = &self.code.programs[f.prog];
            format!(
                "{} line {}",
                p.name,
                p.lines.get(f.pc).copied().unwrap_or(0)
            )
        });
        let text = match &where_ {
            Some(w) => format!("{e} ({w})"),
            None => e.to_string(),
        };
        if self.enter_error_program(i, &text, e.code(), sys) {
            return;
        }
        self.abort(id);
        self.tasks[i].last_error = Some(text.clone());
        self.message(sys, id, text);
        sys.raise_error(e.code());
    }

    pub(super) fn message(&mut self, sys: &mut dyn System, task: TaskId, text: String) {
        sys.terminal(task, &text);
        self.terminal.push_back(TerminalLine {
            at: Duration::from_nanos(self.now),
            task,
            text,
        });
        while self.terminal.len() > self.cfg.terminal_lines {
            self.terminal.pop_front();
        }
    }
}
