//! Print format codes (`/F10.3`, `/I5`, `/S`…): after a `/` in PRINT, TYPE and `$ENCODE`.

use crate::ast::FormatCode;
use crate::error::ParseError;
use crate::lexer::{Sigil, Tok};
use crate::span::Span;

use super::cursor::{Cur, PResult};

impl Cur<'_> {
    pub(super) fn format_code(&mut self, span: Span) -> PResult<FormatCode> {
        let text = match self.next().map(|t| t.tok) {
            Some(Tok::Name(n)) if !n.local && n.sigil == Sigil::None => n.text,
            _ => return Err(ParseError::new(self.file, span, "expected a format code after / (D, L, S, Fm.n, Em.n, Gm.n, Im, Km, Hm, Jm, Xn, Cn)")),
        };
        parse_format(&text).ok_or_else(|| {
            ParseError::new(
                self.file,
                span,
                format!(
                    "/{} is not a format code (D, L, S, Fm.n, Em.n, Gm.n, Im, Km, Hm, Jm, Xn, Cn)",
                    text.to_uppercase()
                ),
            )
        })
    }
}

/// Parses a format code's text (lower case, without the `/`): `d`, `f10.3`, `i5`, …
pub fn parse_format(text: &str) -> Option<FormatCode> {
    let (letter, rest) = text.split_at(text.char_indices().nth(1).map_or(text.len(), |(i, _)| i));
    let num = |s: &str| -> Option<u8> {
        if s.is_empty() || !s.bytes().all(|b| b.is_ascii_digit()) {
            return None;
        }
        s.parse::<u32>().ok().map(|v| v.min(u8::MAX as u32) as u8)
    };
    let pair = |s: &str| -> Option<(u8, u8)> {
        let (w, d) = s.split_once('.').unwrap_or((s, "0"));
        Some((num(w)?, num(d)?))
    };
    let count = |s: &str| -> Option<u8> {
        if s.is_empty() {
            Some(1)
        } else {
            num(s)
        }
    };
    match letter {
        "d" if rest.is_empty() => Some(FormatCode::D),
        "l" if rest.is_empty() => Some(FormatCode::L),
        "s" if rest.is_empty() => Some(FormatCode::S),
        "f" => pair(rest).map(|(w, d)| FormatCode::F(w, d)),
        "e" => pair(rest).map(|(w, d)| FormatCode::E(w, d)),
        "g" => pair(rest).map(|(w, d)| FormatCode::G(w, d)),
        "i" => num(rest).map(FormatCode::I),
        "k" => num(rest).map(FormatCode::K),
        "h" => num(rest).map(FormatCode::H),
        "j" => num(rest).map(FormatCode::J),
        "x" => count(rest).map(FormatCode::X),
        "c" => count(rest).map(FormatCode::C),
        _ => None,
    }
}
