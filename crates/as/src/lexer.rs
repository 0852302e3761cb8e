//! Tokens of one AS source line.
//!
//! AS is line-oriented: a statement never spans lines, so the lexer works on one line at a
//! time (the line ending, `\n` or `\r\n`, already removed). A `;` outside a string starts a
//! comment that runs to the end of the line. Names are case-insensitive and kept in lower
//! case; they may contain letters, digits, `_` and `.` (`autostart.pc`, `abs.speed`), and carry
//! a type sigil (`$` string, `#` joint point) and a leading `.` for program-local variables
//! (`.$buf`, `.#p`, `.count`).

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

/// A token with the column (1-based, in characters) where it starts.
#[derive(Debug, Clone, PartialEq)]
pub struct Token {
    /// The token.
    pub tok: Tok,
    /// Where it starts.
    pub span: Span,
}

/// Longest name accepted (the controller allows 15 characters; saved files from other tools
/// may carry longer ones, which are kept).
pub const MAX_NAME: usize = 64;

/// Longest string literal, bytes (an AS string holds at most 255 characters).
pub const MAX_STRING: usize = 255;

fn is_name_char(c: char) -> bool {
    c.is_ascii_alphanumeric() || c == '_' || c == '.'
}

/// Splits off the comment: returns the code part of a line (a `;` inside a string does not
/// start a comment).
pub fn strip_comment(line: &str) -> &str {
    let mut in_str = false;
    for (i, c) in line.char_indices() {
        match c {
            '"' => in_str = !in_str,
            ';' if !in_str => return &line[..i],
            _ => {}
        }
    }
    line
}

/// Tokenizes the code part of one line (`line_no` is 1-based). `file` names the source in
/// errors.
pub fn tokenize(file: &str, line_no: u32, code: &str) -> Result<Vec<Token>, ParseError> {
    let chars: Vec<char> = code.chars().collect();
    let mut out: Vec<Token> = Vec::new();
    let mut i = 0;
    let err =
        |col: usize, msg: String| ParseError::new(file, Span::new(line_no, col as u32 + 1), msg);
    while i < chars.len() {
        let c = chars[i];
        let start = i;
        let span = Span::new(line_no, i as u32 + 1);
        if c == ' ' || c == '\t' || c == '\u{feff}' {
            i += 1;
            continue;
        }
        let prev_operand = out.last().is_some_and(|t| t.tok.ends_operand());
        let tok = match c {
            '"' => {
                let mut j = i + 1;
                while j < chars.len() && chars[j] != '"' {
                    j += 1;
                }
                if j >= chars.len() {
                    return Err(err(start, "expected a closing \" to end the string".into()));
                }
                let s: String = chars[i + 1..j].iter().collect();
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
                Tok::Str(s.into_bytes())
            }
            '0'..='9' => {
                let (v, len) = lex_number(&chars[i..]);
                i += len;
                Tok::Num(v)
            }
            '.' if chars.get(i + 1).is_some_and(|d| d.is_ascii_digit()) => {
                let (v, len) = lex_number(&chars[i..]);
                i += len;
                Tok::Num(v)
            }
            '^' if !prev_operand
                && matches!(chars.get(i + 1), Some('H' | 'h' | 'B' | 'b'))
                && chars.get(i + 2).is_some_and(|d| d.is_ascii_hexdigit()) =>
            {
                let radix = if matches!(chars[i + 1], 'H' | 'h') {
                    16
                } else {
                    2
                };
                let mut j = i + 2;
                while j < chars.len() && chars[j].is_ascii_alphanumeric() {
                    j += 1;
                }
                let digits: String = chars[i + 2..j].iter().collect();
                let v = u64::from_str_radix(&digits, radix).map_err(|_| {
                    err(
                        start,
                        format!(
                            "\"^{}{digits}\" is not a {} number",
                            chars[i + 1],
                            if radix == 16 { "hexadecimal" } else { "binary" }
                        ),
                    )
                })?;
                i = j;
                Tok::Num(v as f64)
            }
            '.' | '$' | '#' | 'a'..='z' | 'A'..='Z' | '_' => {
                let mut j = i;
                let mut local = false;
                if chars[j] == '.' {
                    local = true;
                    j += 1;
                    // `.&name`: a by-reference parameter.
                    if chars.get(j) == Some(&'&') {
                        out.push(Token {
                            tok: Tok::Amp,
                            span,
                        });
                        j += 1;
                    }
                }
                let sigil = match chars.get(j) {
                    Some('$') => {
                        j += 1;
                        Sigil::Dollar
                    }
                    Some('#') => {
                        j += 1;
                        Sigil::Hash
                    }
                    _ => Sigil::None,
                };
                if !chars
                    .get(j)
                    .is_some_and(|c| c.is_ascii_alphabetic() || *c == '_')
                {
                    return Err(err(
                        j.min(chars.len()),
                        "expected a name (a letter first)".into(),
                    ));
                }
                let name_start = j;
                while j < chars.len() && is_name_char(chars[j]) {
                    j += 1;
                }
                // A name does not end with a dot (`a.` then something else).
                while j > name_start + 1 && chars[j - 1] == '.' {
                    j -= 1;
                }
                let text: String = chars[name_start..j]
                    .iter()
                    .collect::<String>()
                    .to_lowercase();
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
            '(' => {
                i += 1;
                Tok::LParen
            }
            ')' => {
                i += 1;
                Tok::RParen
            }
            '[' => {
                i += 1;
                Tok::LBracket
            }
            ']' => {
                i += 1;
                Tok::RBracket
            }
            ',' => {
                i += 1;
                Tok::Comma
            }
            ':' => {
                i += 1;
                Tok::Colon
            }
            '+' => {
                i += 1;
                Tok::Plus
            }
            '-' => {
                i += 1;
                Tok::Minus
            }
            '*' => {
                i += 1;
                Tok::Star
            }
            '/' => {
                i += 1;
                Tok::Slash
            }
            '^' => {
                i += 1;
                Tok::Caret
            }
            '&' => {
                i += 1;
                Tok::Amp
            }
            '=' => {
                if chars.get(i + 1) == Some(&'=') {
                    i += 2;
                    Tok::Eq
                } else if chars.get(i + 1) == Some(&'<') {
                    i += 2;
                    Tok::Le
                } else if chars.get(i + 1) == Some(&'>') {
                    i += 2;
                    Tok::Ge
                } else {
                    i += 1;
                    Tok::Assign
                }
            }
            '<' => match chars.get(i + 1) {
                Some('>') => {
                    i += 2;
                    Tok::Ne
                }
                Some('=') => {
                    i += 2;
                    Tok::Le
                }
                _ => {
                    i += 1;
                    Tok::Lt
                }
            },
            '>' => {
                if chars.get(i + 1) == Some(&'=') {
                    i += 2;
                    Tok::Ge
                } else {
                    i += 1;
                    Tok::Gt
                }
            }
            other => {
                return Err(err(
                    start,
                    format!("unexpected character {other:?} (outside a string or a comment)"),
                ))
            }
        };
        out.push(Token { tok, span });
    }
    Ok(out)
}

/// A decimal number at the start of `chars` (digits, optional fraction, optional exponent
/// with at least one digit): its value and length in characters.
fn lex_number(chars: &[char]) -> (f64, usize) {
    let mut j = 0;
    while j < chars.len() && chars[j].is_ascii_digit() {
        j += 1;
    }
    if j < chars.len() && chars[j] == '.' && chars.get(j + 1).is_some_and(|c| c.is_ascii_digit()) {
        j += 1;
        while j < chars.len() && chars[j].is_ascii_digit() {
            j += 1;
        }
    } else if j < chars.len()
        && chars[j] == '.'
        && !chars.get(j + 1).is_some_and(|c| is_name_char(*c))
    {
        // "5." — a trailing point.
        j += 1;
    }
    if j < chars.len() && matches!(chars[j], 'e' | 'E') {
        let mut k = j + 1;
        if k < chars.len() && matches!(chars[k], '+' | '-') {
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
    let text: String = chars[..j].iter().collect();
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
