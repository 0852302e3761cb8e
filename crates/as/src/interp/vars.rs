//! Variables: reading and writing reals, strings and locations, with their indices.

use crate::ast::BinOp;
use crate::compile::{var_display, LRef, RExpr, Ty, VarRef};
use crate::error::RuntimeError;
use crate::system::System;
use crate::value::{Bytes, Store, Var, MAX_ELEMENTS, MAX_INDEX};

use super::arith::{check, R};
use super::strings::{decode_cut, val};
use super::task::TaskSlot;
use super::Interpreter;
use super::MAX_STRING;

#[inline(always)]
pub(super) fn simple_leaf(globals: &Store, locals: &Store, e: &RExpr) -> Option<f32> {
    match e {
        RExpr::Const(c) => Some(*c),
        RExpr::Var(v) if v.idx.is_empty() => {
            let store = if v.var.global { globals } else { locals };
            store.reals.get(v.var.slot as usize)?.scalar
        }
        _ => None,
    }
}

/// An index that is a [`simple_leaf`] or the sum of two, finite and in range, truncated.
#[inline(always)]
pub(super) fn simple_index(globals: &Store, locals: &Store, e: &RExpr) -> Option<i32> {
    let v = match e {
        RExpr::Bin(BinOp::Add, a, b) => {
            let v = simple_leaf(globals, locals, a)? + simple_leaf(globals, locals, b)?;
            v.is_finite().then_some(v)?
        }
        _ => simple_leaf(globals, locals, e)?,
    };
    (v > -1.0 && v < (MAX_INDEX + 1) as f32).then_some(v as i32)
}

/// [`simple_index`] of each of up to three indices.
#[inline(always)]
pub(super) fn simple_index_list(g: &Store, s: &Store, idx: &[RExpr]) -> Option<[i32; 3]> {
    Some(match idx {
        [] => [0; 3],
        [a] => [simple_index(g, s, a)?, 0, 0],
        [a, b] => [simple_index(g, s, a)?, simple_index(g, s, b)?, 0],
        [a, b, c, ..] => [
            simple_index(g, s, a)?,
            simple_index(g, s, b)?,
            simple_index(g, s, c)?,
        ],
    })
}

impl Interpreter {
    pub(super) fn store(&mut self, i: TaskSlot, global: bool) -> &mut Store {
        if global {
            &mut self.globals
        } else {
            match self.tasks[i].frames.last_mut() {
                Some(f) => &mut f.locals,
                None => &mut self.globals,
            }
        }
    }

    pub(super) fn indices(&mut self, i: TaskSlot, l: &LRef, sys: &mut dyn System) -> R<[i32; 3]> {
        if let Some(out) = self.simple_indices(i, l) {
            return Ok(out);
        }
        let mut out = [0i32; 3];
        match &*l.idx {
            [] => {}
            [a] => out[0] = self.index(i, l, a, sys)?,
            [a, b] => {
                out[0] = self.index(i, l, a, sys)?;
                out[1] = self.index(i, l, b, sys)?;
            }
            [a, b, c, ..] => {
                out[0] = self.index(i, l, a, sys)?;
                out[1] = self.index(i, l, b, sys)?;
                out[2] = self.index(i, l, c, sys)?;
            }
        }
        Ok(out)
    }

    /// The indices of `l` when each is a constant, a defined real scalar or the sum of two
    /// such (`.i+1`), finite and in range, read with one lookup of the task's locals; `None`
    /// otherwise (then [`Self::indices`] evaluates them in full, with the same values or
    /// its errors: these reads change nothing).
    #[inline]
    pub(super) fn simple_indices(&self, i: TaskSlot, l: &LRef) -> Option<[i32; 3]> {
        let globals = &self.globals;
        let locals = match self.tasks.get(i.index())?.frames.last() {
            Some(f) => &f.locals,
            None => globals,
        };
        simple_index_list(globals, locals, &l.idx)
    }

    /// A real array element whose indices are [`Self::simple_indices`], when it exists
    /// (`None`: [`Self::read_r`] reads it in full, with its errors).
    #[inline]
    pub(super) fn simple_element_r(&self, i: TaskSlot, l: &LRef) -> Option<f32> {
        let globals = &self.globals;
        let locals = match self.tasks.get(i.index())?.frames.last() {
            Some(f) => &f.locals,
            None => globals,
        };
        let idx = simple_index_list(globals, locals, &l.idx)?;
        let store = if l.var.global { globals } else { locals };
        store
            .reals
            .get(l.var.slot as usize)?
            .get(&idx[..l.idx.len().min(3)])
            .copied()
    }

    /// One array index of `l`: 0 to [`MAX_INDEX`] after truncation.
    #[inline(always)]
    pub(super) fn index(
        &mut self,
        i: TaskSlot,
        l: &LRef,
        e: &RExpr,
        sys: &mut dyn System,
    ) -> R<i32> {
        // `.i+1`, the common computed index, is added here (as `eval_r` adds).
        let v = match e {
            RExpr::Bin(BinOp::Add, a, b) => {
                let x = self.operand_r(i, a, sys)?;
                let y = self.operand_r(i, b, sys)?;
                check(x + y, "+")?
            }
            _ => self.operand_r(i, e, sys)?,
        };
        // `0 <= trunc(v) <= MAX_INDEX` without a call of `truncf` (NaN fails both).
        if !(v > -1.0 && v < (MAX_INDEX + 1) as f32) {
            return Err(self.index_range(i, l, v));
        }
        Ok(v as i32)
    }

    #[cold]
    pub(super) fn index_range(&self, i: TaskSlot, l: &LRef, v: f32) -> Box<RuntimeError> {
        Box::new(RuntimeError::IndexRange(format!(
            "{} in {}",
            v,
            self.lref_name(i, l, Ty::Real)
        )))
    }

    pub(super) fn lref_name(&self, i: TaskSlot, l: &LRef, ty: Ty) -> String {
        let name = if l.var.global {
            self.code.global_name(ty, l.var.slot).to_owned()
        } else {
            self.tasks[i]
                .frames
                .last()
                .and_then(|f| self.code.programs.get(f.prog))
                .and_then(|p| p.local_names[ty as usize].get(l.var.slot as usize))
                .cloned()
                .unwrap_or_else(|| "?".into())
        };
        var_display(ty, l.var.global, &name)
    }

    pub(super) fn undefined(
        &self,
        i: TaskSlot,
        l: &LRef,
        ty: Ty,
        idx: &[i32],
    ) -> Box<RuntimeError> {
        let mut s = self.lref_name(i, l, ty);
        if !idx.is_empty() {
            let v: Vec<String> = idx.iter().map(|x| x.to_string()).collect();
            s.push_str(&format!("[{}]", v.join(",")));
        }
        Box::new(match ty {
            Ty::Real => RuntimeError::Undefined(s),
            Ty::Str => RuntimeError::StringUndefined(s),
            Ty::Joint | Ty::Trans => RuntimeError::LocationUndefined(s),
        })
    }

    pub(super) fn count_element(&mut self, created: bool) -> R<()> {
        if created {
            self.elements += 1;
            if self.elements > MAX_ELEMENTS {
                return Err(Box::new(RuntimeError::MemoryFull(MAX_ELEMENTS)));
            }
        }
        Ok(())
    }

    /// A real scalar's value; `None` when it was never assigned.
    #[inline]
    pub(super) fn scalar_r(&self, i: TaskSlot, var: VarRef) -> Option<f32> {
        let store = if var.global {
            &self.globals
        } else {
            match self.tasks[i].frames.last() {
                Some(f) => &f.locals,
                None => &self.globals,
            }
        };
        store.reals.get(var.slot as usize).and_then(|v| v.scalar)
    }

    /// A real operand: a constant or a scalar read in place (the common leaves of an
    /// expression and of array indices), anything else through the evaluator.
    #[inline(always)]
    pub(super) fn operand_r(&mut self, i: TaskSlot, e: &RExpr, sys: &mut dyn System) -> R<f32> {
        match e {
            RExpr::Const(v) => Ok(*v),
            RExpr::Var(l) if l.idx.is_empty() => match self.scalar_r(i, l.var) {
                Some(v) => Ok(v),
                None => Err(self.undefined(i, l, Ty::Real, &[])),
            },
            _ => self.eval_r(i, e, sys),
        }
    }

    /// A real variable or element (a scalar read in place).
    #[inline(always)]
    pub(super) fn operand_r_var(&mut self, i: TaskSlot, l: &LRef, sys: &mut dyn System) -> R<f32> {
        if l.idx.is_empty() {
            match self.scalar_r(i, l.var) {
                Some(v) => Ok(v),
                None => Err(self.undefined(i, l, Ty::Real, &[])),
            }
        } else {
            self.read_r(i, l, sys)
        }
    }

    pub(super) fn read_r(&mut self, i: TaskSlot, l: &LRef, sys: &mut dyn System) -> R<f32> {
        if l.idx.is_empty() {
            let slot = l.var.slot as usize;
            return match self
                .store(i, l.var.global)
                .reals
                .get(slot)
                .and_then(|v| v.scalar)
            {
                Some(v) => Ok(v),
                None => Err(self.undefined(i, l, Ty::Real, &[])),
            };
        }
        if let Some(v) = self.simple_element_r(i, l) {
            return Ok(v);
        }
        let n = l.idx.len().min(3);
        let idx = self.indices(i, l, sys)?;
        let slot = l.var.slot as usize;
        match self
            .store(i, l.var.global)
            .reals
            .get(slot)
            .and_then(|v| v.get(&idx[..n]))
        {
            Some(v) => Ok(*v),
            None => Err(self.undefined(i, l, Ty::Real, &idx[..n])),
        }
    }

    pub(super) fn write_r(&mut self, i: TaskSlot, l: &LRef, v: f32, sys: &mut dyn System) -> R<()> {
        if l.idx.is_empty() {
            if let Some(x) = self
                .store(i, l.var.global)
                .reals
                .get_mut(l.var.slot as usize)
            {
                x.scalar = Some(v);
            }
            return Ok(());
        }
        let n = l.idx.len().min(3);
        let idx = match self.simple_indices(i, l) {
            Some(idx) => idx,
            None => self.indices(i, l, sys)?,
        };
        self.write_r_at(i, l.var, &idx[..n], v)
    }

    #[inline]
    pub(super) fn write_r_at(&mut self, i: TaskSlot, var: VarRef, idx: &[i32], v: f32) -> R<()> {
        let created = match self.store(i, var.global).reals.get_mut(var.slot as usize) {
            Some(x) => x.set(idx, v),
            None => false,
        };
        self.count_element(created)
    }

    /// `dst = $DECODE(src, d, mode)` for string scalars, constant delimiters and mode: what
    /// [`Self::eval_s`] and [`Self::write_s`] do (the rest is written to `src` first, then
    /// the token to `dst`; the same errors), without copies of the string's handle.
    pub(super) fn decode_scalar(
        &mut self,
        i: TaskSlot,
        dst: &LRef,
        src: &LRef,
        d: &[u8],
        mode: f32,
    ) -> R<()> {
        let store = self.store(i, src.var.global);
        let Some(var) = store.strs.get_mut(src.var.slot as usize) else {
            return Err(self.undefined(i, src, Ty::Str, &[]));
        };
        let Some(s) = &var.scalar else {
            return Err(self.undefined(i, src, Ty::Str, &[]));
        };
        let text: &[u8] = s;
        let cut = decode_cut(text, d, mode).min(text.len());
        if text.len() - cut > MAX_STRING {
            return Err(Box::new(RuntimeError::StringTooLong(text.len() - cut)));
        }
        let Some(s) = var.scalar.take() else {
            return Err(self.undefined(i, src, Ty::Str, &[]));
        };
        let (head, rest) = s.split_off_head(cut);
        var.scalar = Some(rest);
        if head.len() > MAX_STRING {
            return Err(Box::new(RuntimeError::StringTooLong(head.len())));
        }
        // The token's variable, in the same scope (the usual case) without a second lookup.
        let strs = if dst.var.global == src.var.global {
            &mut store.strs
        } else {
            &mut self.store(i, dst.var.global).strs
        };
        if let Some(x) = strs.get_mut(dst.var.slot as usize) {
            x.scalar = Some(head);
        }
        Ok(())
    }

    pub(super) fn read_s(&mut self, i: TaskSlot, l: &LRef, sys: &mut dyn System) -> R<Bytes> {
        if l.idx.is_empty() {
            let slot = l.var.slot as usize;
            return match self
                .store(i, l.var.global)
                .strs
                .get(slot)
                .and_then(|v| v.scalar.clone())
            {
                Some(v) => Ok(v),
                None => Err(self.undefined(i, l, Ty::Str, &[])),
            };
        }
        let n = l.idx.len().min(3);
        let idx = self.indices(i, l, sys)?;
        let slot = l.var.slot as usize;
        match self
            .store(i, l.var.global)
            .strs
            .get(slot)
            .and_then(|v| v.get(&idx[..n]))
        {
            Some(v) => Ok(v.clone()),
            None => Err(self.undefined(i, l, Ty::Str, &idx[..n])),
        }
    }

    /// The bytes of `n` consecutive string elements from `buf` on (`$buf[i]`, `$buf[i+1]`, …),
    /// joined; it stops once more than `limit` bytes are gathered (the caller refuses those).
    /// An element never assigned is the AS error "variable not defined".
    pub(super) fn string_elements(
        &mut self,
        i: TaskSlot,
        buf: &LRef,
        n: i32,
        limit: usize,
        sys: &mut dyn System,
    ) -> R<Vec<u8>> {
        let dims = buf.idx.len().clamp(1, 3);
        let base = self.indices(i, buf, sys)?;
        let mut data = Vec::new();
        for k in 0..n {
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
            if data.len() > limit {
                break;
            }
        }
        Ok(data)
    }

    /// Writes `bytes` into consecutive string elements from `buf` on, at most `max` bytes each
    /// and at most [`super::MAX_TRANSFER`] elements, stopping at the last index: how
    /// `TCP_RECV` and `UDP_RECVFROM` fill their arrays. The number of elements written.
    pub(super) fn split_into_elements(
        &mut self,
        i: TaskSlot,
        buf: &LRef,
        bytes: &[u8],
        max: usize,
        sys: &mut dyn System,
    ) -> R<usize> {
        let dims = buf.idx.len().clamp(1, 3);
        let base = self.indices(i, buf, sys)?;
        let mut n = 0;
        for (k, chunk) in (bytes.chunks(max.max(1)).take(super::MAX_TRANSFER)).enumerate() {
            let mut at = base;
            at[0] += k as i32;
            if at[0] > MAX_INDEX {
                break;
            }
            self.write_s_at(i, buf.var, &at[..dims], Bytes::from(chunk))?;
            n += 1;
        }
        Ok(n)
    }

    pub(super) fn write_s_at(&mut self, i: TaskSlot, var: VarRef, idx: &[i32], v: Bytes) -> R<()> {
        if v.len() > MAX_STRING {
            return Err(Box::new(RuntimeError::StringTooLong(v.len())));
        }
        let created = match self.store(i, var.global).strs.get_mut(var.slot as usize) {
            Some(x) => x.set(idx, v),
            None => false,
        };
        self.count_element(created)
    }

    pub(super) fn write_s(
        &mut self,
        i: TaskSlot,
        l: &LRef,
        v: Bytes,
        sys: &mut dyn System,
    ) -> R<()> {
        if l.idx.is_empty() {
            if v.len() > MAX_STRING {
                return Err(Box::new(RuntimeError::StringTooLong(v.len())));
            }
            if let Some(x) = self
                .store(i, l.var.global)
                .strs
                .get_mut(l.var.slot as usize)
            {
                x.scalar = Some(v);
            }
            return Ok(());
        }
        let n = l.idx.len().min(3);
        let idx = self.indices(i, l, sys)?;
        self.write_s_at(i, l.var, &idx[..n], v)
    }

    pub(super) fn read_loc_var(
        &mut self,
        i: TaskSlot,
        l: &LRef,
        ty: Ty,
        sys: &mut dyn System,
    ) -> R<[f32; 6]> {
        let n = l.idx.len().min(3);
        let idx = self.indices(i, l, sys)?;
        let slot = l.var.slot as usize;
        let store = self.store(i, l.var.global);
        let v = if ty == Ty::Joint {
            store
                .joints
                .get(slot)
                .and_then(|v| v.get(&idx[..n]))
                .copied()
        } else {
            store
                .trans
                .get(slot)
                .and_then(|v| v.get(&idx[..n]))
                .copied()
        };
        v.ok_or_else(|| self.undefined(i, l, ty, &idx[..n]))
    }

    pub(super) fn write_loc_var(
        &mut self,
        i: TaskSlot,
        l: &LRef,
        ty: Ty,
        v: [f32; 6],
        sys: &mut dyn System,
    ) -> R<()> {
        let n = l.idx.len().min(3);
        let idx = self.indices(i, l, sys)?;
        let slot = l.var.slot as usize;
        let store = self.store(i, l.var.global);
        let created = if ty == Ty::Joint {
            store
                .joints
                .get_mut(slot)
                .is_some_and(|x| x.set(&idx[..n], v))
        } else {
            store
                .trans
                .get_mut(slot)
                .is_some_and(|x| x.set(&idx[..n], v))
        };
        self.count_element(created)
    }

    /// `VAL` of a string scalar, read in place.
    pub(super) fn val_scalar(&self, i: TaskSlot, l: &LRef) -> R<f32> {
        let store = if l.var.global {
            &self.globals
        } else {
            match self.tasks[i].frames.last() {
                Some(f) => &f.locals,
                None => &self.globals,
            }
        };
        match store.strs.get(l.var.slot as usize) {
            Some(Var {
                scalar: Some(b), ..
            }) => val(b, 0.0),
            _ => Err(self.undefined(i, l, Ty::Str, &[])),
        }
    }

    pub(super) fn hidden_r(&mut self, i: TaskSlot, slot: u32) -> f32 {
        let s = slot as usize;
        self.store(i, false)
            .reals
            .get(s)
            .and_then(|v| v.scalar)
            .unwrap_or(0.0)
    }

    pub(super) fn set_hidden_r(&mut self, i: TaskSlot, slot: u32, v: f32) {
        if let Some(x) = self.store(i, false).reals.get_mut(slot as usize) {
            x.scalar = Some(v);
        }
    }
}
