//! Numbers: the result type, overflow checks, the binary operators, truth, seconds.

use std::time::Duration;

use crate::ast::BinOp;
use crate::error::RuntimeError;

/// [`Interpreter::exec_hot`]'s answer for an op that is not pure computation (never a pc).
pub(super) const NOT_PURE: usize = usize::MAX;

/// A runtime error, boxed: results stay two words (returned in registers) on the hot path.
pub(super) type R<T> = Result<T, Box<RuntimeError>>;

#[inline]
pub(super) fn check(v: f32, what: &str) -> R<f32> {
    if v.is_finite() {
        Ok(v)
    } else {
        Err(overflow(what))
    }
}

#[cold]
pub(super) fn overflow(what: &str) -> Box<RuntimeError> {
    Box::new(RuntimeError::Overflow(what.to_owned()))
}

/// A constant or a defined real scalar (of `globals` or `locals`), `None` for anything else.
/// A binary operation on reals (AS reals: 32-bit; a result that is not finite is an overflow).
#[inline]
pub(super) fn bin_r(op: BinOp, x: f32, y: f32) -> R<f32> {
    Ok(match op {
        BinOp::Add => check(x + y, "+")?,
        BinOp::Sub => check(x - y, "-")?,
        BinOp::Mul => check(x * y, "*")?,
        BinOp::Div => {
            if y == 0.0 {
                return Err(division_by_zero());
            }
            check(x / y, "/")?
        }
        BinOp::Mod => {
            if y == 0.0 {
                return Err(division_by_zero());
            }
            check(x % y, "MOD")?
        }
        BinOp::Pow => pow_r(x, y)?,
        BinOp::Eq => as_bool(x == y),
        BinOp::Ne => as_bool(x != y),
        BinOp::Lt => as_bool(x < y),
        BinOp::Gt => as_bool(x > y),
        BinOp::Le => as_bool(x <= y),
        BinOp::Ge => as_bool(x >= y),
        BinOp::And => as_bool(truthy(x) && truthy(y)),
        BinOp::Or => as_bool(truthy(x) || truthy(y)),
        BinOp::Xor => as_bool(truthy(x) != truthy(y)),
        BinOp::Band => (to_i32(x) & to_i32(y)) as f32,
        BinOp::Bor => (to_i32(x) | to_i32(y)) as f32,
        BinOp::Bxor => (to_i32(x) ^ to_i32(y)) as f32,
    })
}

#[cold]
pub(super) fn division_by_zero() -> Box<RuntimeError> {
    Box::new(RuntimeError::DivisionByZero)
}

#[inline(never)]
pub(super) fn pow_r(x: f32, y: f32) -> R<f32> {
    let r = x.powf(y);
    if r.is_nan() {
        return Err(Box::new(RuntimeError::IllegalValue(format!("{x} ^ {y}"))));
    }
    check(r, "^")
}

pub(super) fn truthy(v: f32) -> bool {
    v != 0.0
}

pub(super) fn as_bool(b: bool) -> f32 {
    if b {
        -1.0
    } else {
        0.0
    }
}

/// A signal number from a real (bounded, so that its absolute value always exists).
pub(super) fn signal_number(v: f32) -> i32 {
    v.trunc().clamp(-1.0e6, 1.0e6) as i32
}

pub(super) fn to_i32(v: f32) -> i32 {
    v as i32
}

/// Interpreter time in nanoseconds: the scheduler compares and adds times on every step, and
/// a `u64` does that in one instruction where a [`Duration`] takes two fields (584 years of
/// virtual time; every wait the language allows is far shorter).
pub(super) type Ns = u64;

/// A duration in [`Ns`] (saturating).
#[inline]
pub(super) fn ns(d: Duration) -> Ns {
    u64::try_from(d.as_nanos()).unwrap_or(u64::MAX)
}

pub(super) fn secs(v: f32, what: &str) -> R<Duration> {
    if !(v.is_finite() && v >= 0.0) {
        return Err(Box::new(RuntimeError::IllegalValue(format!(
            "{what} {v} (expected seconds ≥ 0)"
        ))));
    }
    Ok(Duration::from_secs_f64(f64::from(v).min(1.0e7)))
}
