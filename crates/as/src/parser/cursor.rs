//! A cursor over the tokens of one line: look, take, expect, and the errors it makes.

use crate::ast::Label;
use crate::error::ParseError;
use crate::lexer::{Sigil, Tok, Token};
use crate::span::Span;

/// Deepest nesting of blocks (IF, WHILE, …) and of parentheses accepted.
pub const MAX_NESTING: usize = 48;

/// A cursor over the tokens of one line.
pub(super) struct Cur<'a> {
    pub(super) file: &'a str,
    pub(super) toks: &'a [Token],
    pub(super) pos: usize,
    pub(super) line: u32,
    pub(super) depth: usize,
}

pub(super) type PResult<T> = Result<T, ParseError>;

pub(super) fn describe(t: Option<&Token>) -> String {
    match t {
        Some(t) => t.tok.describe(),
        None => "the end of the line".into(),
    }
}

impl<'a> Cur<'a> {
    pub(super) fn new(file: &'a str, toks: &'a [Token], line: u32) -> Cur<'a> {
        Cur {
            file,
            toks,
            pos: 0,
            line,
            depth: 0,
        }
    }

    pub(super) fn peek(&self) -> Option<&Tok> {
        self.toks.get(self.pos).map(|t| &t.tok)
    }

    pub(super) fn peek_at(&self, k: usize) -> Option<&Tok> {
        self.toks.get(self.pos + k).map(|t| &t.tok)
    }

    /// The robot number at `k` tokens ahead (`2` in `ABS.SPEED 2: ON`, `POINT 2: …`,
    /// `INRANGE:2(…)`), when that token can be one: a number or a variable. The emulator is
    /// robot 1; any other number, or a variable, names [`RobotNumber::Other`].
    pub(super) fn robot_number_at(&self, k: usize) -> Option<RobotNumber> {
        match self.peek_at(k)? {
            Tok::Num(n) if *n == 1.0 => Some(RobotNumber::This),
            Tok::Num(_) | Tok::Name(_) => Some(RobotNumber::Other),
            _ => None,
        }
    }

    pub(super) fn span(&self) -> Span {
        match self.toks.get(self.pos) {
            Some(t) => t.span,
            None => match self.toks.last() {
                Some(t) => Span::new(self.line, t.span.col + 1),
                None => Span::new(self.line, 1),
            },
        }
    }

    pub(super) fn next(&mut self) -> Option<Token> {
        let t = self.toks.get(self.pos).cloned();
        if t.is_some() {
            self.pos += 1;
        }
        t
    }

    pub(super) fn at_end(&self) -> bool {
        self.pos >= self.toks.len()
    }

    pub(super) fn eat(&mut self, t: &Tok) -> bool {
        if self.peek() == Some(t) {
            self.pos += 1;
            true
        } else {
            false
        }
    }

    pub(super) fn err(&self, msg: impl Into<String>) -> ParseError {
        ParseError::new(self.file, self.span(), msg)
    }

    pub(super) fn err_at(&self, span: Option<Span>, msg: impl Into<String>) -> ParseError {
        ParseError::new(self.file, span.unwrap_or_else(|| self.span()), msg)
    }

    pub(super) fn found(&self) -> String {
        match self.peek() {
            // `IF a = 1 THEN`: a common slip.
            Some(Tok::Assign) => "\"=\" (a comparison is written ==)".into(),
            _ => describe(self.toks.get(self.pos)),
        }
    }

    pub(super) fn expect(&mut self, t: &Tok, what: &str) -> PResult<Span> {
        let span = self.span();
        if self.eat(t) {
            Ok(span)
        } else {
            Err(self.err(format!("expected {what}, found {}", self.found())))
        }
    }

    /// The plain word at the cursor (no sigil, not local), lower case.
    pub(super) fn word(&self) -> Option<&str> {
        match self.peek() {
            Some(Tok::Name(n)) if !n.local && n.sigil == Sigil::None => Some(&n.text),
            _ => None,
        }
    }

    pub(super) fn eat_word(&mut self, w: &str) -> bool {
        if self.word() == Some(w) {
            self.pos += 1;
            true
        } else {
            false
        }
    }

    pub(super) fn expect_word(&mut self, w: &str, what: &str) -> PResult<()> {
        if self.eat_word(w) {
            Ok(())
        } else {
            Err(self.err(format!("expected {what}, found {}", self.found())))
        }
    }

    pub(super) fn expect_end(&mut self, what: &str) -> PResult<()> {
        if self.at_end() {
            Ok(())
        } else {
            Err(self.err(format!(
                "unexpected {} after the end of {what}",
                self.found()
            )))
        }
    }

    /// A label at the start of the line: `name:` or a number (with or without `:`).
    pub(super) fn label(&mut self) -> Option<Label> {
        let span = self.span();
        match (self.peek(), self.peek_at(1)) {
            (Some(Tok::Name(n)), Some(Tok::Colon))
                if !n.local
                    && n.sigil == Sigil::None
                    && !matches!(n.text.as_str(), "any" | "value") =>
            {
                let name = n.text.clone();
                self.pos += 2;
                Some(Label { name, span })
            }
            (Some(Tok::Num(v)), _) if v.fract() == 0.0 && *v >= 0.0 && *v < 1e9 => {
                let name = format!("{}", *v as u64);
                self.pos += 1;
                self.eat(&Tok::Colon);
                Some(Label { name, span })
            }
            _ => None,
        }
    }

    pub(super) fn label_ref(&mut self, what: &str) -> PResult<Label> {
        let span = self.span();
        match self.next().map(|t| t.tok) {
            Some(Tok::Name(n)) if !n.local && n.sigil == Sigil::None => {
                Ok(Label { name: n.text, span })
            }
            Some(Tok::Num(v)) if v.fract() == 0.0 && (0.0..1e9).contains(&v) => Ok(Label {
                name: format!("{}", v as u64),
                span,
            }),
            other => Err(ParseError::new(
                self.file,
                span,
                format!(
                    "expected a label after {what}, found {}",
                    other.map_or("the end of the line".into(), |t| t.describe())
                ),
            )),
        }
    }

    pub(super) fn program_name(&mut self, what: &str) -> PResult<String> {
        let span = self.span();
        match self.next().map(|t| t.tok) {
            Some(Tok::Name(n)) if !n.local && n.sigil == Sigil::None => Ok(n.text),
            other => Err(ParseError::new(
                self.file,
                span,
                format!(
                    "expected a program name after {what}, found {}",
                    other.map_or("the end of the line".into(), |t| t.describe())
                ),
            )),
        }
    }
}

/// Which robot a robot number before or after a colon names (multi-robot controllers write
/// `POINT 2: …`, `SWITCH(name, 2)`, `INRANGE:2(…)`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum RobotNumber {
    /// Robot 1: the emulated arm.
    This,
    /// Another robot (or one given by a variable): not emulated.
    Other,
}
