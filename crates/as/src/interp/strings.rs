//! String helpers of the AS functions (`VAL`, `$DECODE`, `INSTR`).

use fs020n_proto::number::as_val;

use crate::error::RuntimeError;

use super::arith::R;

/// AS `VAL`: decimal through fs020n-proto's `as_val` (the protocol server's own reading),
/// `^H`/`^B` prefixes, and radix codes 1 (binary) and 2 (hexadecimal).
pub(super) fn val(s: &[u8], radix: f32) -> R<f32> {
    // Leading blanks are cut on the bytes (ASCII: the same as on the text).
    let start = s
        .iter()
        .position(|&c| c != b' ' && c != b'\t')
        .unwrap_or(s.len());
    let s = &s[start..];
    // Valid UTF-8 (the usual case) is read in place; `from_utf8_lossy` gives the same text
    // but walks it chunk by chunk.
    let text = match std::str::from_utf8(s) {
        Ok(t) => std::borrow::Cow::Borrowed(t),
        Err(_) => String::from_utf8_lossy(s),
    };
    // A decimal number (no `^H`/`^B` prefix, radix code 0: `trunc(radix)` is 0, NaN
    // included): straight to the protocol's reading.
    if s.first() != Some(&b'^') && !(radix <= -1.0 || radix >= 1.0) {
        return Ok(as_val(&text) as f32);
    }
    let t = &*text;
    let (radix, digits) = if let Some(rest) = t.strip_prefix("^H").or_else(|| t.strip_prefix("^h"))
    {
        (16, rest)
    } else if let Some(rest) = t.strip_prefix("^B").or_else(|| t.strip_prefix("^b")) {
        (2, rest)
    } else {
        match radix.trunc() as i32 {
            0 => return Ok(as_val(t) as f32),
            1 => (2, t),
            2 => (16, t),
            other => {
                return Err(Box::new(RuntimeError::IllegalValue(format!(
                    "VAL radix code {other} (0, 1 or 2)"
                ))))
            }
        }
    };
    let end = digits
        .find(|c: char| !c.is_digit(radix))
        .unwrap_or(digits.len());
    Ok(u64::from_str_radix(&digits[..end.min(16)], radix).map_or(0.0, |v| v as f32))
}

/// `$DECODE`: where the token ends (mode ≤ 0: at the first delimiter; else at the first byte
/// that is not one). Delimiters match regardless of ASCII case.
#[inline]
pub(super) fn decode_cut(s: &[u8], d: &[u8], mode: f32) -> usize {
    if let [x] = d {
        if !x.is_ascii_alphabetic() {
            // No case to ignore (the server's blank).
            return if mode <= 0.0 {
                s.iter().position(|c| c == x).unwrap_or(s.len())
            } else {
                s.iter().position(|c| c != x).unwrap_or(s.len())
            };
        }
    }
    let one = match d {
        [x] => Some(x.to_ascii_lowercase()),
        _ => None,
    };
    let is_delim = |c: u8| match one {
        Some(x) => c.to_ascii_lowercase() == x,
        None => d.iter().any(|x| x.eq_ignore_ascii_case(&c)),
    };
    if mode <= 0.0 {
        s.iter().position(|&c| is_delim(c)).unwrap_or(s.len())
    } else {
        s.iter().position(|&c| !is_delim(c)).unwrap_or(s.len())
    }
}

/// `INSTR`: 1-based position of `sub` in `s` at or after `start`, 0 when absent.
pub(super) fn instr(s: &[u8], sub: &[u8], start: usize) -> usize {
    let from = start.saturating_sub(1);
    if from > s.len() {
        return 0;
    }
    if sub.is_empty() {
        return 0;
    }
    s[from..]
        .windows(sub.len())
        .position(|w| w == sub)
        .map_or(0, |p| p + from + 1)
}
