//! Byte-level reading of a file: lines, blanks, the end of a `.PROGRAM` header, the end of a
//! program, and whether a line that loads without being parsed is well formed.

use crate::lexer::strip_comment_bytes;

/// Splits a file into lines (without their endings).
pub fn split_lines(bytes: &[u8]) -> Vec<&[u8]> {
    if !bytes.contains(&b'\n') && bytes.contains(&b'\r') {
        return bytes.split(|&b| b == b'\r').collect();
    }
    bytes
        .split(|&b| b == b'\n')
        .map(|l| l.strip_suffix(b"\r").unwrap_or(l))
        .collect()
}

/// Bytes of blank at the start of `code` (blanks, tabs, a byte-order mark, the end-of-file
/// byte 0x1A some editors leave).
pub(super) fn leading_blank(code: &[u8]) -> usize {
    let mut i = 0;
    loop {
        match code.get(i..) {
            Some([b' ' | b'\t' | b'\x0c' | b'\x1a', ..]) => i += 1,
            // The byte order mark, the ideographic space and the no-break space: blanks, as
            // the lexer reads them.
            Some([0xEF, 0xBB, 0xBF, ..] | [0xE3, 0x80, 0x80, ..]) => i += 3,
            Some([0xC2, 0xA0, ..]) => i += 2,
            _ => return i,
        }
    }
}

/// `code` without blanks around it, and the offset where it starts.
pub(super) fn trim_blanks(code: &[u8]) -> (&[u8], usize) {
    let start = leading_blank(code);
    let mut end = code.len();
    while end > start && matches!(code[end - 1], b' ' | b'\t' | b'\x0c' | b'\x1a') {
        end -= 1;
    }
    (&code[start..end], start)
}

/// Where the saved decorations after a `.PROGRAM` header start: a `@` (edit time) or a `#`
/// followed by a digit (step-number marker). Parameters never hold either.
pub(crate) fn header_end(rest: &[u8]) -> Option<usize> {
    (0..rest.len()).find(|&k| {
        rest[k] == b'@' || (rest[k] == b'#' && rest.get(k + 1).is_some_and(u8::is_ascii_digit))
    })
}

pub(super) fn truncate(s: &str, n: usize) -> String {
    if s.chars().count() <= n {
        s.to_owned()
    } else {
        let mut t: String = s.chars().take(n).collect();
        t.push('…');
        t
    }
}

/// `true` when the line is exactly `.END` (any case, blanks and a comment allowed).
pub(super) fn is_end_line(line: &[u8]) -> bool {
    trim_blanks(strip_comment_bytes(line))
        .0
        .eq_ignore_ascii_case(b".end")
}

/// Whether the arguments of a line that loads without being parsed are well formed: strings
/// closed, parentheses and brackets balanced and properly nested, and nothing but ASCII outside
/// strings (the blanks the lexer reads as blanks excepted). `Err` holds the offset of the
/// fault and what it is.
pub(super) fn well_formed(args: &[u8]) -> Result<(), (usize, String)> {
    let mut open: Vec<(u8, usize)> = Vec::new();
    let mut k = 0;
    while k < args.len() {
        match args[k] {
            b'"' => match args[k + 1..].iter().position(|&b| b == b'"') {
                Some(n) => k += n + 1,
                None => return Err((k, "this string is not closed (a \" is missing)".into())),
            },
            b'(' | b'[' => open.push((args[k], k)),
            b')' | b']' => {
                let want = if args[k] == b')' { b'(' } else { b'[' };
                match open.pop() {
                    Some((o, _)) if o == want => {}
                    Some(_) => {
                        return Err((k, "this bracket closes another kind of bracket".into()))
                    }
                    None => return Err((k, "this bracket closes nothing".into())),
                }
            }
            b if b >= 0x80 => {
                // No-break space, ideographic space, byte order mark: blanks.
                let blank = [&b"\xc2\xa0"[..], b"\xe3\x80\x80", b"\xef\xbb\xbf"]
                    .into_iter()
                    .find(|s| args[k..].starts_with(s));
                match blank {
                    Some(s) => k += s.len() - 1,
                    None => {
                        return Err((
                            k,
                            format!(
                            "unexpected character byte 0x{b:02X} (outside a string or a comment)"
                        ),
                        ))
                    }
                }
            }
            _ => {}
        }
        k += 1;
    }
    match open.pop() {
        Some((_, at)) => Err((at, "this bracket is not closed".into())),
        None => Ok(()),
    }
}
