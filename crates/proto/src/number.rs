//! AS number formats: what the controller writes and reads.
//!
//! * [`as_val`] — the controller's `VAL` function, used by the server to read request tokens.
//! * [`format_request_number`] — how a client must write a number in a request: fixed point,
//!   at most [`REQUEST_DECIMALS`] decimals, never exponent notation.
//! * [`format_f10_3`] — the `/F10.3` format of reply fields 8–14.
//! * [`format_default_int`] — the AS default format of reply fields 1–7.

use crate::error::EncodeError;

/// Decimals written for each number of a request.
///
/// The controller stores reals as 32-bit floats (about 7 significant digits) and reports joint
/// angles with 3 decimals, so more decimals carry no information but cost bytes of the
/// 255-byte budget.
pub const REQUEST_DECIMALS: usize = 3;

/// Largest magnitude a request number may have.
///
/// Larger numbers cannot be represented by an AS real with a meaningful fractional part, and
/// would eat the 255-byte budget; no real quantity of the protocol comes close.
pub const REQUEST_NUMBER_LIMIT: f64 = 1.0e7;

/// Width of an `/F10.3` field.
pub const F10_WIDTH: usize = 10;

/// What `/F10.3` prints when a value does not fit in 10 characters.
pub const F10_OVERFLOW: &str = "**********";

/// The step between neighbouring 32-bit AS reals at the magnitude of `x`: the precision the
/// controller keeps of a value (`TIMER`, a variable). 0 for 0; infinite beyond the range.
///
/// ```
/// use fs020n_proto::number::as_real_step;
/// assert_eq!(as_real_step(1.0), 1.0 / 8_388_608.0);
/// assert_eq!(as_real_step(16_384.0), 1.0 / 512.0);
/// ```
pub fn as_real_step(x: f64) -> f64 {
    let f = x.abs() as f32;
    if f == 0.0 {
        return 0.0;
    }
    if !f.is_finite() {
        return f64::INFINITY;
    }
    let next = f32::from_bits(f.to_bits() + 1);
    f64::from(next) - f64::from(f)
}

/// Converts text to a number exactly as the AS `VAL` function does.
///
/// Leading blanks are skipped; the number ends at the first character that cannot continue it
/// (`"12abc"` is 12); text without a number is 0; exponent form (`1.2E-5`) is accepted. The
/// result is rounded to an AS real (a 32-bit float), as the controller stores it.
///
/// ```
/// use fs020n_proto::number::as_val;
/// assert_eq!(as_val("12abc"), 12.0);
/// assert_eq!(as_val(""), 0.0);
/// assert_eq!(as_val("  -7.5"), -7.5);
/// assert_eq!(as_val("1.5E2x"), 150.0);
/// assert_eq!(as_val("E5"), 0.0);
/// ```
pub fn as_val(text: &str) -> f64 {
    as_val_bytes(text.as_bytes())
}

/// [`as_val`] on raw bytes (the server's tokens). Bytes that are not ASCII can neither start
/// nor continue a number, so the result is the same as on the text decoded lossily.
pub(crate) fn as_val_bytes(b: &[u8]) -> f64 {
    let start = b
        .iter()
        .position(|&c| c != b' ' && c != b'\t')
        .unwrap_or(b.len());
    let s = &b[start..];
    match short_decimal(s) {
        Some((v, _)) => f64::from(v as f32),
        None => general_val(s),
    }
}

/// `VAL` of `s` (which starts at its first non-blank) through the general parser.
pub(crate) fn general_val(s: &[u8]) -> f64 {
    let end = numeric_prefix_len(s);
    if end == 0 {
        return 0.0;
    }
    // A number beyond the range of an AS real (a 32-bit float, about ±3.4E38), e.g. an
    // overflowing exponent: the controller would report an error; 0 is the safe reading.
    match std::str::from_utf8(&s[..end]).map(|t| t.parse::<f64>().map(|v| v as f32)) {
        Ok(Ok(v)) if v.is_finite() => f64::from(v),
        _ => 0.0,
    }
}

/// Exact powers of ten up to 10¹⁵.
const POW10: [f64; 16] = [
    1e0, 1e1, 1e2, 1e3, 1e4, 1e5, 1e6, 1e7, 1e8, 1e9, 1e10, 1e11, 1e12, 1e13, 1e14, 1e15,
];

/// Most digits [`short_decimal`] reads: `m < 10^15 < 2^53` is then an exact double.
const SHORT_DIGITS: usize = 15;

/// The number at the start of `b` when it is short: `[sign]digits[.digits]` with at most 15
/// digits and no exponent (whatever follows the number is ignored, as `VAL` ignores it), with
/// the index where the reading stopped. `Some((0.0, _))` when `b` does not start with a
/// number; `None` when the general parser is needed (more digits, an exponent).
///
/// Such a number is `m / 10^k` with `m < 2^53` and `10^k` both exact doubles, so one IEEE
/// division rounds it correctly: the same double as `str::parse::<f64>` (Clinger's fast path),
/// without the general parser's cost.
#[inline(always)]
pub(crate) fn short_decimal(b: &[u8]) -> Option<(f64, usize)> {
    short_decimal_at(b, 0)
}

/// [`short_decimal`] of `&b[start..]` (nothing when `start` is past the end), with the index
/// in `b` where the reading stopped. On indices rather than a subslice, and with the digits
/// accumulated wrapping (a reading of more than [`SHORT_DIGITS`] digits discards `m`), so the
/// loops compile to a few instructions per byte.
#[inline(always)]
pub(crate) fn short_decimal_at(b: &[u8], start: usize) -> Option<(f64, usize)> {
    let len = b.len();
    let mut i = start;
    let mut negative = false;
    if let Some(&c @ (b'-' | b'+')) = b.get(i) {
        negative = c == b'-';
        i += 1;
    }
    let int_start = i;
    let mut m: u64 = 0;
    while i < len {
        let d = b[i].wrapping_sub(b'0');
        if d > 9 {
            break;
        }
        m = m.wrapping_mul(10).wrapping_add(u64::from(d));
        i += 1;
    }
    let mut count = i - int_start;
    let mut decimals = 0;
    if i < len && b[i] == b'.' {
        i += 1;
        let frac_start = i;
        while i < len {
            let d = b[i].wrapping_sub(b'0');
            if d > 9 {
                break;
            }
            m = m.wrapping_mul(10).wrapping_add(u64::from(d));
            i += 1;
        }
        decimals = i - frac_start;
        count += decimals;
    }
    if count == 0 {
        return Some((0.0, i));
    }
    // `| 0x20` maps 'E' to 'e' (and nothing else to it).
    if count > SHORT_DIGITS || (i < len && (b[i] | 0x20) == b'e') {
        return None;
    }
    // m < 10^15 < 2^63: the signed conversion (one instruction, where the unsigned one takes
    // several) is exact.
    let v = m as i64 as f64 / POW10[decimals];
    Some((if negative { -v } else { v }, i))
}

/// Length of the longest prefix of `b` that forms a decimal number (sign, digits, point,
/// digits, optional exponent with at least one digit). Returns 0 when no digit is present.
pub(crate) fn numeric_prefix_len(b: &[u8]) -> usize {
    let mut i = 0;
    if i < b.len() && (b[i] == b'+' || b[i] == b'-') {
        i += 1;
    }
    let int_start = i;
    while i < b.len() && b[i].is_ascii_digit() {
        i += 1;
    }
    let mut digits = i - int_start;
    if i < b.len() && b[i] == b'.' {
        let frac_start = i + 1;
        let mut j = frac_start;
        while j < b.len() && b[j].is_ascii_digit() {
            j += 1;
        }
        digits += j - frac_start;
        if digits > 0 {
            i = j;
        }
    }
    if digits == 0 {
        return 0;
    }
    if i < b.len() && (b[i] == b'E' || b[i] == b'e') {
        let mut j = i + 1;
        if j < b.len() && (b[j] == b'+' || b[j] == b'-') {
            j += 1;
        }
        let exp_start = j;
        while j < b.len() && b[j].is_ascii_digit() {
            j += 1;
        }
        if j > exp_start {
            i = j;
        }
    }
    i
}

/// Formats one request number: fixed point, at most [`REQUEST_DECIMALS`] decimals, trailing
/// zeros dropped, never exponent notation, `-0` written as `0`.
///
/// `field` names the value in the error (e.g. `"JT3 target"`).
///
/// ```
/// use fs020n_proto::number::format_request_number;
/// assert_eq!(format_request_number(30.0, "x").unwrap(), "30");
/// assert_eq!(format_request_number(-12.34567, "x").unwrap(), "-12.346");
/// assert_eq!(format_request_number(1e-9, "x").unwrap(), "0");
/// assert!(format_request_number(f64::NAN, "x").is_err());
/// ```
pub fn format_request_number(value: f64, field: &'static str) -> Result<String, EncodeError> {
    let mut out = String::with_capacity(12);
    push_request_number(&mut out, value, field)?;
    Ok(out)
}

/// Appends one request number, formatted as [`format_request_number`] does, to `out` (no
/// allocation for the usual values: a request of 21 numbers is built in one buffer). On an
/// error, `out` is unchanged.
///
/// ```
/// use fs020n_proto::number::push_request_number;
/// let mut s = String::from("1040 7 1 ");
/// push_request_number(&mut s, -0.5, "x").unwrap();
/// assert_eq!(s, "1040 7 1 -0.5");
/// ```
pub fn push_request_number(
    out: &mut String,
    value: f64,
    field: &'static str,
) -> Result<(), EncodeError> {
    if !value.is_finite() {
        return Err(EncodeError::NonFinite { field, value });
    }
    if value.abs() >= REQUEST_NUMBER_LIMIT {
        return Err(EncodeError::OutOfRange {
            field,
            value,
            limit: REQUEST_NUMBER_LIMIT,
        });
    }
    let Some(m) = thousandths(value) else {
        out.push_str(&trim_decimals(format!(
            "{value:.prec$}",
            prec = REQUEST_DECIMALS
        )));
        return Ok(());
    };
    // Sign, integer digits, then the decimals without trailing zeros ("-0" cannot occur: a
    // negative `m` is at least one thousandth).
    let (int, frac) = (m.unsigned_abs() / 1000, m.unsigned_abs() % 1000);
    // "-" and the 15 digits below REQUEST_NUMBER_LIMIT (10^15 thousandths at most) and ".ddd".
    let mut text = [0u8; 24];
    let mut digits = [0u8; 20];
    let mut n = 0;
    let mut rest = int;
    loop {
        digits[n] = b'0' + (rest % 10) as u8;
        n += 1;
        rest /= 10;
        if rest == 0 {
            break;
        }
    }
    let mut len = 0;
    if m < 0 {
        text[0] = b'-';
        len = 1;
    }
    for &d in digits[..n].iter().rev() {
        text[len] = d;
        len += 1;
    }
    let decimals: &[u8] = match frac {
        0 => &[],
        f if f % 100 == 0 => &[b'0' + (f / 100) as u8],
        f if f % 10 == 0 => &[b'0' + (f / 100) as u8, b'0' + (f / 10 % 10) as u8],
        f => &[
            b'0' + (f / 100) as u8,
            b'0' + (f / 10 % 10) as u8,
            b'0' + (f % 10) as u8,
        ],
    };
    if !decimals.is_empty() {
        text[len] = b'.';
        len += 1;
        text[len..len + decimals.len()].copy_from_slice(decimals);
        len += decimals.len();
    }
    out.push_str(ascii(&text[..len]));
    Ok(())
}

/// Drops trailing zeros (and a trailing point) of a fixed-point number; `-0` becomes `0`.
fn trim_decimals(mut s: String) -> String {
    if s.contains('.') {
        while s.ends_with('0') {
            s.pop();
        }
        if s.ends_with('.') {
            s.pop();
        }
    }
    if s == "-0" {
        s = "0".to_owned();
    }
    s
}

/// `value` in thousandths, rounded exactly as `format!("{:.3}")` rounds it, computed with
/// integers for speed; `None` when the value is so close to a rounding tie that the product
/// `value * 1000` might round the other way (the caller then uses the exact float printer), or
/// too large for an `i64`.
///
/// Below 10¹⁵ (< 2⁶³) the conversion to `i64` truncates exactly and `x - trunc(x)` is exact, so
/// `trunc` and `round` need no float rounding instructions (which the baseline x86-64 lacks):
/// away from a tie, `round(x)` is `trunc(x)` moved one away from zero when the fraction
/// exceeds one half.
fn thousandths(value: f64) -> Option<i64> {
    let x = value * 1000.0;
    if x.is_nan() || x.abs() >= 1.0e15 {
        return None;
    }
    let t = x as i64;
    let frac = (x - t as f64).abs();
    if (frac - 0.5).abs() < 1.0e-6 {
        return None;
    }
    Some(if frac < 0.5 {
        t
    } else if x < 0.0 {
        t - 1
    } else {
        t + 1
    })
}

/// Formats a value as AS `/F10.3`: 3 decimals, right-justified in exactly 10 characters, or
/// ten asterisks when it does not fit. A value that rounds to zero prints as `0.000`
/// (never `-0.000`).
///
/// ```
/// use fs020n_proto::number::format_f10_3;
/// assert_eq!(format_f10_3(12.5), "    12.500");
/// assert_eq!(format_f10_3(-90.0), "   -90.000");
/// assert_eq!(format_f10_3(1.0e6), "**********");
/// ```
pub fn format_f10_3(value: f64) -> String {
    let mut out = String::with_capacity(F10_WIDTH);
    push_f10_3(&mut out, value);
    out
}

/// Appends `value` in the `/F10.3` format (see [`format_f10_3`]) to `out`.
pub fn push_f10_3(out: &mut String, value: f64) {
    out.push_str(ascii(&f10_3_field(value)));
}

/// The ten bytes of `value` in the `/F10.3` format (see [`format_f10_3`]).
pub(crate) fn f10_3_field(value: f64) -> [u8; F10_WIDTH] {
    const OVERFLOW: [u8; F10_WIDTH] = [b'*'; F10_WIDTH];
    let Some(m) = thousandths(value) else {
        return if value.is_finite() {
            f10_3_field_exact(value)
        } else {
            OVERFLOW
        };
    };
    let a = m.unsigned_abs();
    let negative = m < 0;
    // Ten characters hold 3 decimals, the point and 6 integer digits, or a sign and 5.
    if a >= if negative { 100_000_000 } else { 1_000_000_000 } {
        return OVERFLOW;
    }
    // Right-justified, written from the right: 3 decimals, the point, the integer part (at
    // least one digit), the sign.
    let mut field = [b' '; F10_WIDTH];
    // Below 10^9: u32 arithmetic, two digits per division.
    let a = a as u32;
    let frac = a % 1000;
    field[7] = b'0' + (frac / 100) as u8;
    field[8..10].copy_from_slice(&digit_pair(frac % 100));
    field[6] = b'.';
    let mut int = a / 1000;
    let mut i = 6;
    while int >= 100 {
        field[i - 2..i].copy_from_slice(&digit_pair(int % 100));
        int /= 100;
        i -= 2;
    }
    if int >= 10 {
        field[i - 2..i].copy_from_slice(&digit_pair(int));
        i -= 2;
    } else {
        field[i - 1] = b'0' + int as u8;
        i -= 1;
    }
    if negative {
        field[i - 1] = b'-';
    }
    field
}

/// `"00"` to `"99"`, one after the other.
const DIGIT_PAIRS: [u8; 200] = {
    let mut t = [0u8; 200];
    let mut n = 0;
    while n < 100 {
        t[2 * n] = b'0' + (n / 10) as u8;
        t[2 * n + 1] = b'0' + (n % 10) as u8;
        n += 1;
    }
    t
};

/// The two digits of `n` (below 100).
#[inline(always)]
fn digit_pair(n: u32) -> [u8; 2] {
    let i = 2 * (n as usize % 100);
    [DIGIT_PAIRS[i], DIGIT_PAIRS[i + 1]]
}

/// `/F10.3` of a finite value next to a rounding tie, through the exact float printer.
#[cold]
fn f10_3_field_exact(value: f64) -> [u8; F10_WIDTH] {
    let s = format!("{value:>10.3}");
    let s = if s.trim() == "-0.000" {
        format!("{:>10}", "0.000")
    } else {
        s
    };
    <[u8; F10_WIDTH]>::try_from(s.as_bytes()).unwrap_or([b'*'; F10_WIDTH])
}

/// Bytes this module wrote (digits, blanks, signs, points, asterisks) as text.
fn ascii(bytes: &[u8]) -> &str {
    std::str::from_utf8(bytes).unwrap_or_default()
}

/// Formats an integer in the AS default format as it appears in `$ENCODE`: one blank, then the
/// number without a decimal point.
pub fn format_default_int(value: i64) -> String {
    let mut out = String::with_capacity(8);
    push_default_int(&mut out, value);
    out
}

/// Appends `value` in the AS default format (see [`format_default_int`]) to `out`.
pub fn push_default_int(out: &mut String, value: i64) {
    let mut field = [0u8; DEFAULT_INT_MAX];
    let n = put_default_int(&mut field, value);
    out.push_str(ascii(&field[..n]));
}

/// Longest AS default-format integer: `" -9223372036854775808"`.
pub(crate) const DEFAULT_INT_MAX: usize = 21;

/// Writes `value` in the AS default format (see [`format_default_int`]) at the start of `out`
/// and returns how many bytes it wrote (at most [`DEFAULT_INT_MAX`]; `out` must hold them).
pub(crate) fn put_default_int(out: &mut [u8], value: i64) -> usize {
    // The switch fields are 0 and -1: one digit needs no loop and no copy.
    if (-9..=9).contains(&value) {
        let digit = b'0' + value.unsigned_abs() as u8;
        if value < 0 {
            if let Some(field) = out.get_mut(..3) {
                field.copy_from_slice(&[b' ', b'-', digit]);
            }
            return 3;
        }
        if let Some(field) = out.get_mut(..2) {
            field.copy_from_slice(&[b' ', digit]);
        }
        return 2;
    }
    let mut field = [b' '; DEFAULT_INT_MAX];
    let mut rest = value.unsigned_abs();
    let mut i = field.len();
    loop {
        i -= 1;
        field[i] = b'0' + (rest % 10) as u8;
        rest /= 10;
        if rest == 0 {
            break;
        }
    }
    if value < 0 {
        i -= 1;
        field[i] = b'-';
    }
    // The blank before the number.
    let text = &field[i - 1..];
    if let Some(dest) = out.get_mut(..text.len()) {
        dest.copy_from_slice(text);
    }
    text.len()
}

/// `true` when `field` is exactly what `/F10.3` prints: ten characters holding blanks, an
/// optional minus sign, at least one digit, the point and exactly three decimals — or the ten
/// asterisks of an overflow. Such a field cannot be the beginning of a longer `/F10.3` field.
///
/// ```
/// use fs020n_proto::number::is_f10_3_field;
/// assert!(is_f10_3_field(b"    12.500"));
/// assert!(is_f10_3_field(b"**********"));
/// assert!(!is_f10_3_field(b"      0.00"), "two decimals: the field may go on");
/// assert!(!is_f10_3_field(b"   12.5000"));
/// ```
pub fn is_f10_3_field(field: &[u8]) -> bool {
    if field.len() != F10_WIDTH {
        return false;
    }
    if field == F10_OVERFLOW.as_bytes() {
        return true;
    }
    let (int, frac) = field.split_at(F10_WIDTH - 4);
    if frac[0] != b'.' || !frac[1..].iter().all(u8::is_ascii_digit) {
        return false;
    }
    let lead = int.iter().take_while(|&&c| c == b' ').count();
    let number = &int[lead..];
    let digits = number.strip_prefix(b"-").unwrap_or(number);
    !digits.is_empty() && digits.iter().all(u8::is_ascii_digit)
}

/// Parses one reply field: a decimal number, optionally with an exponent. Returns `None` for
/// anything else (including asterisks, which the caller handles).
pub(crate) fn parse_field(token: &str) -> Option<f64> {
    let b = token.as_bytes();
    if b.is_empty() || numeric_prefix_len(b) != b.len() {
        return None;
    }
    // The reply's numbers are short decimals: read them without the general parser (the same
    // double, see `short_decimal`).
    if let Some((v, _)) = short_decimal(b) {
        return Some(v);
    }
    token.parse::<f64>().ok().filter(|v| v.is_finite())
}

/// The implementations before the integer fast paths, kept as the definition the fast paths
/// must match bit for bit and byte for byte.
#[cfg(test)]
pub(crate) mod reference {
    use super::{numeric_prefix_len, F10_OVERFLOW, F10_WIDTH, POW10};

    /// `VAL` on bytes as it was read before.
    pub(crate) fn as_val_bytes(b: &[u8]) -> f64 {
        let start = b
            .iter()
            .position(|&c| c != b' ' && c != b'\t')
            .unwrap_or(b.len());
        let s = &b[start..];
        if let Some(v) = short_decimal(s) {
            return f64::from(v as f32);
        }
        let end = numeric_prefix_len(s);
        if end == 0 {
            return 0.0;
        }
        match std::str::from_utf8(&s[..end]).map(|t| t.parse::<f64>().map(|v| v as f32)) {
            Ok(Ok(v)) if v.is_finite() => f64::from(v),
            _ => 0.0,
        }
    }

    /// The short-decimal reading as it was.
    pub(crate) fn short_decimal(b: &[u8]) -> Option<f64> {
        let (negative, mut i) = match b.first() {
            Some(b'-') => (true, 1),
            Some(b'+') => (false, 1),
            _ => (false, 0),
        };
        let mut m: u64 = 0;
        let mut count = 0usize;
        let mut decimals = 0usize;
        let mut point = false;
        while let Some(&c) = b.get(i) {
            match c {
                b'0'..=b'9' => {
                    count += 1;
                    if count > 15 {
                        return None;
                    }
                    m = m * 10 + u64::from(c - b'0');
                    decimals += usize::from(point);
                }
                b'.' if !point => point = true,
                b'e' | b'E' if count > 0 => return None,
                _ => break,
            }
            i += 1;
        }
        if count == 0 {
            return Some(0.0);
        }
        let v = m as f64 / POW10[decimals];
        Some(if negative { -v } else { v })
    }

    /// Thousandths as they were computed (with `trunc` and `round`).
    pub(crate) fn thousandths(value: f64) -> Option<i64> {
        let x = value * 1000.0;
        if x.is_nan() || x.abs() >= 1.0e15 {
            return None;
        }
        let frac = (x - x.trunc()).abs();
        if (frac - 0.5).abs() < 1.0e-6 {
            return None;
        }
        Some(x.round() as i64)
    }

    /// `/F10.3` as it was written.
    pub(crate) fn write_f10_3(out: &mut Vec<u8>, value: f64) {
        if !value.is_finite() {
            out.extend_from_slice(F10_OVERFLOW.as_bytes());
            return;
        }
        match thousandths(value) {
            Some(m) => {
                let a = m.unsigned_abs();
                let int = a / 1000;
                let negative = m < 0;
                let digits = int.checked_ilog10().unwrap_or(0) as usize + 1;
                let len = usize::from(negative) + digits + 4;
                if len > F10_WIDTH {
                    out.extend_from_slice(F10_OVERFLOW.as_bytes());
                    return;
                }
                let mut field = [b' '; F10_WIDTH];
                let mut rest = a;
                let mut i = F10_WIDTH;
                for k in 0..digits + 3 {
                    if k == 3 {
                        i -= 1;
                        field[i] = b'.';
                    }
                    i -= 1;
                    field[i] = b'0' + (rest % 10) as u8;
                    rest /= 10;
                }
                if negative {
                    field[i - 1] = b'-';
                }
                out.extend_from_slice(&field);
            }
            None => {
                let s = format!("{value:>10.3}");
                if s.trim() == "-0.000" {
                    out.extend_from_slice(format!("{:>10}", "0.000").as_bytes());
                } else if s.len() > F10_WIDTH {
                    out.extend_from_slice(F10_OVERFLOW.as_bytes());
                } else {
                    out.extend_from_slice(s.as_bytes());
                }
            }
        }
    }

    /// The AS default integer format as it was written.
    pub(crate) fn write_default_int(out: &mut Vec<u8>, value: i64) {
        if (-9..=9).contains(&value) {
            let digit = b'0' + value.unsigned_abs() as u8;
            if value < 0 {
                out.extend_from_slice(&[b' ', b'-', digit]);
            } else {
                out.extend_from_slice(&[b' ', digit]);
            }
            return;
        }
        let mut field = [b' '; 21];
        let mut rest = value.unsigned_abs();
        let mut i = field.len();
        loop {
            i -= 1;
            field[i] = b'0' + (rest % 10) as u8;
            rest /= 10;
            if rest == 0 {
                break;
            }
        }
        if value < 0 {
            i -= 1;
            field[i] = b'-';
        }
        out.extend_from_slice(&field[i - 1..]);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::strategy::Strategy;

    #[test]
    fn val_semantics() {
        assert_eq!(as_val("1040"), 1040.0);
        assert_eq!(as_val(" 1040"), 1040.0);
        assert_eq!(as_val("6.5"), 6.5);
        assert_eq!(as_val("abc"), 0.0);
        assert_eq!(as_val("-"), 0.0);
        assert_eq!(as_val("."), 0.0);
        assert_eq!(as_val(".5"), 0.5);
        assert_eq!(as_val("5."), 5.0);
        assert_eq!(as_val("1.2E-5"), f64::from(1.2e-5f32));
        assert_eq!(as_val("3e"), 3.0);
        assert_eq!(as_val("3e+"), 3.0);
        assert_eq!(as_val("+4"), 4.0);
        assert_eq!(as_val("1e999"), 0.0);
        // Finite as a double but beyond an AS real: the same safe reading, never infinity.
        assert_eq!(as_val("3.5e38"), 0.0);
        assert_eq!(as_val("-1e39"), 0.0);
        assert_eq!(as_val("3.4e38"), f64::from(3.4e38f32));
        // AS reals are 32-bit floats.
        assert_eq!(as_val("0.1"), f64::from(0.1f32));
    }

    #[test]
    fn request_numbers() {
        assert_eq!(format_request_number(0.0, "x").unwrap(), "0");
        assert_eq!(format_request_number(-0.0, "x").unwrap(), "0");
        assert_eq!(format_request_number(-0.0004, "x").unwrap(), "0");
        assert_eq!(format_request_number(1.5, "x").unwrap(), "1.5");
        assert_eq!(format_request_number(-90.0, "x").unwrap(), "-90");
        assert_eq!(
            format_request_number(123456.7894, "x").unwrap(),
            "123456.789"
        );
        assert_eq!(
            format_request_number(1e20, "x").unwrap_err(),
            EncodeError::OutOfRange {
                field: "x",
                value: 1e20,
                limit: REQUEST_NUMBER_LIMIT
            }
        );
        assert!(matches!(
            format_request_number(f64::INFINITY, "y"),
            Err(EncodeError::NonFinite { field: "y", .. })
        ));
    }

    #[test]
    fn f10_3() {
        assert_eq!(format_f10_3(0.0), "     0.000");
        assert_eq!(format_f10_3(-0.0001), "     0.000");
        assert_eq!(format_f10_3(999999.999), "999999.999");
        assert_eq!(format_f10_3(-99999.999), "-99999.999");
        assert_eq!(format_f10_3(-999999.0), "**********");
        assert_eq!(format_f10_3(f64::NAN), "**********");
        assert_eq!(format_default_int(-31088), " -31088");
    }

    fn reference_f10_3(value: f64) -> String {
        let s = format!("{value:>10.3}");
        let s = if s.trim() == "-0.000" {
            format!("{:>10}", "0.000")
        } else {
            s
        };
        if s.len() > F10_WIDTH {
            F10_OVERFLOW.to_owned()
        } else {
            s
        }
    }

    proptest::proptest! {
        #![proptest_config(proptest::prelude::ProptestConfig::with_cases(20_000))]
        /// The integer fast path prints exactly what the exact float printer prints.
        #[test]
        fn integer_formatting_matches_the_float_printer(
            v in proptest::prelude::any::<f64>().prop_filter("finite", |v| v.is_finite()),
            k in -10_000_000_000i64..10_000_000_000,
            half in proptest::bool::ANY,
        ) {
            // Arbitrary doubles, and values on and next to the decimal ties.
            let near = k as f64 / 1000.0 + if half { 0.0005 } else { 0.0 };
            for x in [v, near, near.next_up(), near.next_down(), v / 1e6] {
                proptest::prop_assert_eq!(format_f10_3(x), reference_f10_3(x));
                if x.abs() < REQUEST_NUMBER_LIMIT {
                    let reference = trim_decimals(format!("{x:.3}"));
                    proptest::prop_assert_eq!(format_request_number(x, "x").unwrap(), reference);
                }
            }
        }
    }

    /// `VAL` through the general parser only (the reading before the short-decimal path).
    fn reference_val(text: &str) -> f64 {
        let s = text.trim_start_matches([' ', '\t']);
        let end = numeric_prefix_len(s.as_bytes());
        match s[..end].parse::<f64>().map(|v| v as f32) {
            Ok(v) if end > 0 && v.is_finite() => f64::from(v),
            _ => 0.0,
        }
    }

    proptest::proptest! {
        #![proptest_config(proptest::prelude::ProptestConfig::with_cases(4_000))]
        /// The short-decimal path reads exactly what the general parser reads (bit for bit,
        /// signed zeros included), whatever the digits, point, sign and trailing text.
        #[test]
        fn short_decimals_read_as_the_general_parser_reads(
            text in "[ \t]{0,2}[+-]?[0-9]{0,18}\\.?[0-9]{0,18}([eE][+-]?[0-9]{1,3})?[a-z ]{0,2}",
            v in proptest::prelude::any::<f64>().prop_filter("finite", |v| v.is_finite()),
            i in proptest::prelude::any::<i64>(),
            mix in "[-+.0-9eE \t]{0,14}",
        ) {
            for t in [text, mix, format!("{v}"), format!("{v:.3}"), format!("{i}"), format!("{:.6}", v / 1e300)] {
                proptest::prop_assert_eq!(as_val(&t).to_bits(), reference_val(&t).to_bits(), "{:?}", t);
            }
        }

        /// Reply fields read through the short-decimal path are the standard parser's doubles,
        /// bit for bit (signed zeros included); what it cannot read goes to that parser.
        #[test]
        fn reply_fields_read_as_the_standard_parser_reads(
            text in "[+-]?[0-9]{0,18}\\.?[0-9]{0,18}([eE][+-]?[0-9]{1,3})?",
            v in proptest::prelude::any::<f64>().prop_filter("finite", |v| v.is_finite()),
        ) {
            for t in [text, format!("{v}"), format!("{v:.3}"), format!("{:.3}", v / 1e300)] {
                let whole = !t.is_empty() && numeric_prefix_len(t.as_bytes()) == t.len();
                let reference = t.parse::<f64>().ok().filter(|x| whole && x.is_finite());
                proptest::prop_assert_eq!(parse_field(&t).map(f64::to_bits), reference.map(f64::to_bits), "{:?}", t);
            }
        }

        /// Integers are written as the standard formatter writes them.
        #[test]
        fn default_ints_match_the_formatter(v in proptest::prelude::any::<i64>()) {
            proptest::prop_assert_eq!(format_default_int(v), format!(" {v}"));
        }
    }

    #[test]
    fn short_decimal_edges() {
        for t in [
            "-0",
            "0.",
            "-.5",
            "999999999999999",
            "9999999999999999",
            "0.000000000000001",
            "1.",
            "+.0",
        ] {
            assert_eq!(as_val(t).to_bits(), reference_val(t).to_bits(), "{t}");
        }
        assert_eq!(format_default_int(i64::MIN), format!(" {}", i64::MIN));
        assert_eq!(format_default_int(0), " 0");
    }

    #[test]
    fn field_parsing() {
        assert_eq!(parse_field("12.500"), Some(12.5));
        assert_eq!(parse_field("1.0E-03"), Some(0.001));
        assert_eq!(parse_field("-1"), Some(-1.0));
        assert_eq!(parse_field("12abc"), None);
        assert_eq!(parse_field("**********"), None);
        assert_eq!(parse_field(""), None);
        assert_eq!(parse_field("inf"), None);
        assert_eq!(parse_field("NaN"), None);
    }

    proptest::proptest! {
        #![proptest_config(proptest::prelude::ProptestConfig::with_cases(20_000))]
        /// `VAL` reads every text bit for bit as the previous implementation read it: short
        /// decimals, long and odd texts, exponents, runs of signs and points, arbitrary bytes.
        #[test]
        fn val_matches_the_previous_implementation(
            short in "[ \t]{0,2}[+-]?[0-9]{0,9}\\.?[0-9]{0,9}[ a-zE.+-]{0,2}",
            long in "[ \t]{0,3}[+-]{0,2}[0-9]{0,20}\\.{0,2}[0-9]{0,20}([eE][+-]?[0-9]{0,4})?[.eE+-]{0,2}",
            mix in "[-+.0-9eE \t*x]{0,24}",
            bytes in proptest::collection::vec(proptest::prelude::any::<u8>(), 0..24),
            v in proptest::prelude::any::<f64>(),
            f in proptest::prelude::any::<f32>(),
        ) {
            let texts = [
                short.into_bytes(),
                long.into_bytes(),
                mix.into_bytes(),
                bytes,
                format!("{v}").into_bytes(),
                format!("{v:.3}").into_bytes(),
                format!("{v:e}").into_bytes(),
                format!("{f}").into_bytes(),
                format!("{:.6}", v / 1e300).into_bytes(),
            ];
            for t in texts {
                proptest::prop_assert_eq!(
                    as_val_bytes(&t).to_bits(),
                    reference::as_val_bytes(&t).to_bits(),
                    "{:?}", String::from_utf8_lossy(&t)
                );
                let new = short_decimal(&t).map(|(v, _)| v.to_bits());
                proptest::prop_assert_eq!(new, reference::short_decimal(&t).map(f64::to_bits));
            }
        }

        /// `/F10.3` and the default integer format write exactly the bytes the previous
        /// implementation wrote, for arbitrary doubles, values on and next to the decimal ties
        /// and at the edges of the field's width.
        #[test]
        fn reply_formats_match_the_previous_implementation(
            v in proptest::prelude::any::<f64>(),
            k in -1_000_000_000_000i64..1_000_000_000_000,
            half in proptest::bool::ANY,
            i in proptest::prelude::any::<i64>(),
            small in -100_000i64..100_000,
            width in 0u32..10,
            field in -1.0e6f64..1.0e6,
        ) {
            let near = k as f64 / 1000.0 + if half { 0.0005 } else { 0.0 };
            // Every number of integer digits, both signs.
            let sized = field / 10f64.powi(width as i32);
            for x in [v, near, near.next_up(), near.next_down(), v / 1e6, v / 1e300, -near, sized, -sized] {
                let mut old = Vec::new();
                reference::write_f10_3(&mut old, x);
                proptest::prop_assert_eq!(&f10_3_field(x)[..], &old[..], "{}", x);
                proptest::prop_assert_eq!(thousandths(x), reference::thousandths(x), "{}", x);
            }
            for n in [i, small, i >> 32] {
                let mut old = Vec::new();
                reference::write_default_int(&mut old, n);
                let mut new = [0u8; DEFAULT_INT_MAX];
                let len = put_default_int(&mut new, n);
                proptest::prop_assert_eq!(&new[..len], &old[..]);
            }
        }
    }

    #[test]
    fn reply_format_edges() {
        for x in [
            0.0,
            -0.0,
            f64::NAN,
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::MAX,
            f64::MIN_POSITIVE,
            999_999.999,
            999_999.999_5,
            999_999.999_4,
            1_000_000.0,
            -99_999.999,
            -99_999.999_5,
            -100_000.0,
            -0.0005,
            0.0005,
            -0.0004999,
            1.0e12 - 0.25,
            1.0e12,
            -1.0e12,
            2.5,
            0.0015,
        ] {
            let mut old = Vec::new();
            reference::write_f10_3(&mut old, x);
            assert_eq!(&f10_3_field(x)[..], &old[..], "{x}");
            assert_eq!(thousandths(x), reference::thousandths(x), "{x}");
        }
        for n in [0, -1, 9, -9, 10, -10, 1040, i64::MAX, i64::MIN] {
            let mut old = Vec::new();
            reference::write_default_int(&mut old, n);
            let mut new = [0u8; DEFAULT_INT_MAX];
            let len = put_default_int(&mut new, n);
            assert_eq!(&new[..len], &old[..], "{n}");
        }
    }
}
