//! Starting and ending programs: `start`, `EXECUTE`, `PCEXECUTE`, frames.

use crate::compile::{var_display, Ty};
use crate::error::RuntimeError;
use crate::system::{System, TaskId};
use crate::value::Store;

use super::arith::R;
use super::report::{p_code, Refusal, TaskState};
use super::task::{ArgVal, ByRef, ByRefTarget, Frame, MotionParams, Run, TaskSlot};
use super::Interpreter;

impl Interpreter {
    /// Controller start: runs `autostart.pc` in PC task 1 and `autostart2.pc` …
    /// `autostart5.pc` in PC tasks 2–5, those that are loaded.
    pub fn start(&mut self, sys: &mut dyn System) {
        for n in 1..=5u8 {
            let name = if n == 1 {
                "autostart.pc".to_owned()
            } else {
                format!("autostart{n}.pc")
            };
            if let Some(p) = self.code.defined(&name) {
                self.start_task(TaskSlot::at(usize::from(n)), p, &[], 1);
                self.message(sys, TaskId::Pc(n), format!("{name} started in PC task {n}"));
            }
        }
    }

    /// `EXECUTE program` from outside (the pendant): starts it in robot task 1, with the
    /// controller's checks, for one cycle.
    pub fn execute(&mut self, program: &str, sys: &mut dyn System) -> Result<(), Refusal> {
        self.execute_cycles(program, 1, sys)
    }

    /// `EXECUTE program, cycles`: as [`Interpreter::execute`], the program run `cycles` times
    /// (0 counts as 1; a negative count runs it until it is aborted).
    pub fn execute_cycles(
        &mut self,
        program: &str,
        cycles: i64,
        sys: &mut dyn System,
    ) -> Result<(), Refusal> {
        let p = self.program_named(program)?;
        self.execute_robot(p, Vec::new(), cycles, sys)
    }

    /// `PCEXECUTE n: program` from outside, for one cycle.
    pub fn pc_execute(&mut self, task: u8, program: &str) -> Result<(), Refusal> {
        self.pc_execute_cycles(task, program, 1)
    }

    /// `PCEXECUTE n: program, cycles`: the program run `cycles` times in PC task `n` (0 counts
    /// as 1; a negative count, the usual `-1`, runs it until `PCABORT`).
    pub fn pc_execute_cycles(
        &mut self,
        task: u8,
        program: &str,
        cycles: i64,
    ) -> Result<(), Refusal> {
        let p = self.program_named(program)?;
        self.pc_execute_at(task, p, Vec::new(), cycles)
    }

    /// A task's cycle counts as `PCSTATUS`/`STATUS` show them: `(completed, remaining)`, the
    /// remaining count negative for a task started to run for ever. `(0, 0)` for a task never
    /// started.
    pub fn cycles(&self, task: TaskId) -> (u32, i64) {
        let t = &self.tasks[TaskSlot::of(task)];
        let remaining = if t.run == Run::Idle { 0 } else { t.cycles_left };
        (t.cycles_done, remaining)
    }

    /// The index of the program called `program`, or the refusal naming it.
    fn program_named(&self, program: &str) -> Result<usize, Refusal> {
        (self.code.defined(program)).ok_or_else(|| Refusal::NoProgram(program.to_owned()))
    }

    /// Stops a task at once (`ABORT`/`PCABORT` from outside, a panel switch that stops the
    /// robot program). The robot's motion is the system's business.
    pub fn abort(&mut self, task: TaskId) {
        let i = TaskSlot::of(task);
        if i.is_robot() && self.tasks[i].run != Run::Idle {
            if !self.run_mask.is_empty() {
                self.apply_run_mask();
            }
            // An OPEN/CLOSE/RELAX left for a motion that never came is dropped.
            self.hand_pending.clear();
            // So is a C1MOVE point without its C2MOVE.
            self.circle_via = None;
        }
        self.release_frames(i, 0);
        self.set_run(i, Run::Idle);
        let t = &mut self.tasks[i];
        t.wait = None;
        t.interrupts.clear();
        t.pending_on = None;
        t.error_depth = None;
        self.int_epoch += 1;
    }

    pub(super) fn new_locals(&mut self, task: TaskSlot, prog: usize) -> Store {
        if self.cfg.persistent_locals {
            if let Some(s) = self.kept.remove(&(task, prog)) {
                return s;
            }
        }
        Store::with_sizes(self.code.programs[prog].locals)
    }

    /// Pops task `i`'s frames down to `keep`, releasing their locals.
    pub(super) fn release_frames(&mut self, i: TaskSlot, keep: usize) {
        while self.tasks[i].frames.len() > keep {
            let Some(f) = self.tasks[i].frames.pop() else {
                break;
            };
            self.release(i, f);
        }
    }

    pub(super) fn release(&mut self, i: TaskSlot, f: Frame) {
        if self.cfg.persistent_locals {
            self.kept.insert((i, f.prog), f.locals);
        } else {
            self.elements = self.elements.saturating_sub(f.locals.element_count());
        }
    }

    /// Arguments evaluated in the caller: values, and for by-reference parameters where the
    /// value goes back.
    pub(super) fn push_frame(
        &mut self,
        i: TaskSlot,
        prog: usize,
        args: &[(ArgVal, Option<ByRefTarget>)],
    ) -> R<()> {
        if self.tasks[i].frames.len() >= self.cfg.max_call_depth {
            return Err(Box::new(RuntimeError::CallDepth(self.cfg.max_call_depth)));
        }
        let code = self.code.clone();
        let p = &code.programs[prog];
        if !p.defined {
            return Err(Box::new(RuntimeError::NoProgram(p.name.clone())));
        }
        let mut store = self.new_locals(i, prog);
        let mut byref = Vec::new();
        for (k, param) in p.params.iter().enumerate() {
            let Some((val, target)) = args.get(k) else {
                continue;
            };
            let store = &mut store;
            let s = param.slot as usize;
            match (param.ty, val) {
                (Ty::Real, ArgVal::R(v)) => {
                    store.reals[s].set(&[], *v);
                }
                (Ty::Str, ArgVal::S(v)) => {
                    store.strs[s].set(&[], v.clone());
                }
                (Ty::Joint, ArgVal::J(v)) => {
                    store.joints[s].set(&[], *v);
                }
                (Ty::Trans, ArgVal::T(v)) => {
                    store.trans[s].set(&[], *v);
                }
                // A variable not yet defined: the parameter starts undefined, and the
                // variable receives its final value.
                (_, ArgVal::Undefined) => {}
                // A whole array: the parameter holds its every element (counted in the
                // variable memory, as the frame's locals are).
                (ty, ArgVal::Array(a)) if a.fits(ty) => {
                    let more = a.clone().put(store, ty, s).unwrap_or(0);
                    self.elements = self.elements.saturating_add_signed(more);
                    if self.elements > crate::value::MAX_ELEMENTS {
                        return Err(Box::new(RuntimeError::MemoryFull(
                            crate::value::MAX_ELEMENTS,
                        )));
                    }
                }
                _ => {
                    return Err(Box::new(RuntimeError::IllegalValue(format!(
                        "argument {} of {} has the wrong type for parameter {}",
                        k + 1,
                        p.name,
                        var_display(param.ty, false, &p.local_names[param.ty as usize][s])
                    ))))
                }
            }
            // Every argument that is a variable receives the parameter's final value when the
            // subroutine returns (AS-E p.4-12, example 1: `CALL calc(a,b,c)` sets `c`).
            if let Some(t) = target {
                byref.push(ByRef {
                    ty: param.ty,
                    param: param.slot,
                    var: t.var,
                    idx: t.idx.clone(),
                    frame: t.frame,
                    whole: t.whole,
                });
            }
        }
        self.tasks[i].frames.push(Frame {
            prog,
            pc: 0,
            locals: store,
            byref,
        });
        Ok(())
    }

    pub(super) fn start_task(
        &mut self,
        i: TaskSlot,
        prog: usize,
        args: &[(ArgVal, Option<ByRefTarget>)],
        cycles: i64,
    ) -> bool {
        let now = self.now;
        self.release_frames(i, 0);
        self.set_run(i, Run::Running);
        {
            let t = &mut self.tasks[i];
            t.wait = None;
            t.kick = false;
            t.interrupts.clear();
            t.pending_on = None;
            t.ready_at = now;
            t.cycles_left = if cycles == 0 { 1 } else { cycles };
            t.cycles_done = 0;
            t.end_after_cycle = false;
            t.motion = MotionParams::default();
            t.last_error = None;
            t.line_buf.clear();
            t.error_program = None;
            t.error_depth = None;
        }
        self.int_epoch += 1;
        match self.push_frame(i, prog, args) {
            Ok(()) => true,
            Err(_) => {
                self.set_run(i, Run::Idle);
                false
            }
        }
    }

    pub(super) fn execute_robot(
        &mut self,
        prog: usize,
        args: Vec<(ArgVal, Option<ByRefTarget>)>,
        cycles: i64,
        sys: &mut dyn System,
    ) -> Result<(), Refusal> {
        let panel = sys.panel();
        if !panel.power {
            return Err(p_code(-11000, "Motor power OFF, cannot execute program."));
        }
        if !panel.repeat {
            return Err(p_code(-11001, "Cannot execute program in TEACH mode."));
        }
        if panel.teach_lock {
            return Err(p_code(-11002, "Teach lock ON, cannot execute program."));
        }
        if !sys.error().is_none() {
            return Err(p_code(
                -11013,
                "In error, cannot execute program. Reset the error first.",
            ));
        }
        if self.task_state(TaskId::Robot, sys) != TaskState::Idle {
            return Err(p_code(-11009, "Program is already running."));
        }
        self.mc_hold = false;
        if self.start_task(TaskSlot::ROBOT, prog, &args, cycles) {
            Ok(())
        } else {
            Err(Refusal::Other(
                "the program could not start (argument types)".into(),
            ))
        }
    }

    pub(super) fn pc_execute_at(
        &mut self,
        task: u8,
        prog: usize,
        args: Vec<(ArgVal, Option<ByRefTarget>)>,
        cycles: i64,
    ) -> Result<(), Refusal> {
        if !(1..=5).contains(&task) {
            return Err(Refusal::Other(format!(
                "PC task {task} does not exist (1 to 5)"
            )));
        }
        if self.tasks[TaskSlot::at(usize::from(task))].run != Run::Idle {
            return Err(Refusal::Other(format!("PC task {task} is already running")));
        }
        if self.start_task(TaskSlot::at(usize::from(task)), prog, &args, cycles) {
            Ok(())
        } else {
            Err(Refusal::Other(
                "the program could not start (argument types)".into(),
            ))
        }
    }

    /// The program of task `i` ended (`.END` or `RETURN` of its first program, `HALT`).
    /// A robot program whose last motion still runs is "finishing" (TASK(1) = 3): its
    /// interrupts stay armed until the motion is done.
    pub(super) fn end_program(&mut self, i: TaskSlot, sys: &mut dyn System, repeat: bool) {
        let t = &mut self.tasks[i];
        if repeat {
            t.cycles_done = t.cycles_done.saturating_add(1);
        }
        if repeat && t.cycles_left != 1 && !t.end_after_cycle {
            if t.cycles_left > 1 {
                t.cycles_left -= 1;
            }
            self.release_frames(i, 1);
            if let Some(f) = self.tasks[i].frames.first_mut() {
                f.pc = 0;
            }
            return;
        }
        if i.is_robot() && sys.motion_in_progress() {
            self.release_frames(i, 1);
            let at = self.next_tick(self.now);
            self.set_run(TaskSlot::ROBOT, Run::Ending);
            let t = &mut self.tasks[TaskSlot::ROBOT];
            t.wait = None;
            t.pending_on = None;
            t.poll_at = at;
            return;
        }
        let id = self.tasks[i].id;
        self.abort(id);
    }
}
