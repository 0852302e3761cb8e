//! Expressions: reals, strings, locations, functions and `PRINT` encoding.

use fs020n_kin::{Pose, Xyzoat};
use fs020n_proto::format as fmt;
use fs020n_proto::ErrorCode;

use crate::ast::{BinOp, FormatCode};
use crate::compile::{Item, JExpr, Loc, RExpr, RFunc, SExpr, SwitchRef, TExpr, Ty};
use crate::error::{error_message, RuntimeError};
use crate::system::{System, TaskId};
use crate::value::Bytes;

use super::arith::{as_bool, bin_r, check, signal_number, to_i32, truthy, R};
use super::strings::{decode_cut, instr, val};
use super::task::{LocVal, Run, TaskSlot};
use super::Interpreter;
use super::MAX_STRING;

impl Interpreter {
    /// [`Self::eval_r`] with a binary operation on constants and scalars in place (the
    /// usual statement: `.i == 1`, `.n = .n + 1`).
    #[inline(always)]
    pub(super) fn eval_r_top(&mut self, i: TaskSlot, e: &RExpr, sys: &mut dyn System) -> R<f32> {
        match e {
            RExpr::Bin(op, a, b) => {
                let x = self.operand_r(i, a, sys)?;
                let y = self.operand_r(i, b, sys)?;
                bin_r(*op, x, y)
            }
            RExpr::Var(l) if !l.idx.is_empty() => match self.simple_element_r(i, l) {
                Some(v) => Ok(v),
                None => self.eval_r(i, e, sys),
            },
            _ => self.operand_r(i, e, sys),
        }
    }

    /// A real expression: constants, variables and arithmetic here (a small function), the
    /// rest in [`Self::eval_r_other`].
    pub(super) fn eval_r(&mut self, i: TaskSlot, e: &RExpr, sys: &mut dyn System) -> R<f32> {
        match e {
            RExpr::Const(v) => Ok(*v),
            RExpr::Var(l) => self.operand_r_var(i, l, sys),
            RExpr::Bin(op, a, b) => {
                let x = self.operand_r(i, a, sys)?;
                // AND/OR evaluate both sides (AS has no short circuit).
                let y = self.operand_r(i, b, sys)?;
                bin_r(*op, x, y)
            }
            RExpr::Val(s, None) => match &**s {
                SExpr::Var(l) if l.idx.is_empty() => self.val_scalar(i, l),
                _ => self.eval_r_other(i, e, sys),
            },
            _ => self.eval_r_other(i, e, sys),
        }
    }

    #[inline(never)]
    pub(super) fn eval_r_other(&mut self, i: TaskSlot, e: &RExpr, sys: &mut dyn System) -> R<f32> {
        Ok(match e {
            RExpr::Const(_) | RExpr::Var(_) | RExpr::Bin(..) => self.eval_r(i, e, sys)?,
            RExpr::Neg(a) => -self.eval_r(i, a, sys)?,
            RExpr::Not(a) => as_bool(!truthy(self.eval_r(i, a, sys)?)),
            RExpr::Com(a) => !to_i32(self.eval_r(i, a, sys)?) as f32,
            RExpr::StrCmp(op, a, b) => {
                let x = self.eval_s(i, a, sys)?;
                let y = self.eval_s(i, b, sys)?;
                let o = (*x).cmp(&*y);
                as_bool(match op {
                    BinOp::Eq => o.is_eq(),
                    BinOp::Ne => o.is_ne(),
                    BinOp::Lt => o.is_lt(),
                    BinOp::Gt => o.is_gt(),
                    BinOp::Le => o.is_le(),
                    _ => o.is_ge(),
                })
            }
            RExpr::Func(f, args) => self.eval_func(i, *f, args, sys)?,
            RExpr::Val(s, radix) => {
                // VAL of a string scalar (the server's tokens) reads it in place.
                if let (SExpr::Var(l), None) = (&**s, radix) {
                    if l.idx.is_empty() {
                        return self.val_scalar(i, l);
                    }
                }
                let s = self.eval_s(i, s, sys)?;
                let radix = match radix {
                    Some(r) => self.eval_r(i, r, sys)?,
                    None => 0.0,
                };
                val(&s, radix)?
            }
            RExpr::Len(s) => self.eval_s(i, s, sys)?.len() as f32,
            RExpr::Asc(s, n) => {
                let s = self.eval_s(i, s, sys)?;
                let n = match n {
                    Some(n) => self.eval_r(i, n, sys)?.trunc() as i64,
                    None => 1,
                };
                if n >= 1 && (n as usize) <= s.len() {
                    f32::from(s[n as usize - 1])
                } else {
                    -1.0
                }
            }
            RExpr::Instr(start, s, sub) => {
                let start = match start {
                    Some(x) => self.eval_r(i, x, sys)?.trunc().max(1.0) as usize,
                    None => 1,
                };
                let s = self.eval_s(i, s, sys)?;
                let sub = self.eval_s(i, sub, sys)?;
                instr(&s, &sub, start) as f32
            }
            RExpr::Dext(l, n) => {
                let v = match self.eval_loc(i, l, sys)? {
                    LocVal::J(v) | LocVal::T(v) => v,
                };
                let n = self.eval_r(i, n, sys)?.trunc();
                if !(1.0..=6.0).contains(&n) {
                    return Err(Box::new(RuntimeError::IllegalValue(format!(
                        "DEXT element {n} (1 to 6)"
                    ))));
                }
                v[n as usize - 1]
            }
            RExpr::Switch(s) => {
                let p = sys.panel();
                as_bool(match s {
                    SwitchRef::Power => p.power,
                    SwitchRef::Run => p.run,
                    SwitchRef::Repeat => p.repeat,
                    SwitchRef::TeachLock => p.teach_lock,
                    SwitchRef::CycleStart => self.tasks[TaskSlot::ROBOT].run == Run::Running,
                    SwitchRef::InError => !sys.error().is_none(),
                    SwitchRef::EmergencyStop => false,
                    SwitchRef::System(k) => self.switches.get(*k).copied().unwrap_or(false),
                })
            }
            RExpr::Error => sys.error().raw() as f32,
            RExpr::SysData(d, None) => self.sysdata(i, *d, sys),
            RExpr::SysData(d, Some(robot)) => {
                if self.eval_r(i, robot, sys)?.trunc() == 1.0 {
                    self.sysdata(i, *d, sys)
                } else {
                    -1.0
                }
            }
            RExpr::Loc(f, t) => self.eval_loc_fn(i, *f, t, sys)?,
            RExpr::Exist(kind, name) => {
                let name = self.eval_s(i, name, sys)?;
                self.exists(*kind, &name)
            }
            RExpr::WhichTask(name) => {
                let name = self.eval_s(i, name, sys)?;
                self.which_task(&name)
            }
            RExpr::NamedReal(name) => {
                let name = self.eval_s(i, name, sys)?;
                self.named_real(&name)?
            }
            RExpr::ArrayIndex(max, name, dim) => {
                let name = self.eval_s(i, name, sys)?;
                let dim = match dim {
                    Some(d) => self.eval_r(i, d, sys)?.trunc(),
                    None => 1.0,
                };
                if !(1.0..=3.0).contains(&dim) {
                    return Err(Box::new(RuntimeError::IllegalValue(format!(
                        "dimension {dim} (1 to 3)"
                    ))));
                }
                self.array_index(*max, &name, dim as usize)
            }
        })
    }

    pub(super) fn eval_func(
        &mut self,
        i: TaskSlot,
        f: RFunc,
        args: &[RExpr],
        sys: &mut dyn System,
    ) -> R<f32> {
        let mut v = [0f32; 32];
        let n = args.len().min(32);
        for (k, a) in args.iter().enumerate().take(32) {
            v[k] = self.eval_r(i, a, sys)?;
        }
        let x = v[0];
        Ok(match f {
            RFunc::Abs => x.abs(),
            RFunc::Sqrt => {
                if x < 0.0 {
                    return Err(Box::new(RuntimeError::SqrtNegative(format!("SQRT({x})"))));
                }
                x.sqrt()
            }
            RFunc::Sin => (f64::from(x).to_radians().sin()) as f32,
            RFunc::Cos => (f64::from(x).to_radians().cos()) as f32,
            RFunc::Tan => check(f64::from(x).to_radians().tan() as f32, "TAN")?,
            RFunc::Atan2 => (f64::from(x).atan2(f64::from(v[1])).to_degrees()) as f32,
            RFunc::Int => x.trunc(),
            RFunc::MaxVal => v[..n].iter().copied().fold(f32::NEG_INFINITY, f32::max),
            RFunc::MinVal => v[..n].iter().copied().fold(f32::INFINITY, f32::min),
            RFunc::Sig => {
                let mut all = true;
                for s in &v[..n] {
                    let s = signal_number(*s);
                    if s == 0 || !Self::signal_number_ok(s, false) {
                        return Err(Box::new(RuntimeError::IllegalValue(format!(
                            "signal number {s}"
                        ))));
                    }
                    all &= self.signal(s.abs()) == (s > 0);
                }
                as_bool(all)
            }
            RFunc::Bits => self.bits_in(x, v[1], 16)?,
            RFunc::Bits32 => self.bits_in(x, v[1], 32)?,
            RFunc::Task => {
                let id = match x.trunc() as i64 {
                    1 => Some(TaskId::Robot),
                    n @ 1001..=1005 => Some(TaskId::Pc((n - 1000) as u8)),
                    _ => None,
                };
                match id {
                    Some(id) => {
                        if id == TaskId::Robot
                            && self.tasks[TaskSlot::ROBOT].run == Run::Ending
                            && !sys.motion_in_progress()
                        {
                            if !self.run_mask.is_empty() {
                                self.apply_run_mask();
                            }
                            self.set_run(TaskSlot::ROBOT, Run::Idle);
                        }
                        self.task_state(id, sys).number()
                    }
                    None => 0.0,
                }
            }
            // Half away from zero (our choice; the manuals say "nearest integer").
            RFunc::Round => x.round(),
            RFunc::UTimer => super::clock::utimer_value(self.now, x),
            RFunc::Timer => {
                let n = x.trunc();
                if !(0.0..=10.0).contains(&n) {
                    return Err(Box::new(RuntimeError::IllegalValue(format!(
                        "TIMER({x}) (0 to 10)"
                    ))));
                }
                let since = if n == 0.0 {
                    Some(0)
                } else {
                    self.timers[n as usize]
                };
                match since {
                    Some(s) => {
                        // 1 ms resolution, truncated.
                        let ms = (i128::from(self.now) - s).div_euclid(1_000_000);
                        (ms as f64 / 1000.0) as f32
                    }
                    None => 0.0,
                }
            }
        })
    }

    pub(super) fn eval_s(&mut self, i: TaskSlot, e: &SExpr, sys: &mut dyn System) -> R<Bytes> {
        Ok(match e {
            SExpr::Const(b) => b.clone(),
            SExpr::Var(l) => self.read_s(i, l, sys)?,
            SExpr::Concat(a, b) => {
                let x = self.eval_s(i, a, sys)?;
                let y = self.eval_s(i, b, sys)?;
                if x.len() + y.len() > MAX_STRING {
                    return Err(Box::new(RuntimeError::StringTooLong(x.len() + y.len())));
                }
                let mut v = Vec::with_capacity(x.len() + y.len());
                v.extend_from_slice(&x);
                v.extend_from_slice(&y);
                v.into()
            }
            SExpr::Mid(s, start, n) => {
                let s = self.eval_s(i, s, sys)?;
                let start = self.eval_r(i, start, sys)?.trunc();
                let n = match n {
                    Some(n) => Some(self.eval_r(i, n, sys)?.trunc()),
                    None => None,
                };
                if start < 1.0 || n.is_some_and(|n| n < 0.0) {
                    return Err(Box::new(RuntimeError::IllegalValue(format!(
                        "$MID start {start} (from 1), count {}",
                        n.unwrap_or(0.0)
                    ))));
                }
                let a = (start as usize - 1).min(s.len());
                let b = match n {
                    Some(n) => a.saturating_add(n as usize).min(s.len()),
                    None => s.len(),
                };
                s.slice(a, b)
            }
            SExpr::Left(s, n) | SExpr::Right(s, n) => {
                let s = self.eval_s(i, s, sys)?;
                let n = self.eval_r(i, n, sys)?.trunc();
                if n < 0.0 {
                    return Err(Box::new(RuntimeError::IllegalValue(format!("count {n}"))));
                }
                let n = (n as usize).min(s.len());
                if matches!(e, SExpr::Left(..)) {
                    s.slice(0, n)
                } else {
                    s.slice(s.len() - n, s.len())
                }
            }
            SExpr::Space(n) => {
                let n = self.eval_r(i, n, sys)?.trunc();
                if !(0.0..=MAX_STRING as f32).contains(&n) {
                    return Err(Box::new(RuntimeError::IllegalValue(format!(
                        "$SPACE({n}) (0 to {MAX_STRING})"
                    ))));
                }
                Bytes::from(vec![b' '; n as usize].as_slice())
            }
            SExpr::Chr(n) => {
                let n = self.eval_r(i, n, sys)?.trunc();
                if !(0.0..=255.0).contains(&n) {
                    return Err(Box::new(RuntimeError::IllegalValue(format!(
                        "$CHR({n}) (0 to 255)"
                    ))));
                }
                Bytes::from(&[n as u8][..])
            }
            SExpr::Encode(items) => {
                let (bytes, _) = self.encode(i, items, sys)?;
                if bytes.len() > MAX_STRING {
                    return Err(Box::new(RuntimeError::StringTooLong(bytes.len())));
                }
                bytes.into()
            }
            SExpr::Decode(var, delims, mode) => {
                let s = self.read_s(i, var, sys)?;
                // Constant delimiters (the usual case) are used in place.
                let evaluated;
                let d: &[u8] = match &**delims {
                    SExpr::Const(b) => b,
                    other => {
                        evaluated = self.eval_s(i, other, sys)?;
                        &evaluated
                    }
                };
                let mode = self.eval_r(i, mode, sys)?;
                let cut = decode_cut(&s, d, mode);
                let (head, rest) = s.split_off_head(cut);
                self.write_s(i, var, rest, sys)?;
                head
            }
            SExpr::Time => Bytes::from(self.time_text().as_bytes()),
            SExpr::Date(form) => {
                let form = self.eval_r(i, form, sys)?;
                Bytes::from(self.date_text(form)?.as_bytes())
            }
            SExpr::RobotName => Bytes::from(&b"FS020N"[..]),
            SExpr::ErrorMsg(code) => {
                let c = self.eval_r(i, code, sys)?.trunc() as i32;
                let text = match error_message(c) {
                    Some(m) => m.to_owned(),
                    None if c == 0 => String::new(),
                    None => format!("Error {}", ErrorCode(c)),
                };
                Bytes::from(text.as_bytes())
            }
        })
    }

    pub(super) fn eval_loc(&mut self, i: TaskSlot, l: &Loc, sys: &mut dyn System) -> R<LocVal> {
        Ok(match l {
            Loc::J(j) => LocVal::J(self.eval_j(i, j, sys)?),
            Loc::T(t) => LocVal::T(self.eval_t(i, t, sys)?),
            Loc::Named(s) => {
                let name = self.eval_s(i, s, sys)?;
                self.named_pose(&name)?
            }
        })
    }

    pub(super) fn eval_j(&mut self, i: TaskSlot, e: &JExpr, sys: &mut dyn System) -> R<[f32; 6]> {
        Ok(match e {
            JExpr::Var(l) => self.read_loc_var(i, l, Ty::Joint, sys)?,
            JExpr::PPoint(args) => {
                let mut v = [0f32; 6];
                for (k, a) in args.iter().enumerate().take(6) {
                    v[k] = self.eval_r(i, a, sys)?;
                }
                v
            }
            JExpr::Here => sys.joints().map(|x| x as f32),
            JExpr::Inverse(t) => self.inverse_of(i, t, sys)?,
            JExpr::Dest => self.dest_joints(sys)?,
        })
    }

    pub(super) fn eval_t(&mut self, i: TaskSlot, e: &TExpr, sys: &mut dyn System) -> R<[f32; 6]> {
        Ok(match e {
            TExpr::Var(l) => self.read_loc_var(i, l, Ty::Trans, sys)?,
            TExpr::Trans(args) => {
                let mut v = [0f32; 6];
                for (k, a) in args.iter().enumerate().take(6) {
                    v[k] = self.eval_r(i, a, sys)?;
                }
                v
            }
            TExpr::Here => self.here_world(sys)?,
            TExpr::Forward(j) => self.forward_of(i, j, sys)?,
            TExpr::Dest => self.dest_world(sys)?,
            TExpr::Shift(t, d) => {
                let mut v = self.eval_t(i, t, sys)?;
                for (k, e) in d.iter().enumerate().take(3) {
                    v[k] = check(v[k] + self.eval_r(i, e, sys)?, "SHIFT")?;
                }
                v
            }
            TExpr::Frame(t) => self.eval_frame(i, t, sys)?,
            TExpr::Inverse(t) => {
                let x = self.eval_t(i, t, sys)?;
                let r = Pose::from_xyzoat(xyzoat(&x)).inverse().to_xyzoat();
                [r.x_mm, r.y_mm, r.z_mm, r.o_deg, r.a_deg, r.t_deg].map(|v| v as f32)
            }
            TExpr::Rot(axis, a) => {
                let deg = f64::from(self.eval_r(i, a, sys)?);
                let axis = match axis {
                    0 => nalgebra::Vector3::x_axis(),
                    1 => nalgebra::Vector3::y_axis(),
                    _ => nalgebra::Vector3::z_axis(),
                };
                let q = nalgebra::UnitQuaternion::from_axis_angle(&axis, deg.to_radians());
                let r = Pose::new(nalgebra::Vector3::zeros(), q).to_xyzoat();
                [r.x_mm, r.y_mm, r.z_mm, r.o_deg, r.a_deg, r.t_deg].map(|v| v as f32)
            }
            TExpr::Compose(a, b) => {
                let x = self.eval_t(i, a, sys)?;
                let y = self.eval_t(i, b, sys)?;
                let px = Pose::from_xyzoat(xyzoat(&x));
                let py = Pose::from_xyzoat(xyzoat(&y));
                let r = (px * py).to_xyzoat();
                [r.x_mm, r.y_mm, r.z_mm, r.o_deg, r.a_deg, r.t_deg].map(|v| v as f32)
            }
        })
    }

    /// Formats PRINT/$ENCODE items: the bytes (line feeds for `/C`) and whether `/S` was given.
    pub(super) fn encode(
        &mut self,
        i: TaskSlot,
        items: &[Item],
        sys: &mut dyn System,
    ) -> R<(Vec<u8>, bool)> {
        // Room for the usual items (a number takes up to a dozen characters): no regrowth.
        let mut out = String::with_capacity(16 * items.len());
        let mut bytes = Vec::new();
        let mut current = FormatCode::D;
        let mut no_newline = false;
        for item in items {
            match item {
                Item::Format(f) => match f {
                    FormatCode::X(n) => out.extend(std::iter::repeat_n(' ', usize::from(*n))),
                    FormatCode::C(n) => out.extend(std::iter::repeat_n('\n', usize::from(*n))),
                    FormatCode::S => no_newline = true,
                    other => current = *other,
                },
                Item::Real(e) => {
                    let v = f64::from(self.eval_r(i, e, sys)?);
                    match current {
                        FormatCode::D => {
                            out.push(' ');
                            fmt::push_default(&mut out, v);
                        }
                        FormatCode::L => fmt::push_default(&mut out, v),
                        FormatCode::F(w, d) => {
                            fmt::push_fixed(&mut out, v, usize::from(w), usize::from(d))
                        }
                        FormatCode::E(w, d) => {
                            fmt::push_exponent(&mut out, v, usize::from(w), usize::from(d))
                        }
                        FormatCode::G(w, d) => {
                            fmt::push_general(&mut out, v, usize::from(w), usize::from(d))
                        }
                        FormatCode::I(w) => fmt::push_integer(&mut out, v, usize::from(w), false),
                        FormatCode::K(w) => fmt::push_integer(&mut out, v, usize::from(w), true),
                        FormatCode::H(w) => fmt::push_hex(&mut out, v, usize::from(w), false),
                        FormatCode::J(w) => fmt::push_hex(&mut out, v, usize::from(w), true),
                        FormatCode::X(_) | FormatCode::C(_) | FormatCode::S => {}
                    }
                }
                Item::Str(e) => {
                    let s = self.eval_s(i, e, sys)?;
                    bytes.extend_from_slice(out.as_bytes());
                    out.clear();
                    bytes.extend_from_slice(&s);
                }
            }
            if out.len() + bytes.len() > 64 * 1024 {
                return Err(Box::new(RuntimeError::StringTooLong(
                    out.len() + bytes.len(),
                )));
            }
        }
        if bytes.is_empty() {
            // Numbers and formats only: the text is the result.
            return Ok((out.into_bytes(), no_newline));
        }
        bytes.extend_from_slice(out.as_bytes());
        Ok((bytes, no_newline))
    }
}

pub(super) fn xyzoat(v: &[f32; 6]) -> Xyzoat {
    Xyzoat {
        x_mm: f64::from(v[0]),
        y_mm: f64::from(v[1]),
        z_mm: f64::from(v[2]),
        o_deg: f64::from(v[3]),
        a_deg: f64::from(v[4]),
        t_deg: f64::from(v[5]),
    }
}
