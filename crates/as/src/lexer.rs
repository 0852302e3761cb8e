//! Tokens of one AS source line.
//!
//! AS is line-oriented: a statement never spans lines, so the lexer works on one line at a
//! time (the line ending, `\n` or `\r\n`, already removed). A line is **bytes** in whatever
//! code page the file was saved in ([`tokenize_bytes`]; [`tokenize`] takes text): names,
//! numbers and operators are ASCII, string literals keep their bytes as written. A `;` outside
//! a string starts a comment that runs to the end of the line. Names are case-insensitive and
//! kept in lower case; they may contain letters, digits, `_` and `.` (`autostart.pc`,
//! `abs.speed`), and carry a type sigil (`$` string, `#` joint point) and a leading `.` for
//! program-local variables (`.$buf`, `.#p`, `.count`). `!=` is read as `<>`, `|` as `OR`.

use crate::error::ParseError;
use crate::span::Span;

/// The type sigil in front of a name.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Sigil {
    /// No sigil: a real (or, where a location is expected, a transformation).
    None,
    /// `$`: a string.
    Dollar,
    /// `#`: a joint-displacement point.
    Hash,
}

/// A name as written: `ros_cmd`, `.$buf`, `#ppoint`, `$decode`.
#[derive(Debug, Clone, PartialEq, Eq, Hash)]
pub struct Name {
    /// Program-local (written with a leading `.`).
    pub local: bool,
    /// Type sigil.
    pub sigil: Sigil,
    /// The name without `.`/sigil, in lower case.
    pub text: String,
}

impl std::fmt::Display for Name {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        if self.local {
            f.write_str(".")?;
        }
        match self.sigil {
            Sigil::None => {}
            Sigil::Dollar => f.write_str("$")?,
            Sigil::Hash => f.write_str("#")?,
        }
        f.write_str(&self.text)
    }
}

/// One token.
#[derive(Debug, Clone, PartialEq)]
pub enum Tok {
    /// A name (variable, keyword, function or program name).
    Name(Name),
    /// A number literal (decimal, `^H` hexadecimal or `^B` binary).
    Num(f64),
    /// A string literal (the bytes between the quotes).
    Str(Vec<u8>),
    /// `(`
    LParen,
    /// `)`
    RParen,
    /// `[`
    LBracket,
    /// `]`
    RBracket,
    /// `,`
    Comma,
    /// `:`
    Colon,
    /// `=`
    Assign,
    /// `==`
    Eq,
    /// `<>`
    Ne,
    /// `<`
    Lt,
    /// `>`
    Gt,
    /// `<=`
    Le,
    /// `>=`
    Ge,
    /// `+`
    Plus,
    /// `-`
    Minus,
    /// `*`
    Star,
    /// `/`
    Slash,
    /// `^`
    Caret,
    /// `&`
    Amp,
    /// `|` (logical OR, as some editors write it).
    Bar,
    /// `#[`: a joint-value constant `#[j1, j2, …]`, closed by `]`.
    HashBracket,
}

impl Tok {
    /// How the token reads in an error message.
    pub fn describe(&self) -> String {
        match self {
            Tok::Name(n) => format!("\"{n}\""),
            Tok::Num(v) => format!("the number {v}"),
            Tok::Str(s) => format!("the string \"{}\"", String::from_utf8_lossy(s)),
            Tok::LParen => "\"(\"".into(),
            Tok::RParen => "\")\"".into(),
            Tok::LBracket => "\"[\"".into(),
            Tok::RBracket => "\"]\"".into(),
            Tok::Comma => "\",\"".into(),
            Tok::Colon => "\":\"".into(),
            Tok::Assign => "\"=\"".into(),
            Tok::Eq => "\"==\"".into(),
            Tok::Ne => "\"<>\"".into(),
            Tok::Lt => "\"<\"".into(),
            Tok::Gt => "\">\"".into(),
            Tok::Le => "\"<=\"".into(),
            Tok::Ge => "\">=\"".into(),
            Tok::Plus => "\"+\"".into(),
            Tok::Minus => "\"-\"".into(),
            Tok::Star => "\"*\"".into(),
            Tok::Slash => "\"/\"".into(),
            Tok::Caret => "\"^\"".into(),
            Tok::Amp => "\"&\"".into(),
            Tok::Bar => "\"|\"".into(),
            Tok::HashBracket => "\"#[\"".into(),
        }
    }

    /// `true` for a token after which a value has ended (so `^H…` is the power operator).
    fn ends_operand(&self) -> bool {
        matches!(
            self,
            Tok::Name(_) | Tok::Num(_) | Tok::Str(_) | Tok::RParen | Tok::RBracket
        )
    }
}

/// A token with the column where it starts (1-based; see [`columns`]).
#[derive(Debug, Clone, PartialEq)]
pub struct Token {
    /// The token.
    pub tok: Tok,
    /// Where it starts.
    pub span: Span,
}

/// Longest name accepted (the controller keeps 15 characters; files from other tools may
/// carry longer ones, which load and are linted: [`crate::lint`]).
pub const MAX_NAME: usize = 64;

/// Longest string literal, bytes (an AS string holds at most 255 characters).
pub const MAX_STRING: usize = 255;

fn is_name_byte(c: u8) -> bool {
    c.is_ascii_alphanumeric() || c == b'_' || c == b'.'
}

/// Splits off the comment: returns the code part of a line (a `;` inside a string does not
/// start a comment).
pub fn strip_comment(line: &str) -> &str {
    let code = strip_comment_bytes(line.as_bytes());
    // `;` and `"` are ASCII, so the cut falls on a character boundary.
    line.get(..code.len()).unwrap_or(line)
}

/// [`strip_comment`] on the bytes of a line, in any encoding: `"` and `;` are never the
/// second byte of a Shift-JIS or GBK character, so the cut is right for those code pages too.
pub fn strip_comment_bytes(line: &[u8]) -> &[u8] {
    let mut in_str = false;
    for (i, &c) in line.iter().enumerate() {
        match c {
            b'"' => in_str = !in_str,
            b';' if !in_str => return &line[..i],
            _ => {}
        }
    }
    line
}

/// Columns of a line: the 1-based column of each byte offset (and of the end). A line that is
/// valid UTF-8 counts characters; a line in another code page counts bytes (a Shift-JIS or GBK
/// character takes two columns, as wide as an editor shows it).
pub fn columns(line: &[u8]) -> Vec<u32> {
    let utf8 = std::str::from_utf8(line).is_ok();
    let mut out = Vec::with_capacity(line.len() + 1);
    let mut col = 1u32;
    for &b in line {
        out.push(col);
        if !(utf8 && (0x80..0xC0).contains(&b)) {
            col = col.saturating_add(1);
        }
    }
    // A continuation byte shares its character's column.
    if utf8 {
        for k in 0..line.len() {
            if (0x80..0xC0).contains(&line[k]) && k > 0 {
                out[k] = out[k - 1];
            }
        }
    }
    out.push(col);
    out
}

/// Blanks between tokens: space, tab, a byte-order mark, and the no-break and ideographic
/// spaces an editor may leave (these two are linted: the controller takes only ASCII).
fn blank_len(code: &[u8], i: usize) -> usize {
    match code[i] {
        b' ' | b'\t' | b'\x0c' | b'\x1a' => 1,
        0xEF if code.get(i + 1..i + 3) == Some(&[0xBB, 0xBF]) => 3,
        0xE3 if code.get(i + 1..i + 3) == Some(&[0x80, 0x80]) => 3,
        0xC2 if code.get(i + 1) == Some(&0xA0) => 2,
        _ => 0,
    }
}

/// Tokenizes the code part of one line (`line_no` is 1-based). `file` names the source in
/// errors.
pub fn tokenize(file: &str, line_no: u32, code: &str) -> Result<Vec<Token>, ParseError> {
    tokenize_bytes(file, line_no, code.as_bytes(), &columns(code.as_bytes()))
}

/// Tokenizes the code part of one line given as bytes; `cols` are the line's [`columns`] (a
/// table at least one longer than `code`). String literals keep their bytes as written.
pub fn tokenize_bytes(
    file: &str,
    line_no: u32,
    code: &[u8],
    cols: &[u32],
) -> Result<Vec<Token>, ParseError> {
    let chars = code;
    let col = |i: usize| cols.get(i).or(cols.last()).copied().unwrap_or(1);
    let mut out: Vec<Token> = Vec::new();
    let mut i = 0;
    let err = |at: usize, msg: String| ParseError::new(file, Span::new(line_no, col(at)), msg);
    while i < chars.len() {
        let c = chars[i];
        let start = i;
        let span = Span::new(line_no, col(i));
        let blank = blank_len(chars, i);
        if blank > 0 {
            i += blank;
            continue;
        }
        let prev_operand = out.last().is_some_and(|t| t.tok.ends_operand());
        let tok = match c {
            b'"' => {
                let mut j = i + 1;
                while j < chars.len() && chars[j] != b'"' {
                    j += 1;
                }
                if j >= chars.len() {
                    return Err(err(start, "expected a closing \" to end the string".into()));
                }
                let s = unescape(&chars[i + 1..j]);
                if s.len() > MAX_STRING {
                    return Err(err(
                        start,
                        format!(
                            "a string literal holds at most {MAX_STRING} bytes, this one has {}",
                            s.len()
                        ),
                    ));
                }
                i = j + 1;
                Tok::Str(s)
            }
            b'0'..=b'9' => {
                let (v, len) = lex_number(&chars[i..]);
                i += len;
                Tok::Num(v)
            }
            b'.' if chars.get(i + 1).is_some_and(|d| d.is_ascii_digit()) => {
                let (v, len) = lex_number(&chars[i..]);
                i += len;
                Tok::Num(v)
            }
            b'^' if !prev_operand
                && matches!(chars.get(i + 1), Some(b'H' | b'h' | b'B' | b'b'))
                && chars.get(i + 2).is_some_and(|d| d.is_ascii_hexdigit()) =>
            {
                let radix = if matches!(chars[i + 1], b'H' | b'h') {
                    16
                } else {
                    2
                };
                let mut j = i + 2;
                while j < chars.len() && chars[j].is_ascii_alphanumeric() {
                    j += 1;
                }
                let digits = String::from_utf8_lossy(&chars[i + 2..j]).into_owned();
                let v = u64::from_str_radix(&digits, radix).map_err(|_| {
                    err(
                        start,
                        format!(
                            "\"^{}{digits}\" is not a {} number",
                            chars[i + 1] as char,
                            if radix == 16 { "hexadecimal" } else { "binary" }
                        ),
                    )
                })?;
                i = j;
                Tok::Num(v as f64)
            }
            b'#' if chars.get(i + 1) == Some(&b'[') => {
                i += 2;
                Tok::HashBracket
            }
            b'.' | b'$' | b'#' | b'@' | b'a'..=b'z' | b'A'..=b'Z' | b'_' => {
                let mut j = i;
                let mut local = false;
                if chars[j] == b'.' {
                    local = true;
                    j += 1;
                    // `.&name`: a by-reference parameter.
                    if chars.get(j) == Some(&b'&') {
                        out.push(Token {
                            tok: Tok::Amp,
                            span,
                        });
                        j += 1;
                    }
                }
                // `@name`: an integer variable (UTIMER, EXIST…INTEGER). Integers are whole
                // reals here: the name keeps its `@` and is read as a real variable.
                let integer = chars.get(j) == Some(&b'@');
                if integer {
                    j += 1;
                }
                let sigil = match chars.get(j) {
                    Some(b'$') if !integer => {
                        j += 1;
                        Sigil::Dollar
                    }
                    Some(b'#') if !integer => {
                        j += 1;
                        Sigil::Hash
                    }
                    _ => Sigil::None,
                };
                if !chars
                    .get(j)
                    .is_some_and(|c| c.is_ascii_alphabetic() || *c == b'_')
                {
                    return Err(err(
                        j.min(chars.len()),
                        "expected a name (a letter first)".into(),
                    ));
                }
                let name_start = j;
                while j < chars.len() && is_name_byte(chars[j]) {
                    j += 1;
                }
                // A name does not end with a dot (`a.` then something else).
                while j > name_start + 1 && chars[j - 1] == b'.' {
                    j -= 1;
                }
                // ASCII only, so the bytes are text.
                let mut text = String::from_utf8_lossy(&chars[name_start..j]).to_ascii_lowercase();
                if integer {
                    text.insert(0, '@');
                }
                if text.len() > MAX_NAME {
                    return Err(err(
                        start,
                        format!(
                            "a name has at most {MAX_NAME} characters, this one has {}",
                            text.len()
                        ),
                    ));
                }
                i = j;
                Tok::Name(Name { local, sigil, text })
            }
            b'(' => {
                i += 1;
                Tok::LParen
            }
            b')' => {
                i += 1;
                Tok::RParen
            }
            b'[' => {
                i += 1;
                Tok::LBracket
            }
            b']' => {
                i += 1;
                Tok::RBracket
            }
            b',' => {
                i += 1;
                Tok::Comma
            }
            b':' => {
                i += 1;
                Tok::Colon
            }
            b'+' => {
                i += 1;
                Tok::Plus
            }
            b'-' => {
                i += 1;
                Tok::Minus
            }
            b'*' => {
                i += 1;
                Tok::Star
            }
            b'/' => {
                i += 1;
                Tok::Slash
            }
            b'^' => {
                i += 1;
                Tok::Caret
            }
            // `&&` and `||`: AND and OR as newer controllers' programs write them.
            b'&' if chars.get(i + 1) == Some(&b'&') => {
                i += 2;
                Tok::Name(Name {
                    local: false,
                    sigil: Sigil::None,
                    text: "and".into(),
                })
            }
            b'&' => {
                i += 1;
                Tok::Amp
            }
            b'|' => {
                i += if chars.get(i + 1) == Some(&b'|') {
                    2
                } else {
                    1
                };
                Tok::Bar
            }
            b'!' if chars.get(i + 1) == Some(&b'=') => {
                i += 2;
                Tok::Ne
            }
            b'=' => {
                if chars.get(i + 1) == Some(&b'=') {
                    i += 2;
                    Tok::Eq
                } else if chars.get(i + 1) == Some(&b'<') {
                    i += 2;
                    Tok::Le
                } else if chars.get(i + 1) == Some(&b'>') {
                    i += 2;
                    Tok::Ge
                } else {
                    i += 1;
                    Tok::Assign
                }
            }
            b'<' => match chars.get(i + 1) {
                Some(b'>') => {
                    i += 2;
                    Tok::Ne
                }
                Some(b'=') => {
                    i += 2;
                    Tok::Le
                }
                _ => {
                    i += 1;
                    Tok::Lt
                }
            },
            b'>' => {
                if chars.get(i + 1) == Some(&b'=') {
                    i += 2;
                    Tok::Ge
                } else {
                    i += 1;
                    Tok::Gt
                }
            }
            other => {
                let shown = match std::str::from_utf8(&chars[i..]) {
                    Ok(s) => s.chars().next().map(|c| format!("{c:?}")),
                    Err(e) if e.valid_up_to() > 0 => {
                        std::str::from_utf8(&chars[i..i + e.valid_up_to()])
                            .ok()
                            .and_then(|s| s.chars().next())
                            .map(|c| format!("{c:?}"))
                    }
                    Err(_) => None,
                };
                let shown = match shown {
                    Some(s) if other.is_ascii() || other >= 0xC0 => s,
                    _ => format!("byte 0x{other:02X}"),
                };
                return Err(err(
                    start,
                    format!("unexpected character {shown} (outside a string or a comment)"),
                ));
            }
        };
        out.push(Token { tok, span });
    }
    Ok(out)
}

/// The bytes of a string constant, its backslash escapes read: `\n` LF, `\r` CR, `\t` TAB,
/// `\\` a backslash, `\ooo` (three octal digits) that byte — the form controllers save
/// non-printing bytes in (`"\005"`, observed in public saves; the E manual says control
/// characters cannot be written, later controllers' programs send `"ALIVE\n"` as a line).
/// Any other backslash stays as it is.
pub(crate) fn unescape(text: &[u8]) -> Vec<u8> {
    let mut out = Vec::with_capacity(text.len());
    let mut k = 0;
    while k < text.len() {
        let c = text[k];
        if c != b'\\' || k + 1 >= text.len() {
            out.push(c);
            k += 1;
            continue;
        }
        let octal = text
            .get(k + 1..k + 4)
            .filter(|d| d.iter().all(|b| (b'0'..=b'7').contains(b)));
        let simple = match text[k + 1] {
            b'n' => Some(b'\n'),
            b'r' => Some(b'\r'),
            b't' => Some(b'\t'),
            b'\\' => Some(b'\\'),
            _ => None,
        };
        if let Some(d) = octal {
            let v = d.iter().fold(0u32, |v, b| v * 8 + u32::from(b - b'0'));
            out.push(u8::try_from(v).unwrap_or(u8::MAX));
            k += 4;
        } else if let Some(b) = simple {
            out.push(b);
            k += 2;
        } else {
            out.push(c);
            k += 1;
        }
    }
    out
}

/// A decimal number at the start of `chars` (digits, optional fraction, optional exponent
/// with at least one digit): its value and length in bytes.
fn lex_number(chars: &[u8]) -> (f64, usize) {
    let mut j = 0;
    while j < chars.len() && chars[j].is_ascii_digit() {
        j += 1;
    }
    if j < chars.len() && chars[j] == b'.' && chars.get(j + 1).is_some_and(|c| c.is_ascii_digit()) {
        j += 1;
        while j < chars.len() && chars[j].is_ascii_digit() {
            j += 1;
        }
    } else if j < chars.len()
        && chars[j] == b'.'
        && !chars.get(j + 1).is_some_and(|c| is_name_byte(*c))
    {
        // "5." — a trailing point.
        j += 1;
    }
    if j < chars.len() && matches!(chars[j], b'e' | b'E') {
        let mut k = j + 1;
        if k < chars.len() && matches!(chars[k], b'+' | b'-') {
            k += 1;
        }
        let digits = k;
        while k < chars.len() && chars[k].is_ascii_digit() {
            k += 1;
        }
        if k > digits && !chars.get(k).is_some_and(|c| c.is_ascii_alphabetic()) {
            j = k;
        }
    }
    let text = String::from_utf8_lossy(&chars[..j]);
    let v = text.trim_end_matches('.').parse::<f64>().unwrap_or(0.0);
    (if v.is_finite() { v } else { f64::MAX }, j)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn toks(s: &str) -> Vec<Tok> {
        tokenize("t.as", 1, strip_comment(s))
            .unwrap()
            .into_iter()
            .map(|t| t.tok)
            .collect()
    }

    fn name(local: bool, sigil: Sigil, text: &str) -> Tok {
        Tok::Name(Name {
            local,
            sigil,
            text: text.into(),
        })
    }

    #[test]
    fn names_numbers_and_operators() {
        assert_eq!(
            toks(".$buf[1] = $DECODE(.$data, \" ;\", 0) ; a comment ; more"),
            vec![
                name(true, Sigil::Dollar, "buf"),
                Tok::LBracket,
                Tok::Num(1.0),
                Tok::RBracket,
                Tok::Assign,
                name(false, Sigil::Dollar, "decode"),
                Tok::LParen,
                name(true, Sigil::Dollar, "data"),
                Tok::Comma,
                Tok::Str(b" ;".to_vec()),
                Tok::Comma,
                Tok::Num(0.0),
                Tok::RParen,
            ]
        );
        assert_eq!(
            toks("MC EXEC autostart.pc"),
            vec![
                name(false, Sigil::None, "mc"),
                name(false, Sigil::None, "exec"),
                name(false, Sigil::None, "autostart.pc")
            ]
        );
        assert_eq!(
            toks("a<>.5 <= 1.5E-3 >= 2e b==^HFF^2"),
            vec![
                name(false, Sigil::None, "a"),
                Tok::Ne,
                Tok::Num(0.5),
                Tok::Le,
                Tok::Num(1.5e-3),
                Tok::Ge,
                Tok::Num(2.0),
                name(false, Sigil::None, "e"),
                name(false, Sigil::None, "b"),
                Tok::Eq,
                Tok::Num(255.0),
                Tok::Caret,
                Tok::Num(2.0)
            ]
        );
        assert_eq!(
            toks("$ENCODE(/F10.3, x)"),
            vec![
                name(false, Sigil::Dollar, "encode"),
                Tok::LParen,
                Tok::Slash,
                name(false, Sigil::None, "f10.3"),
                Tok::Comma,
                name(false, Sigil::None, "x"),
                Tok::RParen
            ]
        );
        assert_eq!(toks("#PPOINT(1)")[0], name(false, Sigil::Hash, "ppoint"));
        assert_eq!(toks("5."), vec![Tok::Num(5.0)]);
        assert_eq!(toks("^B101"), vec![Tok::Num(5.0)]);
    }

    #[test]
    fn errors_name_the_column() {
        let e = tokenize("f.as", 3, "a = \"open").unwrap_err();
        assert_eq!(
            e.to_string(),
            "f.as:3:5: expected a closing \" to end the string"
        );
        let e = tokenize("f.as", 2, "a = b ? c").unwrap_err();
        assert_eq!(e.span.col, 7);
        let e = tokenize("f.as", 2, "é = 1").unwrap_err();
        assert_eq!(e.span.col, 1);
        assert!(tokenize("f.as", 1, "x = \"é\"").is_ok());
    }
}
