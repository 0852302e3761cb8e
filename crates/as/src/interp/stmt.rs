//! Statements: one step of a task (the hot path of pure computation and the rest).

use std::sync::Arc;
use std::time::Duration;

use crate::ast::SpeedUnit;
use crate::compile::{CArg, CExpr, CProgram, Code, Op, RExpr, SExpr, Ty};
use crate::error::RuntimeError;
use crate::keywords::SYSTEM_SWITCHES;
use crate::sockets::TcpCode;
use crate::system::{Issued, MotionKind, MotionRequest, SockPoll, Speed, System, Target, TaskId};
use crate::value::{Bytes, MAX_INDEX};

use super::arith::{check, ns, secs, signal_number, truthy, Ns, NOT_PURE, R};
use super::report::TraceLine;
use super::task::{ArgVal, ByRefTarget, Flow, Interrupt, LocVal, Run, TaskSlot, Wait};
use super::Interpreter;
use super::MAX_TRANSFER;

impl Interpreter {
    /// Runs one step of task `i` at `self.now`: the op at `pc` of program `p`, the task's
    /// current frame (`None`: no frame or no such program).
    #[allow(clippy::too_many_arguments)]
    pub(super) fn step(
        &mut self,
        i: TaskSlot,
        sys: &mut dyn System,
        code: &Code,
        sync: bool,
        checked: bool,
        p: Option<&CProgram>,
        pc: usize,
    ) -> R<Flow> {
        if i.is_robot() && sync {
            // (`checked`: the poll just did this at this time.)
            if !checked && !self.robot_allowed(sys) {
                return Ok(Flow::Next);
            }
            if self.mc_hold || !sys.panel().run {
                return Ok(Flow::Wait(Box::new(Wait::Held)));
            }
        }
        let Some(p) = p else {
            self.abort(TaskId::from_index(i.index()));
            return Ok(Flow::Next);
        };
        let Some(op) = p.ops.get(pc) else {
            self.end_program(i, sys, true);
            return Ok(Flow::Next);
        };
        let now = self.now;
        if self.trace.is_some() && !matches!(op, Op::Jump(_)) {
            self.trace_step(i, code, p, pc, now);
        }
        // By default the next step is the following op.
        let t = &mut self.tasks[i];
        t.steps += 1;
        let depth = t.frames.len();
        if let Some(f) = t.frames.last_mut() {
            f.pc = pc + 1;
        }
        let r = self.exec(i, sys, code, op, pc, now, self.stmt_ns);
        if r.is_err() && self.tasks[i].frames.len() == depth {
            // Errors name the step that failed.
            self.set_pc(i, pc);
        }
        r
    }

    #[cold]
    pub(super) fn trace_step(
        &mut self,
        i: TaskSlot,
        code: &Code,
        p: &CProgram,
        pc: usize,
        now: Ns,
    ) {
        let id = self.tasks[i].id;
        let Some(trace) = &mut self.trace else { return };
        let line = p.lines.get(pc).copied().unwrap_or(0);
        let prog = code
            .programs
            .iter()
            .position(|q| std::ptr::eq(q, p))
            .unwrap_or(usize::MAX);
        trace.push(TraceLine {
            at: Duration::from_nanos(now),
            task: id,
            program: p.name.clone(),
            line,
            text: code.line_text(prog, line).to_owned(),
        });
        if trace.len() > 1_000_000 {
            trace.drain(..trace.len() / 2);
        }
    }

    // The step's context (program, pc, time, cost) travels as arguments: the hot path.
    /// One step's op (the task's pc already points after it).
    #[allow(clippy::too_many_arguments)]
    #[inline]
    pub(super) fn exec(
        &mut self,
        i: TaskSlot,
        sys: &mut dyn System,
        code: &Code,
        op: &Op,
        pc: usize,
        now: Ns,
        cost: Ns,
    ) -> R<Flow> {
        match self.exec_hot(i, sys, op, pc)? {
            NOT_PURE => self.exec_other(i, sys, code, op, pc, now, cost),
            next => {
                let t = &mut self.tasks[i];
                if let Some(f) = t.frames.last_mut() {
                    f.pc = next;
                }
                t.ready_at = now.saturating_add(cost);
                Ok(Flow::Next)
            }
        }
    }

    /// The ops of pure computation (assignments, jumps, FOR), which change nothing but
    /// variables: the pc of the next step, [`NOT_PURE`] (nothing done) for any other op. The
    /// caller sets the pc and the task's time.
    #[inline(always)]
    pub(super) fn exec_hot(
        &mut self,
        i: TaskSlot,
        sys: &mut dyn System,
        op: &Op,
        pc: usize,
    ) -> R<usize> {
        Ok(match op {
            Op::AssignR(l, e) => {
                let v = self.eval_r_top(i, e, sys)?;
                self.write_r(i, l, v, sys)?;
                pc + 1
            }
            Op::AssignS(l, e) => {
                match e {
                    // `.$tok = $DECODE(.$data, " ", 0)`: the server's tokenizer, in place.
                    SExpr::Decode(var, delims, mode) if l.idx.is_empty() && var.idx.is_empty() => {
                        if let (SExpr::Const(d), RExpr::Const(m)) = (&**delims, &**mode) {
                            self.decode_scalar(i, l, var, d, *m)?;
                            return Ok(pc + 1);
                        }
                    }
                    _ => {}
                }
                let v = self.eval_s(i, e, sys)?;
                self.write_s(i, l, v, sys)?;
                pc + 1
            }
            Op::Jump(t) => *t,
            Op::JumpIfNot(c, t) => {
                if truthy(self.eval_r_top(i, c, sys)?) {
                    pc + 1
                } else {
                    *t
                }
            }
            Op::JumpIf(c, t) => {
                if truthy(self.eval_r_top(i, c, sys)?) {
                    *t
                } else {
                    pc + 1
                }
            }
            Op::ForInit {
                var,
                from,
                to,
                step,
                limit,
                step_slot,
                exit,
            } => {
                let from = self.eval_r(i, from, sys)?;
                let to = self.eval_r(i, to, sys)?;
                let step = match step {
                    Some(s) => self.eval_r(i, s, sys)?,
                    None => 1.0,
                };
                if step == 0.0 {
                    return Err(Box::new(RuntimeError::IllegalValue("FOR … STEP 0".into())));
                }
                self.write_r(i, var, from, sys)?;
                self.set_hidden_r(i, *limit, to);
                self.set_hidden_r(i, *step_slot, step);
                if (step > 0.0 && from > to) || (step < 0.0 && from < to) {
                    *exit
                } else {
                    pc + 1
                }
            }
            Op::ForNext {
                var,
                limit,
                step_slot,
                body,
            } if var.idx.is_empty() && !var.var.global => {
                // A local scalar counter: the counter, limit and step in one lookup of the
                // frame's reals.
                let reals = &mut self.store(i, false).reals;
                let scalar = |k: u32| reals.get(k as usize).and_then(|v| v.scalar);
                let step = scalar(*step_slot).unwrap_or(0.0);
                let to = scalar(*limit).unwrap_or(0.0);
                let Some(cur) = scalar(var.var.slot) else {
                    return Err(self.undefined(i, var, Ty::Real, &[]));
                };
                let v = check(cur + step, "FOR")?;
                if let Some(x) = reals.get_mut(var.var.slot as usize) {
                    x.scalar = Some(v);
                }
                if (step > 0.0 && v <= to) || (step < 0.0 && v >= to) {
                    *body
                } else {
                    pc + 1
                }
            }
            Op::ForNext {
                var,
                limit,
                step_slot,
                body,
            } => {
                let step = self.hidden_r(i, *step_slot);
                let to = self.hidden_r(i, *limit);
                let v = check(self.read_r(i, var, sys)? + step, "FOR")?;
                self.write_r(i, var, v, sys)?;
                if (step > 0.0 && v <= to) || (step < 0.0 && v >= to) {
                    *body
                } else {
                    pc + 1
                }
            }
            _ => NOT_PURE,
        })
    }

    /// The ops [`Self::exec`] leaves to this function.
    #[allow(clippy::too_many_arguments)]
    #[inline(never)]
    pub(super) fn exec_other(
        &mut self,
        i: TaskSlot,
        sys: &mut dyn System,
        code: &Code,
        op: &Op,
        pc: usize,
        now: Ns,
        mut cost: Ns,
    ) -> R<Flow> {
        let robot = i.is_robot();
        let flow = match op {
            Op::Nop => Flow::Next,
            Op::AssignR(..)
            | Op::AssignS(..)
            | Op::Jump(_)
            | Op::JumpIfNot(..)
            | Op::JumpIf(..)
            | Op::ForInit { .. }
            | Op::ForNext { .. } => return self.exec(i, sys, code, op, pc, now, cost),
            Op::AssignJ(l, e) => {
                let v = self.eval_j(i, e, sys)?;
                self.write_loc_var(i, l, Ty::Joint, v, sys)?;
                Flow::Next
            }
            Op::AssignT(l, e) => {
                let v = self.eval_t(i, e, sys)?;
                self.write_loc_var(i, l, Ty::Trans, v, sys)?;
                Flow::Next
            }
            Op::CaseSelR(e, slot) => {
                let v = self.eval_r(i, e, sys)?;
                self.set_hidden_r(i, *slot, v);
                Flow::Next
            }
            Op::CaseSelS(e, slot) => {
                let v = self.eval_s(i, e, sys)?;
                if let Some(x) = self.store(i, false).strs.get_mut(*slot as usize) {
                    x.set(&[], v);
                }
                Flow::Next
            }
            Op::CaseTestR(values, slot, next) => {
                let sel = self.hidden_r(i, *slot);
                let mut hit = false;
                for v in values.iter() {
                    if self.eval_r(i, v, sys)? == sel {
                        hit = true;
                        break;
                    }
                }
                if !hit {
                    self.set_pc(i, *next);
                }
                Flow::Next
            }
            Op::CaseTestS(values, slot, next) => {
                let sel = self
                    .store(i, false)
                    .strs
                    .get(*slot as usize)
                    .and_then(|v| v.get(&[]))
                    .cloned()
                    .unwrap_or_else(|| Bytes::from(&b""[..]));
                let mut hit = false;
                for v in values.iter() {
                    if self.eval_s(i, v, sys)? == sel {
                        hit = true;
                        break;
                    }
                }
                if !hit {
                    self.set_pc(i, *next);
                }
                Flow::Next
            }
            Op::Call(prog, args) => {
                let args = self.eval_args(i, args, sys)?;
                // The caller resumes after the CALL.
                self.push_frame(i, *prog, &args)?;
                Flow::Next
            }
            Op::Return | Op::End => {
                self.ret(i, sys)?;
                Flow::Next
            }
            Op::Print(items) => {
                let (bytes, no_newline) = self.encode(i, items, sys)?;
                cost = cost.saturating_add(ns(self.cfg.cost.print
                    + self.cfg.cost.print_per_byte * bytes.len().min(100_000) as u32));
                let text = String::from_utf8_lossy(&bytes).into_owned();
                let id = self.tasks[i].id;
                let mut parts: Vec<&str> = text.split('\n').collect();
                let last = parts.pop().unwrap_or("");
                for part in parts {
                    let mut line = std::mem::take(&mut self.tasks[i].line_buf);
                    line.push_str(part);
                    self.message(sys, id, line);
                }
                self.tasks[i].line_buf.push_str(last);
                // A line ends unless /S says otherwise (and never grows without bound).
                if !no_newline || self.tasks[i].line_buf.len() > 4096 {
                    let line = std::mem::take(&mut self.tasks[i].line_buf);
                    self.message(sys, id, line);
                }
                Flow::Next
            }
            Op::Twait(e) => {
                let d = secs(self.eval_r(i, e, sys)?, "TWAIT")?;
                Flow::Wait(Box::new(Wait::Until(now.saturating_add(ns(d)))))
            }
            Op::Wait(e) => {
                if truthy(self.eval_r(i, e, sys)?) {
                    Flow::Next
                } else {
                    self.set_pc(i, pc);
                    Flow::Wait(Box::new(Wait::Cond))
                }
            }
            Op::Halt | Op::Stop => {
                self.end_program(i, sys, false);
                Flow::Next
            }
            Op::Pause => Flow::Wait(Box::new(Wait::Paused)),
            Op::Signal(v) => {
                for e in v.iter() {
                    let s = signal_number(self.eval_r(i, e, sys)?);
                    if s == 0 || !Self::signal_number_ok(s, true) {
                        return Err(Box::new(RuntimeError::IllegalValue(format!(
                            "SIGNAL {s} (outputs 1–999, internal 2001–2960)"
                        ))));
                    }
                    self.write_signal(s.abs(), s > 0);
                }
                Flow::Shared
            }
            Op::On {
                immediate,
                signal,
                goto,
                call,
            } => {
                if *immediate && !robot {
                    return Err(Box::new(RuntimeError::WrongTask(
                        "ONI is allowed only in robot programs".into(),
                    )));
                }
                let s = signal_number(self.eval_r(i, signal, sys)?);
                if s == 0 || !Self::signal_number_ok(s, false) {
                    return Err(Box::new(RuntimeError::IllegalValue(format!(
                        "signal number {s}"
                    ))));
                }
                let depth = self.tasks[i].frames.len();
                let t = &mut self.tasks[i];
                t.interrupts.retain(|x| x.signal.abs() != s.abs());
                t.interrupts.push(Interrupt {
                    signal: s,
                    immediate: *immediate,
                    goto: *goto,
                    call: *call,
                    depth,
                    armed_at: now,
                });
                self.int_epoch += 1;
                Flow::Next
            }
            Op::Ignore(e) => {
                let s = signal_number(self.eval_r(i, e, sys)?);
                self.tasks[i]
                    .interrupts
                    .retain(|x| x.signal.abs() != s.abs());
                self.int_epoch += 1;
                Flow::Next
            }
            Op::Execute {
                program,
                args,
                cycles,
            } => {
                if robot {
                    return Err(Box::new(RuntimeError::WrongTask(
                        "EXECUTE/MC is allowed only in PC programs".into(),
                    )));
                }
                let args = self.eval_args(i, args, sys)?;
                let cycles = match cycles {
                    Some(c) => self.eval_r(i, c, sys)?.trunc() as i64,
                    None => 1,
                };
                if let Err(r) = self.execute_robot(*program, args, cycles, sys) {
                    let id = self.tasks[i].id;
                    self.message(
                        sys,
                        id,
                        format!("EXECUTE {}: {r}", code.programs[*program].name),
                    );
                }
                Flow::Shared
            }
            Op::PcExecute {
                task,
                program,
                args,
                cycles,
            } => {
                let n = match task {
                    Some(t) => self.eval_r(i, t, sys)?.trunc(),
                    None => 1.0,
                };
                let args = self.eval_args(i, args, sys)?;
                let cycles = match cycles {
                    Some(c) => self.eval_r(i, c, sys)?.trunc() as i64,
                    None => 1,
                };
                if let Err(r) =
                    self.pc_execute_at(n.clamp(0.0, 255.0) as u8, *program, args, cycles)
                {
                    let id = self.tasks[i].id;
                    self.message(
                        sys,
                        id,
                        format!("PCEXECUTE {}: {r}", code.programs[*program].name),
                    );
                }
                Flow::Shared
            }
            Op::PcAbort(task) => {
                let n = match task {
                    Some(t) => self.eval_r(i, t, sys)?.trunc(),
                    None => 1.0,
                };
                if (1.0..=5.0).contains(&n) {
                    self.abort(TaskId::Pc(n as u8));
                }
                Flow::Shared
            }
            Op::McAbort | Op::McHold | Op::McContinue | Op::McSpeed(_) | Op::McEreset if robot => {
                return Err(Box::new(RuntimeError::WrongTask(
                    "MC is allowed only in PC programs".into(),
                )));
            }
            Op::McAbort => {
                if self.tasks[TaskSlot::ROBOT].run == Run::Running {
                    self.end_program(TaskSlot::ROBOT, sys, false);
                }
                Flow::Shared
            }
            Op::McHold => {
                self.mc_hold = true;
                sys.set_program_hold(true);
                Flow::Shared
            }
            Op::McContinue => {
                self.mc_hold = false;
                sys.set_program_hold(false);
                if matches!(self.tasks[TaskSlot::ROBOT].wait, Some(Wait::Paused)) {
                    self.tasks[TaskSlot::ROBOT].wait = None;
                    self.tasks[TaskSlot::ROBOT].ready_at = now;
                }
                Flow::Shared
            }
            Op::McSpeed(e) => {
                let v = self.eval_r(i, e, sys)?;
                if let Err(why) = sys.set_monitor_speed(f64::from(v)) {
                    let id = self.tasks[i].id;
                    self.message(sys, id, format!("MC SPEED {v}: {why}"));
                }
                Flow::Shared
            }
            Op::McEreset => {
                if let Err(why) = sys.reset_error() {
                    let id = self.tasks[i].id;
                    self.message(sys, id, format!("MC ERESET: {why}"));
                }
                Flow::Shared
            }
            Op::SetSwitch(k, on) => {
                if let Some(s) = self.switches.get_mut(*k) {
                    *s = *on;
                }
                Flow::Next
            }
            Op::Timer(n, v) => {
                let n = self.eval_r(i, n, sys)?.trunc();
                let v = self.eval_r(i, v, sys)?;
                if !(1.0..=10.0).contains(&n) {
                    return Err(Box::new(RuntimeError::IllegalValue(format!(
                        "TIMER {n} (1 to 10)"
                    ))));
                }
                let offset = (f64::from(v).clamp(-1.0e9, 1.0e9) * 1e9) as i128;
                self.timers[n as usize] = Some(i128::from(now) - offset);
                Flow::Next
            }
            Op::Decompose(target, l) => {
                let v = match self.eval_loc(i, l, sys)? {
                    LocVal::J(v) | LocVal::T(v) => v,
                };
                let n = target.idx.len().min(3);
                let idx = self.indices(i, target, sys)?;
                let dims = n.max(1);
                for (k, x) in v.iter().enumerate() {
                    let mut at = idx;
                    at[0] = idx[0] + k as i32;
                    if at[0] > MAX_INDEX {
                        return Err(Box::new(RuntimeError::IndexRange(format!(
                            "DECOMPOSE beyond index {MAX_INDEX}"
                        ))));
                    }
                    self.write_r_at(i, target.var, &at[..dims], *x)?;
                }
                Flow::Next
            }
            Op::HereJ(l) => {
                let v = sys.joints().map(|x| x as f32);
                self.write_loc_var(i, l, Ty::Joint, v, sys)?;
                Flow::Next
            }
            Op::HereT(l) => {
                let Some(p) = sys.pose() else {
                    return Err(Box::new(RuntimeError::IllegalValue(
                        "HERE: this controller has no kinematics".into(),
                    )));
                };
                self.write_loc_var(i, l, Ty::Trans, p.map(|x| x as f32), sys)?;
                Flow::Next
            }
            Op::Move(linear, l) => {
                self.require_robot(robot, "JMOVE/LMOVE")?;
                let target = match self.eval_loc(i, l, sys)? {
                    LocVal::J(v) => Target::Joints(v.map(f64::from)),
                    LocVal::T(v) => Target::Pose(v.map(f64::from)),
                };
                let kind = if *linear {
                    MotionKind::Linear
                } else {
                    MotionKind::Joint
                };
                self.motion(i, kind, target, 0.0, sys)?
            }
            Op::Home => {
                self.require_robot(robot, "HOME")?;
                let home = sys.home();
                self.motion(i, MotionKind::Joint, Target::Joints(home), 0.0, sys)?
            }
            Op::Delay(e) => {
                self.require_robot(robot, "DELAY")?;
                let d = self.eval_r(i, e, sys)?;
                if !(d.is_finite() && d >= 0.0) {
                    return Err(Box::new(RuntimeError::IllegalValue(format!("DELAY {d}"))));
                }
                let here = Target::Joints(sys.joints());
                self.motion(i, MotionKind::Delay, here, f64::from(d), sys)?
            }
            Op::Brake => {
                sys.brake();
                Flow::Shared
            }
            Op::Break => {
                self.require_robot(robot, "BREAK")?;
                if sys.motion_in_progress() {
                    Flow::Wait(Box::new(Wait::MotionDone))
                } else {
                    Flow::Next
                }
            }
            Op::Speed(e, unit, always) => {
                let v = self.eval_r(i, e, sys)?;
                let v = f64::from(v);
                let speed = match unit {
                    SpeedUnit::Percent => Speed::Percent(v.clamp(0.01, 100.0)),
                    other => {
                        if !(v.is_finite() && v > 0.0) {
                            return Err(Box::new(RuntimeError::IllegalValue(format!("SPEED {v}"))));
                        }
                        match other {
                            SpeedUnit::MmPerS => Speed::MmPerS(v),
                            SpeedUnit::MmPerMin => Speed::MmPerS(v / 60.0),
                            _ => Speed::Seconds(v),
                        }
                    }
                };
                let m = &mut self.tasks[i].motion;
                if *always {
                    m.speed = speed;
                    m.speed_once = None;
                } else {
                    m.speed_once = Some(speed);
                }
                Flow::Next
            }
            Op::Accuracy(e, fine, always) => {
                let v = f64::from(self.eval_r(i, e, sys)?);
                if !(v.is_finite() && v >= 0.0) {
                    return Err(Box::new(RuntimeError::IllegalValue(format!(
                        "ACCURACY {v}"
                    ))));
                }
                let m = &mut self.tasks[i].motion;
                if *always {
                    m.accuracy = (v, *fine);
                    m.accuracy_once = None;
                } else {
                    m.accuracy_once = Some((v, *fine));
                }
                Flow::Next
            }
            Op::AccelDecel(decel, e, always) => {
                let v = f64::from(self.eval_r(i, e, sys)?).clamp(0.01, 100.0);
                let m = &mut self.tasks[i].motion;
                match (decel, always) {
                    (false, true) => {
                        m.accel = v;
                        m.accel_once = None;
                    }
                    (false, false) => m.accel_once = Some(v),
                    (true, true) => {
                        m.decel = v;
                        m.decel_once = None;
                    }
                    (true, false) => m.decel_once = Some(v),
                }
                Flow::Next
            }
            Op::Cp(on) => {
                if let Some(k) = SYSTEM_SWITCHES.iter().position(|(n, _)| *n == "cp") {
                    self.switches[k] = *on;
                }
                Flow::Next
            }
            Op::TcpListen(ret, port) => {
                let port = self.port(i, port, sys)?;
                let r = sys.tcp_listen(port);
                self.write_r(i, ret, r as f32, sys)?;
                Flow::Shared
            }
            Op::TcpEndListen(ret, port) => {
                let port = self.port(i, port, sys)?;
                let r = sys.tcp_end_listen(port);
                self.write_r(i, ret, r as f32, sys)?;
                Flow::Shared
            }
            Op::TcpAccept { port, timeout, .. } => {
                let port = self.port(i, port, sys)?;
                let deadline = now.saturating_add(ns(self.timeout(i, timeout.as_ref(), sys)?));
                self.set_pc(i, pc);
                match sys.tcp_accept(port) {
                    SockPoll::Ready(r) => {
                        self.finish_accept(i, r, sys)?;
                        Flow::Shared
                    }
                    SockPoll::Pending => Flow::Wait(Box::new(Wait::Accept { port, deadline })),
                }
            }
            Op::TcpConnect {
                port, ip, timeout, ..
            } => {
                let port = self.port(i, port, sys)?;
                let deadline = now.saturating_add(ns(self.timeout(i, timeout.as_ref(), sys)?));
                let mut addr = [0u8; 4];
                let n = ip.idx.len().min(3);
                let base = self.indices(i, ip, sys)?;
                for (k, b) in addr.iter_mut().enumerate() {
                    let mut at = base;
                    at[0] += k as i32;
                    let v = match self
                        .store(i, ip.var.global)
                        .reals
                        .get(ip.var.slot as usize)
                        .and_then(|x| x.get(&at[..n.max(1)]))
                    {
                        Some(v) => *v,
                        None => return Err(self.undefined(i, ip, Ty::Real, &at[..n.max(1)])),
                    };
                    if !(0.0..=255.0).contains(&v) {
                        return Err(Box::new(RuntimeError::IllegalValue(format!(
                            "IP address byte {v}"
                        ))));
                    }
                    *b = v as u8;
                }
                self.set_pc(i, pc);
                match sys.tcp_connect(addr, port) {
                    SockPoll::Ready(r) => {
                        self.finish_ret(i, r.unwrap_or_else(|e| e) as f32, sys)?;
                        Flow::Shared
                    }
                    SockPoll::Pending => Flow::Wait(Box::new(Wait::Connect {
                        ip: addr,
                        port,
                        deadline,
                    })),
                }
            }
            Op::TcpRecv {
                sock, timeout, max, ..
            } => {
                let sock = self.eval_r(i, sock, sys)?.trunc() as i32;
                let deadline = now.saturating_add(ns(self.timeout(i, timeout.as_ref(), sys)?));
                let max = match max {
                    Some(m) => {
                        let m = self.eval_r(i, m, sys)?.trunc();
                        if !(1.0..=255.0).contains(&m) {
                            return Err(Box::new(RuntimeError::IllegalValue(format!(
                                "TCP_RECV element size {m} (1 to 255)"
                            ))));
                        }
                        m as usize
                    }
                    None => 255,
                };
                self.set_pc(i, pc);
                match sys.tcp_recv(sock, MAX_TRANSFER) {
                    SockPoll::Ready(r) => {
                        self.finish_recv(i, r, max, sys)?;
                        Flow::Shared
                    }
                    SockPoll::Pending => Flow::Wait(Box::new(Wait::Recv {
                        sock,
                        max,
                        deadline,
                    })),
                }
            }
            Op::TcpSend {
                ret,
                sock,
                buf,
                n,
                timeout,
            } => {
                let sock = self.eval_r(i, sock, sys)?.trunc() as i32;
                let deadline = now.saturating_add(ns(self.timeout(i, timeout.as_ref(), sys)?));
                let count = self.eval_r(i, n, sys)?.trunc();
                if !(0.0..=MAX_INDEX as f32).contains(&count) {
                    return Err(Box::new(RuntimeError::IllegalValue(format!(
                        "TCP_SEND element count {count}"
                    ))));
                }
                let dims = buf.idx.len().clamp(1, 3);
                let base = self.indices(i, buf, sys)?;
                let mut data = Vec::new();
                for k in 0..count as i32 {
                    let mut at = base;
                    at[0] += k;
                    let v = match self
                        .store(i, buf.var.global)
                        .strs
                        .get(buf.var.slot as usize)
                        .and_then(|x| x.get(&at[..dims]))
                    {
                        Some(v) => v.clone(),
                        None => return Err(self.undefined(i, buf, Ty::Str, &at[..dims])),
                    };
                    data.extend_from_slice(&v);
                    if data.len() > MAX_TRANSFER {
                        break;
                    }
                }
                if data.len() > MAX_TRANSFER {
                    self.write_r(i, ret, TcpCode::TooLong.code() as f32, sys)?;
                    return Ok(Flow::Shared);
                }
                self.set_pc(i, pc);
                match sys.tcp_send(sock, &data) {
                    SockPoll::Ready(r) => {
                        self.finish_ret(i, r.map_or_else(|e| e as f32, |()| 0.0), sys)?;
                        Flow::Shared
                    }
                    SockPoll::Pending => Flow::Wait(Box::new(Wait::Send {
                        sock,
                        data,
                        deadline,
                    })),
                }
            }
            Op::TcpClose(ret, sock) => {
                let sock = self.eval_r(i, sock, sys)?.trunc() as i32;
                let r = sys.tcp_close(sock);
                self.write_r(i, ret, r as f32, sys)?;
                Flow::Shared
            }
        };
        let t = &mut self.tasks[i];
        t.ready_at = now.saturating_add(cost);
        Ok(flow)
    }

    pub(super) fn require_robot(&self, robot: bool, what: &str) -> R<()> {
        if robot {
            Ok(())
        } else {
            Err(Box::new(RuntimeError::WrongTask(format!(
                "{what} is allowed only in robot programs"
            ))))
        }
    }

    pub(super) fn set_pc(&mut self, i: TaskSlot, pc: usize) {
        if let Some(f) = self.tasks[i].frames.last_mut() {
            f.pc = pc;
        }
    }

    pub(super) fn port(&mut self, i: TaskSlot, e: &RExpr, sys: &mut dyn System) -> R<u16> {
        let p = self.eval_r(i, e, sys)?.trunc();
        if !(8192.0..=65535.0).contains(&p) {
            return Err(Box::new(RuntimeError::IllegalValue(format!(
                "port {p} (8192 to 65535)"
            ))));
        }
        Ok(p as u16)
    }

    pub(super) fn timeout(
        &mut self,
        i: TaskSlot,
        e: Option<&RExpr>,
        sys: &mut dyn System,
    ) -> R<Duration> {
        let v = match e {
            Some(e) => self.eval_r(i, e, sys)?,
            None => 1.0,
        };
        if !(0.0..=60.0).contains(&v) {
            return Err(Box::new(RuntimeError::IllegalValue(format!(
                "timeout {v} s (0 to 60)"
            ))));
        }
        Ok(Duration::from_secs_f64(f64::from(v)))
    }

    /// Writes a socket instruction's result to its `ret` variable and goes on.
    pub(super) fn finish_ret(&mut self, i: TaskSlot, v: f32, sys: &mut dyn System) -> R<()> {
        let code = Arc::clone(&self.code);
        let op = self.tasks[i]
            .frames
            .last()
            .and_then(|f| code.programs.get(f.prog)?.ops.get(f.pc));
        let ret = match op {
            Some(
                Op::TcpConnect { ret, .. }
                | Op::TcpSend { ret, .. }
                | Op::TcpAccept { ret, .. }
                | Op::TcpRecv { ret, .. },
            ) => ret,
            _ => return Ok(()),
        };
        self.write_r(i, ret, v, sys)?;
        self.advance_pc(i);
        Ok(())
    }

    pub(super) fn finish_accept(
        &mut self,
        i: TaskSlot,
        r: Result<(i32, [u8; 4]), i32>,
        sys: &mut dyn System,
    ) -> R<()> {
        let ip = match self.current_op(i) {
            Some(Op::TcpAccept { ip, .. }) => ip.clone(),
            _ => None,
        };
        if let (Ok((_, addr)), Some(ip)) = (&r, ip) {
            let n = ip.idx.len().clamp(1, 3);
            let base = self.indices(i, &ip, sys)?;
            for (k, b) in addr.iter().enumerate() {
                let mut at = base;
                at[0] += k as i32;
                self.write_r_at(i, ip.var, &at[..n], f32::from(*b))?;
            }
        }
        let v = match r {
            Ok((id, _)) => id as f32,
            Err(e) => e as f32,
        };
        self.finish_ret(i, v, sys)
    }

    pub(super) fn finish_recv(
        &mut self,
        i: TaskSlot,
        r: Result<Vec<u8>, i32>,
        max: usize,
        sys: &mut dyn System,
    ) -> R<()> {
        // A handle on the code (not a copy of the op's variables) while the variables change.
        let code = Arc::clone(&self.code);
        let op = self.tasks[i]
            .frames
            .last()
            .and_then(|f| code.programs.get(f.prog)?.ops.get(f.pc));
        let (buf, count) = match op {
            Some(Op::TcpRecv { buf, count, .. }) => (buf, count),
            _ => return Ok(()),
        };
        match r {
            Ok(bytes) => {
                let dims = buf.idx.len().clamp(1, 3);
                let base = self.indices(i, buf, sys)?;
                let mut n = 0;
                for (k, chunk) in bytes.chunks(max.max(1)).take(MAX_TRANSFER).enumerate() {
                    let mut at = base;
                    at[0] += k as i32;
                    if at[0] > MAX_INDEX {
                        break;
                    }
                    self.write_s_at(i, buf.var, &at[..dims], Bytes::from(chunk))?;
                    n += 1;
                }
                self.write_r(i, count, n as f32, sys)?;
                self.finish_ret(i, 0.0, sys)
            }
            Err(e) => {
                self.write_r(i, count, 0.0, sys)?;
                self.finish_ret(i, e as f32, sys)
            }
        }
    }

    pub(super) fn eval_args(
        &mut self,
        i: TaskSlot,
        args: &[CArg],
        sys: &mut dyn System,
    ) -> R<Vec<(ArgVal, Option<ByRefTarget>)>> {
        let mut out = Vec::with_capacity(args.len());
        for a in args {
            let v = match &a.value {
                CExpr::R(e) => ArgVal::R(self.eval_r(i, e, sys)?),
                CExpr::S(e) => ArgVal::S(self.eval_s(i, e, sys)?),
                CExpr::J(e) => ArgVal::J(self.eval_j(i, e, sys)?),
                CExpr::T(e) => ArgVal::T(self.eval_t(i, e, sys)?),
            };
            let target = match &a.var {
                Some((_, l)) => {
                    let n = l.idx.len().min(3);
                    let idx = self.indices(i, l, sys)?;
                    let frame = self.tasks[i].frames.len().saturating_sub(1);
                    Some(ByRefTarget {
                        var: l.var,
                        idx: idx[..n].to_vec(),
                        frame,
                    })
                }
                None => None,
            };
            out.push((v, target));
        }
        Ok(out)
    }

    /// RETURN (or `.END`): back to the caller, writing by-reference parameters back.
    pub(super) fn ret(&mut self, i: TaskSlot, sys: &mut dyn System) -> R<()> {
        if self.tasks[i].frames.len() <= 1 {
            self.end_program(i, sys, true);
            return Ok(());
        }
        let Some(frame) = self.tasks[i].frames.pop() else {
            return Ok(());
        };
        let mut result = Ok(());
        for b in &frame.byref {
            let s = b.param as usize;
            let callee = &frame.locals;
            let val = match b.ty {
                Ty::Real => callee.reals[s].get(&[]).copied().map(ArgVal::R),
                Ty::Str => callee.strs[s].get(&[]).cloned().map(ArgVal::S),
                Ty::Joint => callee.joints[s].get(&[]).copied().map(ArgVal::J),
                Ty::Trans => callee.trans[s].get(&[]).copied().map(ArgVal::T),
            };
            let Some(val) = val else { continue };
            let store = if b.var.global {
                &mut self.globals
            } else {
                match self.tasks[i].frames.get_mut(b.frame) {
                    Some(f) => &mut f.locals,
                    None => continue,
                }
            };
            let slot = b.var.slot as usize;
            let created = match val {
                ArgVal::R(v) => store.reals.get_mut(slot).is_some_and(|x| x.set(&b.idx, v)),
                ArgVal::S(v) => store.strs.get_mut(slot).is_some_and(|x| x.set(&b.idx, v)),
                ArgVal::J(v) => store.joints.get_mut(slot).is_some_and(|x| x.set(&b.idx, v)),
                ArgVal::T(v) => store.trans.get_mut(slot).is_some_and(|x| x.set(&b.idx, v)),
            };
            if let Err(e) = self.count_element(created) {
                result = Err(e);
            }
        }
        // A CALL's caller resumes after its CALL (its pc moved when it executed it); an
        // `ON … CALL` returns to where the interrupt found the task.
        self.release(i, frame);
        result
    }

    /// Issues a motion with the task's motion parameters (the one-shot ones are used up).
    pub(super) fn motion(
        &mut self,
        i: TaskSlot,
        kind: MotionKind,
        target: Target,
        delay_s: f64,
        sys: &mut dyn System,
    ) -> R<Flow> {
        let cp = self.switch_on("cp");
        let abs_speed = self.switch_on("abs.speed");
        let m = &mut self.tasks[i].motion;
        let speed = m.speed_once.take().unwrap_or(m.speed);
        let (accuracy_mm, fine) = m.accuracy_once.take().unwrap_or(m.accuracy);
        let accel_percent = m.accel_once.take().unwrap_or(m.accel);
        let decel_percent = m.decel_once.take().unwrap_or(m.decel);
        let req = MotionRequest {
            kind,
            target,
            speed,
            delay_s,
            accuracy_mm,
            fine,
            accel_percent,
            decel_percent,
            cp,
            abs_speed,
        };
        match sys.issue_motion(&req) {
            Ok(Issued::Started) => Ok(Flow::Next),
            Ok(Issued::Planned) => Ok(Flow::Wait(Box::new(Wait::MotionPlanned))),
            Err(code) => Err(Box::new(RuntimeError::System(code))),
        }
    }
}
