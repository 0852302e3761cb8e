//! Statements: one step of a task (the hot path of pure computation and the rest).

use std::time::Duration;

use crate::compile::{BlockPart, CProgram, Code, Op, RExpr, SExpr, Ty};
use crate::error::RuntimeError;
use crate::keywords::SYSTEM_SWITCHES;
use crate::system::{System, TaskId};

use super::arith::{check, truthy, Ns, NOT_PURE, R};
use super::on_error::Resume;
use super::report::TraceLine;
use super::task::{Flow, Run, TaskSlot, Wait};
use super::Interpreter;

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
        if self.trace.is_some()
            && !matches!(
                op,
                // A block step's line is traced once, at its motion.
                Op::Jump(_) | Op::Block(BlockPart::Arrive | BlockPart::Inputs, _)
            )
        {
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

    /// The ops [`Self::exec`] leaves to this function: each statement has its function in the
    /// file of its concern (`flow.rs`, `monitor.rs`, `motion.rs`, `print.rs`, `signals.rs`,
    /// `tcp.rs`), marked `#[inline(always)]` so that this stays one function, as the compiler
    /// saw it when the statements were written here (they are called from here alone).
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
            Op::NotEmulated(instr) => {
                return Err(Box::new(RuntimeError::NotEmulated(instr.to_string())))
            }
            Op::Fail(label) => return Err(Box::new(RuntimeError::NoLabel(label.to_string()))),
            Op::AssignR(..)
            | Op::AssignS(..)
            | Op::Jump(_)
            | Op::JumpIfNot(..)
            | Op::JumpIf(..)
            | Op::ForInit { .. }
            | Op::ForNext { .. } => return self.exec(i, sys, code, op, pc, now, cost),
            Op::AssignJ(l, e) => self.assign_joints(i, l, e, sys)?,
            Op::AssignT(l, e) => self.assign_trans(i, l, e, sys)?,
            Op::CaseSelR(e, slot) => self.case_select_r(i, e, slot, sys)?,
            Op::CaseSelS(e, slot) => self.case_select_s(i, e, slot, sys)?,
            Op::CaseTestR(values, slot, next) => self.case_test_r(i, values, slot, next, sys)?,
            Op::CaseTestS(values, slot, next) => self.case_test_s(i, values, slot, next, sys)?,
            Op::Call(prog, args) => self.call(i, prog, args, sys)?,
            Op::Return | Op::ReturnAfterError | Op::End => {
                if self.tasks[i].frames.len() <= 1 {
                    self.circle_left_open(i)?;
                }
                let resume = match op {
                    Op::Return => Resume::FailedStep,
                    Op::ReturnAfterError => Resume::NextStep,
                    _ => Resume::Stop,
                };
                self.ret(i, resume, sys)?;
                Flow::Next
            }
            Op::Print(items) => {
                cost = cost.saturating_add(self.print(i, items, sys)?);
                Flow::Next
            }
            Op::Twait(e) => self.twait(i, e, sys, now)?,
            Op::Wait(e) => self.wait_until(i, e, sys, pc)?,
            Op::Halt | Op::Stop => {
                self.end_program(i, sys, false);
                Flow::Next
            }
            Op::Pause => Flow::Wait(Box::new(Wait::Paused)),
            Op::Signal(v) => self.signal_out(i, v, sys)?,
            Op::Pulse(sig, t) => self.pulse(i, sig, t, sys, now)?,
            Op::Dlysig(sig, t) => self.dlysig(i, sig, t, sys, now)?,
            Op::RunMask(sig, count) => self.run_mask(i, sig, count, sys)?,
            Op::Weight(values) => self.weight(i, values, sys)?,
            Op::Sout(signal, logic) => self.sout(i, signal, logic, sys)?,
            Op::IfpWrite(overwrite, w) => self.ifp_write(i, *overwrite, w, sys)?,
            Op::IfpLabel(l) => self.ifp_label(i, &l.0, &l.1, sys)?,
            Op::IfpTitle(t) => self.ifp_title(i, &t.0, &t.1, sys)?,
            Op::Bits(wide, start, count, value) => {
                self.bits_out(i, *wide, start, count, value, sys)?
            }
            Op::Hand(action, immediate, hand) => {
                self.hand(i, *action, *immediate, hand, sys, pc)?
            }
            Op::On {
                immediate,
                signal,
                goto,
                call,
            } => self.arm_interrupt(i, immediate, signal, goto, call, sys, now, robot)?,
            Op::Ignore(e) => self.ignore(i, e, sys)?,
            Op::Execute {
                program,
                args,
                cycles,
            } => self.execute_stmt(i, program, args, cycles, sys, code, robot)?,
            Op::PcExecute {
                task,
                program,
                args,
                cycles,
            } => self.pc_execute_stmt(i, task, program, args, cycles, sys, code)?,
            Op::PcAbort(task) => self.pc_abort(i, task, sys)?,
            Op::PcEnd(task, mode) => self.pc_end(i, task, mode, sys)?,
            Op::McAbort | Op::McHold | Op::McContinue | Op::McSpeed(_) | Op::McEreset if robot => {
                return Err(Box::new(RuntimeError::PcOnly(
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
            Op::McContinue => self.mc_continue(sys, now)?,
            Op::McSpeed(e) => self.mc_speed(i, e, sys)?,
            Op::McEreset => self.mc_ereset(i, sys)?,
            Op::McZpower(on) => self.mc_zpower(i, *on, sys)?,
            Op::SetSwitch(k, on) => {
                if let Some(s) = self.switches.get_mut(*k) {
                    *s = *on;
                }
                Flow::Next
            }
            Op::Timer(n, v) => self.set_timer(i, n, v, sys, now)?,
            Op::UTimer(l, v) => self.set_utimer(i, l, v, sys, now)?,
            Op::Decompose(target, l) => self.decompose(i, target, l, sys)?,
            Op::HereJ(l) => {
                let v = sys.joints().map(|x| x as f32);
                self.write_loc_var(i, l, Ty::Joint, v, sys)?;
                Flow::Next
            }
            Op::HereT(l) => self.here_trans(i, l, sys)?,
            Op::Move(linear, l) => self.move_to(i, linear, l, sys, robot)?,
            Op::Home => self.home(i, sys, robot)?,
            Op::Frame(base, t) => self.set_frame(i, *base, t, sys, pc)?,
            Op::Posture(p) => self.set_posture(i, *p, sys, pc)?,
            Op::Appro(linear, t, d) => self.appro(i, *linear, t, d, sys)?,
            Op::Depart(linear, d) => self.depart(i, *linear, d, sys)?,
            Op::Draw(tool, offset) => self.draw(i, *tool, offset, sys)?,
            Op::Circle(end, t) => self.circle(i, *end, t, sys)?,
            Op::Xmove(l, till) => self.xmove(i, l, till, sys, pc)?,
            Op::Align => self.align(i, sys)?,
            Op::Drive(args) => self.drive(i, args, sys)?,
            Op::Hmove(l) => self.hmove(i, l, sys)?,
            Op::Delay(e) => self.delay(i, e, sys, robot)?,
            Op::Brake => {
                sys.brake();
                Flow::Shared
            }
            Op::Break => self.break_motion(sys, robot)?,
            Op::Speed(e, unit, always) => self.speed(i, e, unit, always, sys)?,
            Op::Accuracy(e, fine, always) => self.accuracy(i, e, fine, always, sys)?,
            Op::AccelDecel(decel, e, always) => self.accel_decel(i, decel, e, always, sys)?,
            Op::Cp(on) => {
                if let Some(k) = SYSTEM_SWITCHES.iter().position(|(n, _)| *n == "cp") {
                    self.switches[k] = *on;
                }
                Flow::Next
            }
            Op::TcpListen(ret, port) => self.tcp_listening(i, ret, port, true, sys)?,
            Op::TcpEndListen(ret, port) => self.tcp_listening(i, ret, port, false, sys)?,
            Op::TcpAccept { port, timeout, .. } => {
                self.tcp_accept(i, port, timeout, sys, pc, now)?
            }
            Op::TcpConnect {
                port, ip, timeout, ..
            } => self.tcp_connect(i, port, ip, timeout, sys, pc, now)?,
            Op::TcpRecv {
                sock, timeout, max, ..
            } => self.tcp_recv(i, sock, timeout, max, sys, pc, now)?,
            Op::TcpSend {
                ret,
                sock,
                buf,
                n,
                timeout,
            } => match self.tcp_send(i, ret, sock, buf, n, timeout, sys, pc, now)? {
                Some(flow) => flow,
                // Refused for its size: the step is not charged.
                None => return Ok(Flow::Shared),
            },
            Op::TcpClose(ret, sock) => self.tcp_close(i, ret, sock, sys)?,
            Op::TcpStatus(ret, arrays) => self.tcp_status(i, ret, arrays, sys)?,
            Op::UdpSendTo(op) => self.udp_sendto(i, op, sys)?,
            Op::UdpRecvFrom(op) => self.udp_recvfrom(i, op, sys, pc, now)?,
            Op::Block(part, step) => self.block_step(i, *part, step, sys, pc, now)?,
            Op::OnError(program) => {
                self.tasks[i].error_program = *program;
                Flow::Next
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
            Err(Box::new(RuntimeError::RobotOnly(format!(
                "{what} is allowed only in robot programs"
            ))))
        }
    }

    pub(super) fn set_pc(&mut self, i: TaskSlot, pc: usize) {
        if let Some(f) = self.tasks[i].frames.last_mut() {
            f.pc = pc;
        }
    }
}
