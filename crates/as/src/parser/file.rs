//! The lines of one file: a program's header and body into blocks, the lines that load without
//! being parsed (not emulated, block steps, words in no table), data lines, and the warnings.

use crate::ast::*;
use crate::error::ParseError;
use crate::keywords;
use crate::lexer::{columns, strip_comment_bytes, tokenize_bytes, Name, Sigil, Tok, Token};
use crate::options::LoadOptions;
use crate::span::Span;

use super::bytes::{header_end, leading_blank, trim_blanks, well_formed};
use super::cursor::{describe, Cur, MAX_NESTING};
use super::statement::LineKind;

pub(super) struct FileParser<'a> {
    pub(super) file: &'a str,
    pub(super) opts: &'a LoadOptions,
    pub(super) errors: Vec<ParseError>,
    pub(super) warnings: Vec<ParseError>,
    /// Not-emulated instructions met: (instruction, first place, count, stubbed).
    pub(super) not_emulated: Vec<(String, Span, usize, bool)>,
}

/// One line of a program before the blocks are assembled.
#[derive(Debug)]
struct LineItem {
    label: Option<Label>,
    kind: LineKind,
    span: Span,
}

/// Instructions that open, divide or close blocks: a line of one is never loaded as not
/// emulated (the block structure depends on it).
const STRUCTURE: &[&str] = &[
    "if", "else", "end", "while", "do", "until", "for", "case", "scase", "value", "svalue", "any",
];

/// What kind of line loads as not emulated without being parsed.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum NotEmulatedKind {
    /// An instruction of the keyword table the emulator does not run.
    Instruction,
    /// A block-teaching step (`JOINT SPEED9 …`, `FN99[ … ]`).
    BlockStep,
    /// `NAME ON|OFF` with a switch the emulator does not keep.
    Switch,
    /// A word that is in no table.
    UnknownWord,
}

impl<'a> FileParser<'a> {
    pub(super) fn error(&mut self, span: Span, msg: impl Into<String>) {
        self.errors.push(ParseError::new(self.file, span, msg));
    }

    fn tokens(&mut self, line_no: u32, code: &[u8], cols: &[u32]) -> Option<Vec<Token>> {
        match tokenize_bytes(self.file, line_no, code, cols) {
            Ok(t) => Some(t),
            Err(e) => {
                self.errors.push(e);
                None
            }
        }
    }

    /// One warning per not-emulated instruction (where it is first used, how often).
    pub(super) fn warn_not_emulated(&mut self) {
        for (instr, span, count, stubbed) in std::mem::take(&mut self.not_emulated) {
            let times = if count == 1 {
                String::new()
            } else {
                format!(" ({count} lines, the first here)")
            };
            let msg = if stubbed {
                format!("{instr} is stubbed: it loads and does nothing{times}")
            } else {
                let word = instr.split(' ').next().unwrap_or(&instr);
                let stub = if word == "CALL" {
                    String::new()
                } else {
                    format!(" (--stub {word} makes it a no-op)")
                };
                format!("{instr} loads but is not emulated{times}: a task that reaches it stops with {}{stub}", crate::error::NOT_EMULATED)
            };
            self.warnings.push(ParseError::new(self.file, span, msg));
        }
    }

    fn note_not_emulated(&mut self, instr: &str, span: Span, stubbed: bool) {
        match self
            .not_emulated
            .iter_mut()
            .find(|(i, _, _, s)| i == instr && *s == stubbed)
        {
            Some(e) => e.2 += 1,
            None => self.not_emulated.push((instr.to_owned(), span, 1, stubbed)),
        }
    }

    /// Parses `.PROGRAM` at `start` (header text `rest`) with its body up to `end`.
    pub(super) fn program(
        &mut self,
        lines: &[&[u8]],
        start: usize,
        end: usize,
        rest: &[u8],
        span: Span,
    ) -> Option<Program> {
        let line_no = start as u32 + 1;
        let line = lines[start];
        let cols = columns(line);
        // `rest` is a slice of the line: its columns start at its offset.
        let offset = (rest.as_ptr() as usize)
            .saturating_sub(line.as_ptr() as usize)
            .min(line.len());
        let rest = strip_comment_bytes(rest);
        // What controllers save after the header: a step-number marker
        // (`.PROGRAM name() #0`) and the time of the last edit (`.PROGRAM name()@25/10/31
        // 16:24 #0`).
        let rest = match header_end(rest) {
            Some(k) => &rest[..k],
            None => rest,
        };
        let toks = self.tokens(line_no, rest, &cols[offset..])?;
        let mut c = Cur::new(self.file, &toks, line_no);
        let header = (|| {
            let name = match c.next() {
                Some(Token {
                    tok: Tok::Name(n), ..
                }) if !n.local && n.sigil == Sigil::None => n.text,
                other => {
                    return Err(c.err_at(
                        other.as_ref().map(|t| t.span),
                        format!(
                            "expected a program name after .PROGRAM, found {}",
                            describe(other.as_ref())
                        ),
                    ))
                }
            };
            let mut params = Vec::new();
            if c.eat(&Tok::LParen) && !c.eat(&Tok::RParen) {
                {
                    loop {
                        let pspan = c.span();
                        let mut by_ref = c.eat(&Tok::Amp);
                        let name = match c.next() {
                            Some(Token {
                                tok: Tok::Name(n), ..
                            }) => n,
                            other => {
                                return Err(c.err_at(
                                    other.as_ref().map(|t| t.span),
                                    format!(
                                    "expected a parameter name such as .a, .$s or .#p, found {}",
                                    describe(other.as_ref())
                                ),
                                ))
                            }
                        };
                        // `.&a`: the lexer reads `.` then `&`… accept `&.a` and `.a&`-less forms only.
                        if !name.local {
                            return Err(c.err_at(Some(pspan), format!("parameter {name} must be a local variable (start it with a dot: .{name})")));
                        }
                        by_ref |= c.eat(&Tok::Amp);
                        // `.$data[]`, `.p[,]`: a whole array.
                        let array = c.peek() == Some(&Tok::LBracket) && {
                            let commas = (1..)
                                .take_while(|&k| c.peek_at(k) == Some(&Tok::Comma))
                                .count();
                            c.peek_at(commas + 1) == Some(&Tok::RBracket)
                        };
                        if array {
                            c.eat(&Tok::LBracket);
                            while c.eat(&Tok::Comma) {}
                            c.eat(&Tok::RBracket);
                        }
                        params.push(Param {
                            name,
                            by_ref,
                            array,
                            span: pspan,
                        });
                        if c.eat(&Tok::RParen) {
                            break;
                        }
                        c.expect(&Tok::Comma, "\",\" or \")\" in the parameter list")?;
                    }
                }
            }
            c.expect_end("the .PROGRAM line")?;
            Ok((name, params))
        })();
        let (name, params) = match header {
            Ok(h) => h,
            Err(e) => {
                self.errors.push(e);
                return None;
            }
        };
        let mut items = Vec::new();
        for (k, line) in lines.iter().enumerate().take(end).skip(start + 1) {
            if let Some(item) = self.line(k as u32 + 1, line) {
                items.push(item);
            }
        }
        let mut it = items.into_iter().peekable();
        let body = self.block(&mut it, &[], 0, "").map(|(b, _)| b);
        let body = match body {
            Ok(b) => b,
            Err(e) => {
                self.errors.push(e);
                return None;
            }
        };
        Some(Program {
            name,
            params,
            body,
            span,
            end_line: end as u32 + 1,
        })
    }

    /// Assembles statements until one of `closers` (returned) or the end of the program.
    fn block(
        &mut self,
        it: &mut std::iter::Peekable<std::vec::IntoIter<LineItem>>,
        closers: &[&str],
        depth: usize,
        opener: &str,
    ) -> Result<(Vec<Stmt>, Option<LineItem>), ParseError> {
        let mut out = Vec::new();
        while let Some(item) = it.next() {
            let name = item.kind.name();
            if closers.contains(&name) {
                return Ok((out, Some(item)));
            }
            if depth >= MAX_NESTING
                && matches!(
                    item.kind,
                    LineKind::IfThen(_)
                        | LineKind::While(_)
                        | LineKind::Do
                        | LineKind::For { .. }
                        | LineKind::Case(_)
                )
            {
                return Err(ParseError::new(
                    self.file,
                    item.span,
                    format!("blocks nested deeper than {MAX_NESTING} levels"),
                ));
            }
            let LineItem { label, kind, span } = item;
            let stmt = match kind {
                LineKind::Stmt(k) => k,
                LineKind::IfThen(cond) => {
                    let (then, close) = self.block(it, &["ELSE", "END"], depth + 1, "IF")?;
                    let close = self.closed(close, span, "IF")?;
                    let otherwise = if close.kind.name() == "ELSE" {
                        self.no_label(&close)?;
                        let (b, close) = self.block(it, &["END"], depth + 1, "IF")?;
                        let close = self.closed(close, span, "IF")?;
                        self.no_label(&close)?;
                        b
                    } else {
                        self.no_label(&close)?;
                        Vec::new()
                    };
                    StmtKind::If {
                        cond,
                        then,
                        otherwise,
                    }
                }
                LineKind::While(cond) => {
                    let (body, close) = self.block(it, &["END"], depth + 1, "WHILE")?;
                    let close = self.closed(close, span, "WHILE")?;
                    self.no_label(&close)?;
                    StmtKind::While { cond, body }
                }
                LineKind::Do => {
                    let (body, close) = self.block(it, &["UNTIL"], depth + 1, "DO")?;
                    let close = self.closed(close, span, "DO")?;
                    self.no_label(&close)?;
                    match close.kind {
                        LineKind::Until(cond) => StmtKind::DoUntil { body, cond },
                        other => {
                            return Err(ParseError::new(
                                self.file,
                                close.span,
                                format!(
                                    "expected UNTIL to close the DO at line {}, found {}",
                                    span.line,
                                    other.name()
                                ),
                            ))
                        }
                    }
                }
                LineKind::For {
                    var,
                    from,
                    to,
                    step,
                } => {
                    let (body, close) = self.block(it, &["END"], depth + 1, "FOR")?;
                    let close = self.closed(close, span, "FOR")?;
                    self.no_label(&close)?;
                    StmtKind::For {
                        var,
                        from,
                        to,
                        step,
                        body,
                    }
                }
                LineKind::Case(selector) => {
                    let mut arms: Vec<CaseArm> = Vec::new();
                    // Only VALUE/ANY/END may follow CASE … OF.
                    let mut next = it.next();
                    loop {
                        let Some(arm_item) = next.take() else {
                            return Err(ParseError::new(
                                self.file,
                                span,
                                "expected END to close this CASE before .END",
                            ));
                        };
                        self.no_label(&arm_item)?;
                        let values = match arm_item.kind {
                            LineKind::End => break,
                            LineKind::Value(v) => Some(v),
                            LineKind::Any => None,
                            other => {
                                return Err(ParseError::new(
                                    self.file,
                                    arm_item.span,
                                    format!(
                                        "expected VALUE …:, ANY: or END in this CASE, found {}",
                                        other.name()
                                    ),
                                ))
                            }
                        };
                        let (body, close) =
                            self.block(it, &["VALUE", "ANY", "END"], depth + 1, "CASE")?;
                        arms.push(CaseArm {
                            values,
                            body,
                            span: arm_item.span,
                        });
                        match close {
                            Some(c) => next = Some(c),
                            None => {
                                return Err(ParseError::new(
                                    self.file,
                                    span,
                                    "expected END to close this CASE before .END",
                                ))
                            }
                        }
                    }
                    StmtKind::Case { selector, arms }
                }
                // A stray END with no block open: kept, as controllers save it, and not
                // emulated (a task that reaches it stops with E0199).
                LineKind::End if opener.is_empty() => {
                    self.note_not_emulated("END without an open block", span, false);
                    StmtKind::NotEmulated {
                        instruction: "END without an open block".into(),
                        stubbed: false,
                    }
                }
                other => {
                    let msg = match (other.name(), opener) {
                        (n, "") => format!("{n} without an open block"),
                        (n, o) => format!("{n} does not belong in this {o} block"),
                    };
                    return Err(ParseError::new(self.file, span, msg));
                }
            };
            out.push(Stmt {
                label,
                kind: stmt,
                span,
            });
        }
        Ok((out, None))
    }

    fn closed(
        &self,
        close: Option<LineItem>,
        open: Span,
        what: &str,
    ) -> Result<LineItem, ParseError> {
        close.ok_or_else(|| {
            let closer = if what == "DO" { "UNTIL" } else { "END" };
            ParseError::new(
                self.file,
                open,
                format!("expected {closer} to close this {what} before .END"),
            )
        })
    }

    fn no_label(&self, item: &LineItem) -> Result<(), ParseError> {
        match &item.label {
            Some(l) => Err(ParseError::new(
                self.file,
                l.span,
                format!("a label cannot stand on a {} line: put it on a line of its own before the block", item.kind.name()),
            )),
            None => Ok(()),
        }
    }

    /// One program line (`None`: empty, or an error was recorded).
    fn line(&mut self, line_no: u32, text: &[u8]) -> Option<LineItem> {
        let code = strip_comment_bytes(text);
        let cols = columns(text);
        if let Some(item) = self.not_emulated_line(line_no, code, &cols) {
            let item = match item {
                Ok(item) => item,
                Err(e) => {
                    self.errors.push(e);
                    return None;
                }
            };
            if let LineKind::Stmt(StmtKind::NotEmulated {
                instruction,
                stubbed,
            }) = &item.kind
            {
                let (i, s) = (instruction.clone(), *stubbed);
                self.note_not_emulated(&i, item.span, s);
            }
            return Some(item);
        }
        let toks = self.tokens(line_no, code, &cols)?;
        if toks.is_empty() {
            return None;
        }
        let mut c = Cur::new(self.file, &toks, line_no);
        let span = toks[0].span;
        let label = c.label();
        let body = c.pos;
        if c.at_end() {
            return Some(LineItem {
                label,
                kind: LineKind::Stmt(StmtKind::Empty),
                span,
            });
        }
        match c.statement() {
            Ok(kind) => {
                if let LineKind::Stmt(StmtKind::NotEmulated { instruction, .. }) = &kind {
                    let i = instruction.clone();
                    self.note_not_emulated(&i, span, false);
                }
                Some(LineItem { label, kind, span })
            }
            Err(e) => {
                // A line of an instruction the emulator runs, in a form it does not read but
                // that is well formed (strings closed, brackets balanced, a number of values
                // the instruction takes): it loads as not emulated, with a warning that asks
                // for a report. A structure line (IF, WHILE, END…) stays an error: the block
                // structure depends on it.
                if let Some(item) = self.unread_form(&toks[body..], code, label.clone(), span, &e) {
                    return Some(item);
                }
                self.errors.push(e);
                // Keep the block structure of a line that opens a block, so that its END
                // does not cause a second, misleading error.
                let dummy = || Expr {
                    kind: ExprKind::Num(0.0),
                    span,
                };
                let word = toks.iter().find_map(|t| match &t.tok {
                    Tok::Name(n) if !n.local && n.sigil == Sigil::None => {
                        keywords::statement(&n.text)
                    }
                    _ => None,
                });
                let has_then = toks
                    .iter()
                    .any(|t| matches!(&t.tok, Tok::Name(n) if n.text == "then"));
                let kind = match word {
                    Some("while") => LineKind::While(dummy()),
                    Some("if") if has_then => LineKind::IfThen(dummy()),
                    Some("for") => LineKind::For {
                        var: LValue {
                            name: Name {
                                local: false,
                                sigil: Sigil::None,
                                text: "~".into(),
                            },
                            indices: Vec::new(),
                            span,
                        },
                        from: dummy(),
                        to: dummy(),
                        step: None,
                    },
                    Some("case" | "scase") => LineKind::Case(dummy()),
                    Some("do") => LineKind::Do,
                    _ => return None,
                };
                Some(LineItem {
                    label: None,
                    kind,
                    span,
                })
            }
        }
    }

    /// A line of an instruction the emulator runs, in a form this parser does not read, that a
    /// controller may accept: `Some` (not emulated, with a warning) when its arguments are well
    /// formed and their number fits the keyword table's grammar.
    fn unread_form(
        &mut self,
        toks: &[Token],
        code: &[u8],
        label: Option<Label>,
        span: Span,
        e: &ParseError,
    ) -> Option<LineItem> {
        let first = match &toks.first()?.tok {
            Tok::Name(n) if !n.local && n.sigil == Sigil::None => n.text.clone(),
            _ => return None,
        };
        let keywords::Lookup::Found(k) = keywords::lookup(&first, keywords::Role::INSTRUCTION)
        else {
            return None;
        };
        if STRUCTURE.contains(&k.name) || !k.runs.contains(keywords::Role::INSTRUCTION) {
            return None;
        }
        let rest = &toks[1..];
        let mut depth = 0i32;
        let mut values = usize::from(!rest.is_empty());
        for t in rest {
            match t.tok {
                Tok::LParen | Tok::LBracket | Tok::HashBracket => depth += 1,
                Tok::RParen | Tok::RBracket => depth -= 1,
                Tok::Comma if depth == 0 => values += 1,
                _ => {}
            }
            if depth < 0 {
                return None;
            }
        }
        if depth != 0 || well_formed(code).is_err() {
            return None;
        }
        if let Some((min, max)) = k.arity(keywords::Role::INSTRUCTION) {
            if values < min || max.is_some_and(|m| values > m) {
                return None;
            }
        }
        let grammar = k.grammar(keywords::Role::INSTRUCTION).unwrap_or("");
        for w in keywords::required_words(grammar) {
            if !rest
                .iter()
                .any(|t| matches!(&t.tok, Tok::Name(n) if n.text == w))
            {
                return None;
            }
        }
        let upper = k.name.to_uppercase();
        let instruction = format!("{upper} in this form");
        self.note_not_emulated(&instruction, span, false);
        self.warnings.push(ParseError::new(
            self.file,
            e.span,
            format!(
                "{upper}: this form is not read by the emulator yet ({}); if a controller accepts it, report it with this line (docs/AS.md)",
                e.message
            ),
        ));
        Some(LineItem {
            label,
            kind: LineKind::Stmt(StmtKind::NotEmulated {
                instruction,
                stubbed: false,
            }),
            span,
        })
    }

    /// A line whose instruction loads without being parsed: one the emulator does not model
    /// (its arguments may use forms this parser does not read, such as `#[…]`), a
    /// block-teaching step, or a stubbed instruction. `None` for every other line.
    fn not_emulated_line(
        &self,
        line_no: u32,
        code: &[u8],
        cols: &[u32],
    ) -> Option<Result<LineItem, ParseError>> {
        let col = |k: usize| cols.get(k).copied().unwrap_or(1);
        let mut i = leading_blank(code);
        let mut label = None;
        // A step number or a `name:` label first.
        let word_at = |i: usize| {
            let mut j = i;
            while j < code.len()
                && (code[j].is_ascii_alphanumeric() || code[j] == b'_' || code[j] == b'.')
            {
                j += 1;
            }
            j
        };
        if code.get(i).is_some_and(|b| b.is_ascii_digit()) {
            let j = word_at(i);
            if !code[i..j].iter().all(|b| b.is_ascii_digit()) || j - i > 9 {
                return None;
            }
            label = Some(Label {
                name: String::from_utf8_lossy(&code[i..j])
                    .trim_start_matches('0')
                    .to_owned(),
                span: Span::new(line_no, col(i)),
            });
            i = j + leading_blank(&code[j..]);
            if code.get(i) == Some(&b':') {
                i += 1;
                i += leading_blank(&code[i..]);
            }
        } else if code.get(i).is_some_and(|b| b.is_ascii_alphabetic()) {
            let j = word_at(i);
            let k = j + leading_blank(&code[j..]);
            if code.get(k) == Some(&b':') {
                let name = String::from_utf8_lossy(&code[i..j]).to_ascii_lowercase();
                if name != "any" && name != "value" && name != "svalue" {
                    label = Some(Label {
                        name,
                        span: Span::new(line_no, col(i)),
                    });
                    i = k + 1 + leading_blank(&code[k + 1..]);
                }
            }
        }
        if let Some(l) = &mut label {
            if l.name.is_empty() {
                l.name.push('0');
            }
        }
        if !code.get(i).is_some_and(|b| b.is_ascii_alphabetic()) {
            return None;
        }
        let j = word_at(i);
        let word = String::from_utf8_lossy(&code[i..j]).to_ascii_lowercase();
        let after = &code[j + leading_blank(&code[j..])..];
        let span = Span::new(line_no, col(i));
        let make = |instruction: String, stubbed: bool| {
            if let Err((k, msg)) = well_formed(after) {
                let at = Span::new(line_no, col(code.len() - after.len() + k));
                let msg = if msg.starts_with("unexpected character") {
                    msg
                } else {
                    format!("{msg}: a controller refuses this line too")
                };
                return Some(Err(ParseError::new(self.file, at, msg)));
            }
            Some(Ok(LineItem {
                label: label.clone(),
                kind: LineKind::Stmt(StmtKind::NotEmulated {
                    instruction,
                    stubbed,
                }),
                span,
            }))
        };
        // A block program's function step: `FN99[ "text" ]`, `FN20[ 17 ]`.
        let fn_step = word.len() > 2
            && word.starts_with("fn")
            && word[2..].bytes().all(|b| b.is_ascii_digit())
            && after.starts_with(b"[");
        // `tool = 1`, `tool[1] = 2`: an assignment, not an instruction.
        if !fn_step
            && ((after.starts_with(b"=") && !after.starts_with(b"==")) || after.starts_with(b"["))
        {
            return None;
        }
        // `PREFETCH.SIGINS OFF`: a system switch the interpreter keeps, not an instruction.
        if keywords::system_switch_default(&word).is_some() {
            return None;
        }
        // A block step may carry an application prefix first (`AC JOINT SPEED2 …`, `WS
        // LINEAR …` in arc-welding saves).
        let prefixed = {
            let k = word_at(j + leading_blank(&code[j..]));
            let next = String::from_utf8_lossy(&code[j + leading_blank(&code[j..])..k])
                .to_ascii_lowercase();
            keywords::BLOCK_TEACHING.contains(&next.as_str())
                && code[k..].windows(2).any(|w| w == b"#[")
        };
        let block_step = fn_step
            || prefixed
            || keywords::BLOCK_TEACHING.contains(&word.as_str()) && {
                let next = &after[..after
                    .iter()
                    .position(|b| !b.is_ascii_alphanumeric())
                    .unwrap_or(after.len())];
                next.len() >= 5 && next[..5].eq_ignore_ascii_case(b"speed")
                    || after.windows(2).any(|w| w == b"#[")
            };
        // `JOINT`/`LINEAR` lines are block steps only: the emulator runs those it reads, the
        // others load as not emulated.
        let block_word = matches!(word.as_str(), "joint" | "linear");
        let block_step = block_step || block_word;
        if block_step && !fn_step && !prefixed && !self.opts.is_stubbed(&word) {
            if let Some(step) = super::block::block_step(&word, after) {
                return Some(Ok(LineItem {
                    label,
                    kind: LineKind::Stmt(StmtKind::BlockStep(Box::new(step))),
                    span,
                }));
            }
        }
        let upper = word.to_ascii_uppercase();
        let kind = if block_step {
            NotEmulatedKind::BlockStep
        } else {
            match keywords::lookup(&word, keywords::Role::INSTRUCTION) {
                keywords::Lookup::Found(k) if k.runs.contains(keywords::Role::INSTRUCTION) => {
                    if !self.opts.is_stubbed(&word) {
                        return None;
                    }
                    NotEmulatedKind::Instruction
                }
                keywords::Lookup::Found(_) => NotEmulatedKind::Instruction,
                keywords::Lookup::Ambiguous(..) => return None,
                keywords::Lookup::Unknown => {
                    let value = trim_blanks(after).0;
                    if value.eq_ignore_ascii_case(b"on") || value.eq_ignore_ascii_case(b"off") {
                        NotEmulatedKind::Switch
                    } else {
                        NotEmulatedKind::UnknownWord
                    }
                }
            }
        };
        let instruction = match kind {
            NotEmulatedKind::BlockStep => format!("{upper} (block-teaching step)"),
            NotEmulatedKind::Switch => format!("{upper} (a system switch)"),
            NotEmulatedKind::Instruction | NotEmulatedKind::UnknownWord => upper,
        };
        if self.opts.is_stubbed(&word) {
            return make(instruction, true);
        }
        if kind == NotEmulatedKind::UnknownWord && self.opts.refuses_unknown_words() {
            return Some(Err(ParseError::new(
                self.file,
                span,
                format!("(P0109) Invalid statement: {instruction} is not an AS keyword"),
            )));
        }
        make(instruction, false)
    }

    /// One data-section line.
    pub(super) fn data_line(
        &mut self,
        section: &str,
        line_no: u32,
        text: &[u8],
    ) -> Option<DataItem> {
        let code = strip_comment_bytes(text);
        if trim_blanks(code).0.is_empty() {
            return None;
        }
        let cols = columns(text);
        let toks = self.tokens(line_no, code, &cols)?;
        let mut c = Cur::new(self.file, &toks, line_no);
        match c.data_item(section) {
            Ok(item) => Some(item),
            // A data line this loader cannot read (a name that is not one, more axes than
            // the FS020N's six) is left out with a warning: nothing runs it, and a program
            // that reads the variable stops with E0102 as on a controller without it.
            Err(e) => {
                self.warnings.push(ParseError::new(
                    self.file,
                    e.span,
                    format!("{}: this data line is not loaded", e.message),
                ));
                None
            }
        }
    }
}
