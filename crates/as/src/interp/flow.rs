//! Control statements: `CASE`, `CALL`/`RETURN` with their arguments, `TWAIT`, `WAIT`.

use crate::compile::{CArg, CExpr, RExpr, SExpr, Ty};
use crate::system::System;
use crate::value::Bytes;

use super::arith::{ns, secs, truthy, Ns, R};
use super::on_error::Resume;
use super::task::{ArgVal, ArrayVal, ByRefTarget, Flow, TaskSlot, Wait};
use super::Interpreter;

impl Interpreter {
    /// `CASE x OF`: keeps the real selector.
    #[inline(always)]
    pub(super) fn case_select_r(
        &mut self,
        i: TaskSlot,
        e: &RExpr,
        slot: &u32,
        sys: &mut dyn System,
    ) -> R<Flow> {
        let v = self.eval_r(i, e, sys)?;
        self.set_hidden_r(i, *slot, v);
        Ok(Flow::Next)
    }

    /// `CASE $x OF`: keeps the string selector.
    #[inline(always)]
    pub(super) fn case_select_s(
        &mut self,
        i: TaskSlot,
        e: &SExpr,
        slot: &u32,
        sys: &mut dyn System,
    ) -> R<Flow> {
        let v = self.eval_s(i, e, sys)?;
        if let Some(x) = self.store(i, false).strs.get_mut(*slot as usize) {
            x.set(&[], v);
        }
        Ok(Flow::Next)
    }

    /// `VALUE a, b:` of a real `CASE`: jumps past the branch unless one matches.
    #[inline(always)]
    pub(super) fn case_test_r(
        &mut self,
        i: TaskSlot,
        values: &[RExpr],
        slot: &u32,
        next: &usize,
        sys: &mut dyn System,
    ) -> R<Flow> {
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
        Ok(Flow::Next)
    }

    /// `VALUE $a, $b:` of a string `CASE`: jumps past the branch unless one matches.
    #[inline(always)]
    pub(super) fn case_test_s(
        &mut self,
        i: TaskSlot,
        values: &[SExpr],
        slot: &u32,
        next: &usize,
        sys: &mut dyn System,
    ) -> R<Flow> {
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
        Ok(Flow::Next)
    }

    /// `CALL program(args)`: a new frame; the caller resumes after the CALL.
    #[inline(always)]
    pub(super) fn call(
        &mut self,
        i: TaskSlot,
        prog: &usize,
        args: &[CArg],
        sys: &mut dyn System,
    ) -> R<Flow> {
        let args = self.eval_args(i, args, sys)?;
        // The caller resumes after the CALL.
        self.push_frame(i, *prog, &args)?;
        Ok(Flow::Next)
    }

    /// `TWAIT t`: waits `t` seconds.
    #[inline(always)]
    pub(super) fn twait(
        &mut self,
        i: TaskSlot,
        e: &RExpr,
        sys: &mut dyn System,
        now: Ns,
    ) -> R<Flow> {
        let d = secs(self.eval_r(i, e, sys)?, "TWAIT")?;
        Ok(Flow::Wait(Box::new(Wait::Until(now.saturating_add(ns(d))))))
    }

    /// `WAIT condition`: polls the condition.
    #[inline(always)]
    pub(super) fn wait_until(
        &mut self,
        i: TaskSlot,
        e: &RExpr,
        sys: &mut dyn System,
        pc: usize,
    ) -> R<Flow> {
        Ok(if truthy(self.eval_r(i, e, sys)?) {
            Flow::Next
        } else {
            self.set_pc(i, pc);
            Flow::Wait(Box::new(Wait::Cond))
        })
    }

    pub(super) fn eval_args(
        &mut self,
        i: TaskSlot,
        args: &[CArg],
        sys: &mut dyn System,
    ) -> R<Vec<(ArgVal, Option<ByRefTarget>)>> {
        let mut out = Vec::with_capacity(args.len());
        for a in args {
            // A whole array: its every element goes in, and back on RETURN.
            if let (None, Some((ty, l))) = (&a.value, &a.var) {
                let frame = self.tasks[i].frames.len().saturating_sub(1);
                let v = ArrayVal::of(self.store(i, l.var.global), *ty, l.var.slot as usize)
                    .map_or(ArgVal::Undefined, ArgVal::Array);
                let target = ByRefTarget {
                    var: l.var,
                    idx: Vec::new(),
                    frame,
                    whole: true,
                };
                out.push((v, Some(target)));
                continue;
            }
            let v = match &a.value {
                Some(CExpr::R(e)) => self.eval_r(i, e, sys).map(ArgVal::R),
                Some(CExpr::S(e)) => self.eval_s(i, e, sys).map(ArgVal::S),
                Some(CExpr::J(e)) => self.eval_j(i, e, sys).map(ArgVal::J),
                Some(CExpr::T(e)) => self.eval_t(i, e, sys).map(ArgVal::T),
                None => Ok(ArgVal::Undefined),
            };
            // A variable may be given before it is defined: it receives the result.
            let v = match v {
                Err(e) if a.var.is_some() && e.is_undefined() => ArgVal::Undefined,
                v => v?,
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
                        whole: false,
                    })
                }
                None => None,
            };
            out.push((v, target));
        }
        Ok(out)
    }

    /// RETURN, RETURNE or `.END`: back to the caller, writing by-reference parameters back;
    /// `resume` says how a task goes on when this leaves its error program (`ONE`).
    pub(super) fn ret(&mut self, i: TaskSlot, resume: Resume, sys: &mut dyn System) -> R<()> {
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
            let val = if b.whole {
                ArrayVal::of(callee, b.ty, s).map(ArgVal::Array)
            } else {
                match b.ty {
                    Ty::Real => callee.reals[s].get(&[]).copied().map(ArgVal::R),
                    Ty::Str => callee.strs[s].get(&[]).cloned().map(ArgVal::S),
                    Ty::Joint => callee.joints[s].get(&[]).copied().map(ArgVal::J),
                    Ty::Trans => callee.trans[s].get(&[]).copied().map(ArgVal::T),
                }
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
                // A whole array: the caller's variable becomes the parameter's.
                ArgVal::Array(a) => {
                    let more = a.put(store, b.ty, slot).unwrap_or(0);
                    self.elements = self.elements.saturating_add_signed(more);
                    if self.elements > crate::value::MAX_ELEMENTS {
                        result = Err(Box::new(crate::error::RuntimeError::MemoryFull(
                            crate::value::MAX_ELEMENTS,
                        )));
                    }
                    false
                }
                ArgVal::R(v) => store.reals.get_mut(slot).is_some_and(|x| x.set(&b.idx, v)),
                ArgVal::S(v) => store.strs.get_mut(slot).is_some_and(|x| x.set(&b.idx, v)),
                ArgVal::J(v) => store.joints.get_mut(slot).is_some_and(|x| x.set(&b.idx, v)),
                ArgVal::T(v) => store.trans.get_mut(slot).is_some_and(|x| x.set(&b.idx, v)),
                ArgVal::Undefined => false,
            };
            if let Err(e) = self.count_element(created) {
                result = Err(e);
            }
        }
        // A CALL's caller resumes after its CALL (its pc moved when it executed it); an
        // `ON … CALL` returns to where the interrupt found the task.
        self.release(i, frame);
        self.after_return(i, self.tasks[i].frames.len(), resume, sys);
        result
    }
}
