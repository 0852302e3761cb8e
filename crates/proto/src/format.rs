//! The AS print formats of `PRINT`, `TYPE` and `$ENCODE`, for any value: `/D` (the default),
//! `/Fm.n`, `/Em.n`, `/Gm.n`, `/Im`, `/Hm` and their zero-padded forms `/Km`, `/Jm`.
//!
//! The reply of the protocol-1040 server uses two of them, with fast paths in
//! [`number`](crate::number) ([`push_default_int`](crate::number::push_default_int),
//! [`push_f10_3`](crate::number::push_f10_3)); the functions here agree with those byte for
//! byte (tested) and cover every other value and width.
//!
//! The AS manual defines the codes (E-series AS language reference, §5.8 and `$ENCODE`):
//! a value too long for its width prints as asterisks, `/D` is `/G15.8` with trailing zeros
//! dropped. Where the manual is silent this module chooses, and says so:
//!
//! * AS reals are 32-bit floats. [`format_default`] prints the **shortest decimal that reads
//!   back as the same 32-bit real** (so `0.1` prints `0.1`, not `0.10000000149`), in fixed
//!   notation when 0.01 < |v| and it fits in 15 characters, else in exponent form with at least
//!   one decimal and a two-digit exponent (`1.0E-03`, `-2.5E+20`).
//! * A value that rounds to zero never prints a minus sign (`-0.000` is `0.000`).
//! * Non-finite values (which AS arithmetic never produces) print as asterisks.
//!
//! ```
//! use fs020n_proto::format::{format_default, format_fixed, format_exponent, format_integer};
//! assert_eq!(format_default(1040.0), "1040");
//! assert_eq!(format_default(-1.0), "-1");
//! assert_eq!(format_default(0.1), "0.1");
//! assert_eq!(format_default(0.001), "1.0E-03");
//! assert_eq!(format_fixed(12.66666, 5, 2), "12.67");
//! assert_eq!(format_fixed(1000.0, 5, 2), "*****");
//! assert_eq!(format_exponent(-123.4, 10, 3), "-1.234E+02");
//! assert_eq!(format_integer(41.6, 4), "  42");
//! ```

use std::fmt::Write;

/// Widest field any format code may ask for (the manual allows up to 32 for `/E`; wider
/// requests are clamped to this).
pub const MAX_WIDTH: usize = 128;

/// Most decimals any format code may ask for (wider requests are clamped to this).
pub const MAX_DECIMALS: usize = 32;

/// Widest text `/D` prints in fixed notation before switching to exponent form (`/G15.8`).
pub const DEFAULT_FIELD: usize = 15;

fn stars(out: &mut String, width: usize) {
    out.extend(std::iter::repeat_n('*', width.min(MAX_WIDTH)));
}

fn pad_left(out: &mut String, text: &str, width: usize, zero: bool) {
    let len = text.chars().count();
    if len >= width {
        out.push_str(text);
        return;
    }
    if zero {
        // Zeros go after the sign.
        let (sign, digits) = match text.strip_prefix('-') {
            Some(d) => ("-", d),
            None => ("", text),
        };
        out.push_str(sign);
        out.extend(std::iter::repeat_n('0', width - len));
        out.push_str(digits);
    } else {
        out.extend(std::iter::repeat_n(' ', width - len));
        out.push_str(text);
    }
}

/// The value as AS stores it: a 32-bit real.
fn as_real(value: f64) -> f32 {
    value as f32
}

/// `/D`: the default format, without the blank AS puts before each value (see the module
/// documentation for the digits chosen).
pub fn format_default(value: f64) -> String {
    let mut out = String::with_capacity(12);
    push_default(&mut out, value);
    out
}

/// Appends `value` in the `/D` format (see [`format_default`]) to `out`.
pub fn push_default(out: &mut String, value: f64) {
    let v = as_real(value);
    if !v.is_finite() {
        out.push('*');
        return;
    }
    if v == 0.0 {
        out.push('0');
        return;
    }
    // Integers that a 32-bit real holds exactly: the digits, no point.
    if v.fract() == 0.0 && v.abs() < 16_777_216.0 {
        let _ = write!(out, "{}", v as i32);
        return;
    }
    let a = v.abs();
    if a > 0.01 {
        // Shortest round-trip digits of the 32-bit real, fixed notation.
        let s = format!("{v}");
        if s.len() <= DEFAULT_FIELD && !s.contains('e') {
            out.push_str(&s);
            return;
        }
    }
    push_exponent_shortest(out, v);
}

/// Exponent form with the shortest round-trip mantissa: `1.0E-03`, `-1.2345E+20`.
fn push_exponent_shortest(out: &mut String, v: f32) {
    let s = format!("{v:e}");
    let (mantissa, exp) = s.split_once('e').unwrap_or((s.as_str(), "0"));
    let exp: i32 = exp.parse().unwrap_or(0);
    out.push_str(mantissa);
    if !mantissa.contains('.') {
        out.push_str(".0");
    }
    push_exp(out, exp);
}

fn push_exp(out: &mut String, exp: i32) {
    let _ = write!(
        out,
        "E{}{:02}",
        if exp < 0 { '-' } else { '+' },
        exp.unsigned_abs()
    );
}

/// `/Fm.n`: fixed point with `decimals` decimals, right-justified in `width` characters, or
/// `width` asterisks when it does not fit.
pub fn format_fixed(value: f64, width: usize, decimals: usize) -> String {
    let mut out = String::with_capacity(width);
    push_fixed(&mut out, value, width, decimals);
    out
}

/// Appends `value` in the `/Fm.n` format (see [`format_fixed`]) to `out`.
pub fn push_fixed(out: &mut String, value: f64, width: usize, decimals: usize) {
    let width = width.min(MAX_WIDTH);
    let decimals = decimals.min(MAX_DECIMALS);
    if width == crate::number::F10_WIDTH && decimals == 3 {
        crate::number::push_f10_3(out, value);
        return;
    }
    if !value.is_finite() {
        stars(out, width);
        return;
    }
    let s = fixed_text(value, decimals);
    if s.len() > width {
        stars(out, width);
    } else {
        pad_left(out, &s, width, false);
    }
}

/// `value` with `decimals` decimals, never `-0…`.
fn fixed_text(value: f64, decimals: usize) -> String {
    let s = format!("{value:.decimals$}");
    match s.strip_prefix('-') {
        Some(rest) if rest.bytes().all(|b| b == b'0' || b == b'.') => rest.to_owned(),
        _ => s,
    }
}

/// `/Em.n`: scientific notation with `decimals` decimals and a two-digit signed exponent
/// (`-1.234E+02`), right-justified in `width` characters, or asterisks when it does not fit.
pub fn format_exponent(value: f64, width: usize, decimals: usize) -> String {
    let mut out = String::with_capacity(width);
    push_exponent(&mut out, value, width, decimals);
    out
}

/// Appends `value` in the `/Em.n` format (see [`format_exponent`]) to `out`.
pub fn push_exponent(out: &mut String, value: f64, width: usize, decimals: usize) {
    let width = width.min(MAX_WIDTH);
    let decimals = decimals.min(MAX_DECIMALS);
    if !value.is_finite() {
        stars(out, width);
        return;
    }
    let s = format!("{value:.decimals$e}");
    let (mantissa, exp) = s.split_once('e').unwrap_or((s.as_str(), "0"));
    let exp: i32 = exp.parse().unwrap_or(0);
    let mut text = String::with_capacity(width);
    match mantissa.strip_prefix('-') {
        Some(rest) if value == 0.0 => text.push_str(rest),
        _ => text.push_str(mantissa),
    }
    push_exp(&mut text, exp);
    if text.len() > width {
        stars(out, width);
    } else {
        pad_left(out, &text, width, false);
    }
}

/// `/Gm.n`: `/Fm.n` when |value| > 0.01 and it fits in `width` characters, else `/Em.n`.
pub fn format_general(value: f64, width: usize, decimals: usize) -> String {
    let mut out = String::with_capacity(width);
    push_general(&mut out, value, width, decimals);
    out
}

/// Appends `value` in the `/Gm.n` format (see [`format_general`]) to `out`.
pub fn push_general(out: &mut String, value: f64, width: usize, decimals: usize) {
    let width = width.min(MAX_WIDTH);
    let decimals = decimals.min(MAX_DECIMALS);
    if value.is_finite() && value.abs() > 0.01 {
        let s = fixed_text(value, decimals);
        if s.len() <= width {
            pad_left(out, &s, width, false);
            return;
        }
    }
    push_exponent(out, value, width, decimals);
}

/// `/Im` (`zero` false) or `/Km` (`zero` true): the value rounded to an integer,
/// right-justified in `width` characters (padded with zeros for `/K`), or asterisks.
pub fn format_integer(value: f64, width: usize) -> String {
    let mut out = String::with_capacity(width);
    push_integer(&mut out, value, width, false);
    out
}

/// Appends `value` in the `/Im` or `/Km` format (see [`format_integer`]) to `out`.
pub fn push_integer(out: &mut String, value: f64, width: usize, zero: bool) {
    let width = width.min(MAX_WIDTH);
    if !value.is_finite() || value.abs() >= 1e18 {
        stars(out, width);
        return;
    }
    let r = value.round() as i64;
    let s = r.to_string();
    if s.len() > width {
        stars(out, width);
    } else {
        pad_left(out, &s, width, zero);
    }
}

/// `/Hm` (`zero` false) or `/Jm` (`zero` true): the value rounded to an integer, as upper-case
/// hexadecimal (a negative value as its 32-bit two's complement), right-justified in `width`
/// characters (zero-padded for `/J`), or asterisks.
pub fn format_hex(value: f64, width: usize, zero: bool) -> String {
    let mut out = String::with_capacity(width);
    push_hex(&mut out, value, width, zero);
    out
}

/// Appends `value` in the `/Hm` or `/Jm` format (see [`format_hex`]) to `out`.
pub fn push_hex(out: &mut String, value: f64, width: usize, zero: bool) {
    let width = width.min(MAX_WIDTH);
    if !value.is_finite() || value.abs() > f64::from(u32::MAX) {
        stars(out, width);
        return;
    }
    let r = value.round() as i64;
    let s = format!("{:X}", r as u32);
    if s.len() > width {
        stars(out, width);
    } else {
        pad_left(out, &s, width, zero);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::number::{format_default_int, format_f10_3};
    use proptest::prelude::*;

    #[test]
    fn default_format() {
        assert_eq!(format_default(0.0), "0");
        assert_eq!(format_default(-0.0), "0");
        assert_eq!(format_default(-31088.0), "-31088");
        assert_eq!(format_default(12.5), "12.5");
        assert_eq!(format_default(-0.25), "-0.25");
        assert_eq!(format_default(1.0 / 3.0), "0.33333334");
        assert_eq!(format_default(123.456), "123.456");
        assert_eq!(format_default(0.01), "1.0E-02");
        assert_eq!(format_default(0.0123), "0.0123");
        assert_eq!(format_default(-1.5e-5), "-1.5E-05");
        assert_eq!(format_default(16_777_216.0), "16777216");
        assert_eq!(format_default(1e20), "1.0E+20");
        assert_eq!(format_default(123456.78), "123456.78");
        assert_eq!(format_default(f64::NAN), "*");
    }

    #[test]
    fn fixed_and_others() {
        assert_eq!(format_fixed(0.0, 6, 2), "  0.00");
        assert_eq!(format_fixed(-0.001, 6, 2), "  0.00");
        assert_eq!(format_fixed(-1.5, 6, 0), "    -2");
        assert_eq!(format_fixed(99.995, 5, 2), "*****");
        assert_eq!(format_fixed(f64::INFINITY, 3, 1), "***");
        assert_eq!(format_exponent(0.0, 9, 2), " 0.00E+00");
        assert_eq!(format_exponent(1.0e-5, 9, 2), " 1.00E-05");
        assert_eq!(format_exponent(1.0e-5, 5, 2), "*****");
        assert_eq!(format_general(5.0, 8, 3), "   5.000");
        assert_eq!(format_general(0.005, 10, 2), "  5.00E-03");
        assert_eq!(format_integer(-3.5, 4), "  -4");
        assert_eq!(format_integer(12345.0, 4), "****");
        let mut s = String::new();
        push_integer(&mut s, -42.0, 5, true);
        assert_eq!(s, "-0042");
        assert_eq!(format_hex(255.0, 4, false), "  FF");
        assert_eq!(format_hex(255.0, 4, true), "00FF");
        assert_eq!(format_hex(-1.0, 8, false), "FFFFFFFF");
        assert_eq!(format_hex(-1.0, 4, false), "****");
    }

    proptest! {
        /// The general fixed format agrees with the reply's `/F10.3` fast path, and `/D` with
        /// the reply's integer format.
        #[test]
        fn agrees_with_the_reply_formats(v in -2.0e6f64..2.0e6, i in -99_999i64..99_999) {
            let mut general = String::new();
            // Width 10, 3 decimals, but through the general path.
            let s = fixed_text(v, 3);
            if s.len() > 10 { stars(&mut general, 10) } else { pad_left(&mut general, &s, 10, false) }
            prop_assert_eq!(&general, &format_f10_3(v));
            prop_assert_eq!(format_fixed(v, 10, 3), format_f10_3(v));
            prop_assert_eq!(format!(" {}", format_default(i as f64)), format_default_int(i));
        }

        /// `/D` reads back (through `VAL`) as the same 32-bit real.
        #[test]
        fn default_round_trips_through_val(v in proptest::num::f32::NORMAL) {
            let text = format_default(f64::from(v));
            prop_assert_eq!(crate::number::as_val(&text), f64::from(v), "{}", text);
        }
    }
}
