//! The parser: AS program files into a [`Module`].
//!
//! A file is **bytes**: programs saved by a controller or an editor come in its code page
//! (Shift-JIS, GBK, Windows-1250, UTF-8, sometimes mixed or damaged), so no file is refused
//! for its encoding. Comments may hold any bytes; string literals keep their bytes as written
//! (AS strings are bytes). Names, numbers and operators are ASCII. Lines end with `\n`,
//! `\r\n`, or `\r` in a file that has no `\n`.
//!
//! A file holds `.PROGRAM name(params)` … `.END` blocks, data sections (`.REALS`, `.STRINGS`,
//! `.JOINTS`, `.TRANS`) and the other sections of a controller backup, in any order
//! ([`crate::sections`]: which are read, which are kept opaque, where each ends); `.*` lines
//! are comments. Instructions the emulator does not model load as
//! [`StmtKind::NotEmulated`] and are listed as warnings.
//!
//! Every error names the file, line and column and what was expected; parsing goes on after an
//! error so that one load reports up to [`MAX_REPORTED`] of them.

use crate::ast::*;
use crate::error::{LoadError, ParseError, MAX_REPORTED};
use crate::keywords;
use crate::lexer::{columns, strip_comment_bytes, tokenize_bytes, Name, Sigil, Tok, Token};
use crate::options::LoadOptions;
use crate::sections::{directive, section, SectionEnd, SectionUse};
use crate::span::Span;

/// Deepest nesting of blocks (IF, WHILE, …) and of parentheses accepted.
pub const MAX_NESTING: usize = 48;

/// Parses one AS file given as text. `file` names it in messages. The same as
/// [`parse_bytes`] on the text's bytes with default options.
///
/// ```
/// let m = fs020n_as::parse("demo.as", ".PROGRAM hello()\r\n  PRINT \"hi\" ; größer\r\n.END\r\n").unwrap();
/// assert_eq!(m.programs[0].name, "hello");
/// let e = fs020n_as::parse("bad.as", ".PROGRAM p()\n  IF a THEN\n.END\n").unwrap_err();
/// assert_eq!(e.to_string(), "bad.as:2:3: expected END to close this IF before .END");
/// ```
pub fn parse(file: &str, text: &str) -> Result<Module, LoadError> {
    parse_bytes(file, text.as_bytes(), &LoadOptions::default())
}

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
fn leading_blank(code: &[u8]) -> usize {
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
fn trim_blanks(code: &[u8]) -> (&[u8], usize) {
    let start = leading_blank(code);
    let mut end = code.len();
    while end > start && matches!(code[end - 1], b' ' | b'\t' | b'\x0c' | b'\x1a') {
        end -= 1;
    }
    (&code[start..end], start)
}

/// Parses one AS file given as bytes, in any encoding. `file` names it in messages; `opts`
/// says which instructions are stubbed.
///
/// ```
/// use fs020n_as::LoadOptions;
/// // A Shift-JIS comment and string: the string's bytes survive as written.
/// let text = b".PROGRAM p() #0\r\n  $s = \"\x83\x65\x83\x58\x83\x67\" ; \x83\x52\x83\x81\r\n.END\r\n";
/// let m = fs020n_as::parse_bytes("p.as", text, &LoadOptions::default()).unwrap();
/// assert_eq!(m.programs[0].name, "p");
/// ```
pub fn parse_bytes(file: &str, bytes: &[u8], opts: &LoadOptions) -> Result<Module, LoadError> {
    let lines = split_lines(bytes);
    let mut p = FileParser {
        file,
        opts,
        errors: Vec::new(),
        warnings: Vec::new(),
        not_emulated: Vec::new(),
    };
    let mut programs: Vec<Program> = Vec::new();
    let mut data = Vec::new();
    let mut sections = Vec::new();
    let mut switches = Vec::new();
    let mut i = 0;
    while i < lines.len() {
        let line_no = i as u32 + 1;
        let code = strip_comment_bytes(lines[i]);
        let (trimmed, offset) = trim_blanks(code);
        if trimmed.is_empty() || trimmed.starts_with(b".*") {
            i += 1;
            continue;
        }
        let span = Span::new(line_no, columns(lines[i])[offset]);
        let Some((word, rest)) = directive(trimmed) else {
            p.error(
                span,
                format!(
                    "expected .PROGRAM or a data section (.REALS, .STRINGS, .JOINTS, .TRANS), found {:?}",
                    truncate(&String::from_utf8_lossy(trimmed), 40)
                ),
            );
            i += 1;
            if p.errors.len() >= MAX_REPORTED {
                break;
            }
            continue;
        };
        if word == "end" {
            // A stray second `.END`: controllers ignore it.
            p.warnings.push(ParseError::new(
                file,
                span,
                ".END without a .PROGRAM or a data section to close: ignored",
            ));
            i += 1;
            continue;
        }
        let kind = section(&word);
        let upper = word.to_ascii_uppercase();
        let reads = kind.map_or(SectionUse::Opaque, |k| k.reads);
        // The last line of the section, and whether it is an `.END` line.
        let (last, closed) = match kind {
            Some(k) if k.end == SectionEnd::OneLine => (i, true),
            Some(k) if k.reads == SectionUse::Program => program_end(&lines, i + 1),
            _ => section_end(&lines, i + 1),
        };
        // Lines of the section's content.
        let body_end = if closed && kind.is_none_or(|k| k.end == SectionEnd::EndLine) {
            last
        } else {
            last + 1
        };
        let body = i + 1..body_end.min(lines.len());
        match reads {
            SectionUse::Program => {
                // The body ends before `.END`, or after `last` when there is none.
                let end = if closed { last } else { last + 1 };
                if let Some(prog) = p.program(&lines, i, end, rest, span) {
                    if let Some(prev) = programs.iter().find(|q| q.name == prog.name) {
                        p.error(
                            span,
                            format!(
                                "program {} is defined twice (first at line {})",
                                prog.name, prev.span.line
                            ),
                        );
                    } else {
                        programs.push(prog);
                    }
                }
                if !closed {
                    let msg = if last + 1 < lines.len() {
                        format!(
                            "expected .END to close this .PROGRAM before the next .PROGRAM at line {}",
                            last + 2
                        )
                    } else {
                        format!(
                            "expected .END to close this .PROGRAM (the file ends at line {})",
                            lines.len()
                        )
                    };
                    p.error(span, msg);
                }
            }
            SectionUse::Data => {
                for k in body {
                    if let Some(item) = p.data_line(&word, k as u32 + 1, lines[k]) {
                        data.push(item);
                    }
                }
                if !closed {
                    p.error(
                        span,
                        format!("expected .END to close this .{upper} section"),
                    );
                }
            }
            SectionUse::SysData | SectionUse::Opaque => {
                if reads == SectionUse::SysData {
                    for k in body {
                        if let Some(s) = sysdata_switch(k as u32 + 1, lines[k]) {
                            switches.push(s);
                        }
                    }
                }
                let last_line = last.min(lines.len().saturating_sub(1)) as u32 + 1;
                let range = if last_line == line_no {
                    format!("line {line_no}")
                } else {
                    format!("lines {line_no}–{last_line}")
                };
                let what = match (kind, reads) {
                    (None, _) => format!("unknown section .{upper} ({range}) is kept as it is"),
                    (_, SectionUse::SysData) => format!(
                        "section .{upper} ({range}): its SWITCH lines are read, the rest is kept as it is"
                    ),
                    _ => format!("section .{upper} ({range}) is kept as it is: the emulator does not use it"),
                };
                let what = if closed {
                    what
                } else if last + 1 < lines.len() {
                    format!("{what}; it has no .END and ends before line {}, where the next section begins", last_line + 1)
                } else {
                    format!("{what}; it has no .END and runs to the end of the file")
                };
                p.warnings.push(ParseError::new(file, span, what));
            }
        }
        sections.push(Section {
            name: upper,
            first_line: line_no,
            last_line: last.min(lines.len().saturating_sub(1)) as u32 + 1,
            reads,
            known: kind.is_some(),
        });
        i = last + 1;
        if p.errors.len() >= MAX_REPORTED {
            break;
        }
    }
    p.warn_not_emulated();
    if !p.errors.is_empty() {
        p.errors.truncate(MAX_REPORTED);
        return Err(LoadError { errors: p.errors });
    }
    p.warnings.sort_by_key(|w| w.span);
    Ok(Module {
        file: file.into(),
        lines: lines
            .iter()
            .map(|l| String::from_utf8_lossy(l).into_owned())
            .collect(),
        programs,
        data,
        warnings: p.warnings,
        sections,
        switches,
    })
}

/// Where the saved decorations after a `.PROGRAM` header start: a `@` (edit time) or a `#`
/// followed by a digit (step-number marker). Parameters never hold either.
pub(crate) fn header_end(rest: &[u8]) -> Option<usize> {
    (0..rest.len()).find(|&k| {
        rest[k] == b'@' || (rest[k] == b'#' && rest.get(k + 1).is_some_and(u8::is_ascii_digit))
    })
}

/// `true` when the tokens hold a whole array: `[` then `]`, or `[` then only commas then `]`
/// (`.$data[]`, `.&p.rel[,]`).
fn whole_array_at(toks: &[Token]) -> bool {
    toks.iter().enumerate().any(|(k, t)| {
        t.tok == Tok::LBracket && {
            let rest = &toks[k + 1..];
            let commas = rest.iter().take_while(|t| t.tok == Tok::Comma).count();
            rest.get(commas).is_some_and(|t| t.tok == Tok::RBracket)
        }
    })
}

/// A `SWITCH name [=] ON|OFF` line of `.SYSDATA`.
fn sysdata_switch(line_no: u32, line: &[u8]) -> Option<SwitchSetting> {
    let code = strip_comment_bytes(line);
    let (trimmed, offset) = trim_blanks(code);
    let words: Vec<&[u8]> = trimmed
        .split(|b| b.is_ascii_whitespace() || *b == b'=')
        .filter(|w| !w.is_empty())
        .collect();
    match words.as_slice() {
        [kw, name, value] if kw.eq_ignore_ascii_case(b"switch") => {
            let on = if value.eq_ignore_ascii_case(b"on") {
                true
            } else if value.eq_ignore_ascii_case(b"off") {
                false
            } else {
                return None;
            };
            Some(SwitchSetting {
                name: String::from_utf8_lossy(name).to_ascii_lowercase(),
                on,
                span: Span::new(line_no, offset as u32 + 1),
            })
        }
        _ => None,
    }
}

fn truncate(s: &str, n: usize) -> String {
    if s.chars().count() <= n {
        s.to_owned()
    } else {
        let mut t: String = s.chars().take(n).collect();
        t.push('…');
        t
    }
}

/// `true` when the line is exactly `.END` (any case, blanks and a comment allowed).
fn is_end_line(line: &[u8]) -> bool {
    trim_blanks(strip_comment_bytes(line))
        .0
        .eq_ignore_ascii_case(b".end")
}

/// The end of a program, searching from `from`: `(its .END line, true)`, or `(the line before
/// the next .PROGRAM line, false)` when that comes first (a body line starting with `.` is a
/// local variable; `.PROGRAM` followed by a name is not), or `(the last line, false)`.
fn program_end(lines: &[&[u8]], from: usize) -> (usize, bool) {
    for (k, line) in lines.iter().enumerate().skip(from) {
        if is_end_line(line) {
            return (k, true);
        }
        let (t, _) = trim_blanks(strip_comment_bytes(line));
        if let Some((w, rest)) = directive(t) {
            let (rest, _) = trim_blanks(rest);
            if w == "program" && rest.first().is_some_and(u8::is_ascii_alphabetic) {
                return (k - 1, false);
            }
        }
    }
    (lines.len(), false)
}

/// The end of a section that is not a program, searching from `from`: `(its .END line, true)`,
/// or `(the line before the next known section, false)` when that comes first, or
/// `(the last line, false)`.
fn section_end(lines: &[&[u8]], from: usize) -> (usize, bool) {
    for (k, line) in lines.iter().enumerate().skip(from) {
        if is_end_line(line) {
            return (k, true);
        }
        let (t, _) = trim_blanks(strip_comment_bytes(line));
        if directive(t).is_some_and(|(w, _)| w != "end" && section(&w).is_some()) {
            return (k - 1, false);
        }
    }
    (
        lines.len().saturating_sub(1).max(from.saturating_sub(1)),
        false,
    )
}

struct FileParser<'a> {
    file: &'a str,
    opts: &'a LoadOptions,
    errors: Vec<ParseError>,
    warnings: Vec<ParseError>,
    /// Not-emulated instructions met: (instruction, first place, count, stubbed).
    not_emulated: Vec<(String, Span, usize, bool)>,
}

/// One line of a program before the blocks are assembled.
#[derive(Debug)]
struct LineItem {
    label: Option<Label>,
    kind: LineKind,
    span: Span,
}

#[derive(Debug)]
enum LineKind {
    Stmt(StmtKind),
    IfThen(Expr),
    Else,
    End,
    While(Expr),
    Do,
    Until(Expr),
    For {
        var: LValue,
        from: Expr,
        to: Expr,
        step: Option<Expr>,
    },
    Case(Expr),
    Value(Vec<Expr>),
    Any,
}

impl LineKind {
    fn name(&self) -> &'static str {
        match self {
            LineKind::Stmt(_) => "statement",
            LineKind::IfThen(_) => "IF",
            LineKind::Else => "ELSE",
            LineKind::End => "END",
            LineKind::While(_) => "WHILE",
            LineKind::Do => "DO",
            LineKind::Until(_) => "UNTIL",
            LineKind::For { .. } => "FOR",
            LineKind::Case(_) => "CASE",
            LineKind::Value(_) => "VALUE",
            LineKind::Any => "ANY",
        }
    }
}

impl<'a> FileParser<'a> {
    fn error(&mut self, span: Span, msg: impl Into<String>) {
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
    fn warn_not_emulated(&mut self) {
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
                format!("{instr} loads but is not emulated{times}: a task that reaches it stops with E0111{stub}")
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
    fn program(
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
                // emulated (a task that reaches it stops with E0111).
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
    fn data_line(&mut self, section: &str, line_no: u32, text: &[u8]) -> Option<DataItem> {
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

fn describe(t: Option<&Token>) -> String {
    match t {
        Some(t) => t.tok.describe(),
        None => "the end of the line".into(),
    }
}

/// Instructions that open, divide or close blocks: a line of one is never loaded as not
/// emulated (the block structure depends on it).
const STRUCTURE: &[&str] = &[
    "if", "else", "end", "while", "do", "until", "for", "case", "scase", "value", "svalue", "any",
];

/// Instructions whose own grammar has `n:` after the keyword (a device, a PC task number, a
/// CASE value).
const OWN_COLON: &[&str] = &[
    "print",
    "type",
    "pcexecute",
    "pcabort",
    "execute",
    "mc",
    "value",
    "svalue",
    "any",
];

/// Whether the arguments of a line that loads without being parsed are well formed: strings
/// closed, parentheses and brackets balanced and properly nested, and nothing but ASCII outside
/// strings (the blanks the lexer reads as blanks excepted). `Err` holds the offset of the
/// fault and what it is.
fn well_formed(args: &[u8]) -> Result<(), (usize, String)> {
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

/// A cursor over the tokens of one line.
struct Cur<'a> {
    file: &'a str,
    toks: &'a [Token],
    pos: usize,
    line: u32,
    depth: usize,
}

type PResult<T> = Result<T, ParseError>;

impl<'a> Cur<'a> {
    fn new(file: &'a str, toks: &'a [Token], line: u32) -> Cur<'a> {
        Cur {
            file,
            toks,
            pos: 0,
            line,
            depth: 0,
        }
    }

    fn peek(&self) -> Option<&Tok> {
        self.toks.get(self.pos).map(|t| &t.tok)
    }

    fn peek_at(&self, k: usize) -> Option<&Tok> {
        self.toks.get(self.pos + k).map(|t| &t.tok)
    }

    fn span(&self) -> Span {
        match self.toks.get(self.pos) {
            Some(t) => t.span,
            None => match self.toks.last() {
                Some(t) => Span::new(self.line, t.span.col + 1),
                None => Span::new(self.line, 1),
            },
        }
    }

    fn next(&mut self) -> Option<Token> {
        let t = self.toks.get(self.pos).cloned();
        if t.is_some() {
            self.pos += 1;
        }
        t
    }

    fn at_end(&self) -> bool {
        self.pos >= self.toks.len()
    }

    fn eat(&mut self, t: &Tok) -> bool {
        if self.peek() == Some(t) {
            self.pos += 1;
            true
        } else {
            false
        }
    }

    fn err(&self, msg: impl Into<String>) -> ParseError {
        ParseError::new(self.file, self.span(), msg)
    }

    fn err_at(&self, span: Option<Span>, msg: impl Into<String>) -> ParseError {
        ParseError::new(self.file, span.unwrap_or_else(|| self.span()), msg)
    }

    fn found(&self) -> String {
        match self.peek() {
            // `IF a = 1 THEN`: a common slip.
            Some(Tok::Assign) => "\"=\" (a comparison is written ==)".into(),
            _ => describe(self.toks.get(self.pos)),
        }
    }

    fn expect(&mut self, t: &Tok, what: &str) -> PResult<Span> {
        let span = self.span();
        if self.eat(t) {
            Ok(span)
        } else {
            Err(self.err(format!("expected {what}, found {}", self.found())))
        }
    }

    /// The plain word at the cursor (no sigil, not local), lower case.
    fn word(&self) -> Option<&str> {
        match self.peek() {
            Some(Tok::Name(n)) if !n.local && n.sigil == Sigil::None => Some(&n.text),
            _ => None,
        }
    }

    fn eat_word(&mut self, w: &str) -> bool {
        if self.word() == Some(w) {
            self.pos += 1;
            true
        } else {
            false
        }
    }

    fn expect_word(&mut self, w: &str, what: &str) -> PResult<()> {
        if self.eat_word(w) {
            Ok(())
        } else {
            Err(self.err(format!("expected {what}, found {}", self.found())))
        }
    }

    fn expect_end(&mut self, what: &str) -> PResult<()> {
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
    fn label(&mut self) -> Option<Label> {
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

    fn label_ref(&mut self, what: &str) -> PResult<Label> {
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

    fn program_name(&mut self, what: &str) -> PResult<String> {
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

    /// The statement after an optional label.
    fn statement(&mut self) -> PResult<LineKind> {
        let span = self.span();
        // Assignment: a variable followed by `=` or `[`.
        if let Some(Tok::Name(n)) = self.peek() {
            let n = n.clone();
            if matches!(self.peek_at(1), Some(Tok::Assign | Tok::LBracket)) {
                let target = self.lvalue()?;
                self.expect(&Tok::Assign, "\"=\" after the variable")?;
                let value = self.expr()?;
                self.expect_end("the assignment")?;
                return Ok(LineKind::Stmt(StmtKind::Assign { target, value }));
            }
            if n.local || n.sigil != Sigil::None {
                return Err(self.err(format!(
                    "expected \"=\" after {n} (an assignment), found {}",
                    describe(self.toks.get(self.pos + 1))
                )));
            }
            // A system switch: `ABS.SPEED ON`.
            if keywords::system_switch_default(&n.text).is_some() && n.text != "cp" {
                if let Some(Tok::Name(v)) = self.peek_at(1) {
                    if matches!(v.text.as_str(), "on" | "off") && self.toks.len() == self.pos + 2 {
                        let on = v.text == "on";
                        self.pos += 2;
                        return Ok(LineKind::Stmt(StmtKind::SetSwitch { name: n.text, on }));
                    }
                }
                // `ABS.SPEED 1: ON`: the robot number first. The emulator has robot 1.
                if let (
                    Some(r @ (Tok::Num(_) | Tok::Name(_))),
                    Some(Tok::Colon),
                    Some(Tok::Name(v)),
                ) = (self.peek_at(1), self.peek_at(2), self.peek_at(3))
                {
                    if matches!(v.text.as_str(), "on" | "off") && self.toks.len() == self.pos + 4 {
                        if *r != Tok::Num(1.0) {
                            let what = format!("{} of another robot", n.text.to_uppercase());
                            return Ok(self.not_emulated_rest(&what));
                        }
                        let on = v.text == "on";
                        self.pos += 4;
                        return Ok(LineKind::Stmt(StmtKind::SetSwitch { name: n.text, on }));
                    }
                }
            }
            let Some(kw) = keywords::statement(&n.text) else {
                let msg = if let keywords::Lookup::Ambiguous(a, b) =
                    keywords::lookup(&n.text, keywords::Role::INSTRUCTION)
                {
                    format!(
                        "{} is short for both {} and {}: spell it out (P0110 Specify full spelling of command.)",
                        n.text.to_uppercase(),
                        a.name.to_uppercase(),
                        b.name.to_uppercase()
                    )
                } else if self.peek_at(1).is_none() {
                    format!(
                        "unknown instruction {:?} (an assignment needs \"= value\")",
                        n.text.to_uppercase()
                    )
                } else {
                    format!("unknown instruction {:?}", n.text.to_uppercase())
                };
                return Err(ParseError::new(self.file, span, msg));
            };
            self.pos += 1;
            return self.keyword_statement(kw, span);
        }
        Err(self.err(format!(
            "expected an instruction or an assignment, found {}",
            self.found()
        )))
    }

    fn keyword_statement(&mut self, kw: &'static str, span: Span) -> PResult<LineKind> {
        let simple = |k: StmtKind| Ok(LineKind::Stmt(k));
        // `POINT .rno: …`, `DECOMPOSE 2: …`: the robot number first, as multi-robot
        // controllers write it. Robot 1 is this robot; another is not emulated.
        if !OWN_COLON.contains(&kw)
            && matches!(self.peek(), Some(Tok::Num(_) | Tok::Name(_)))
            && self.peek_at(1) == Some(&Tok::Colon)
        {
            if self.peek() != Some(&Tok::Num(1.0)) {
                return Ok(
                    self.not_emulated_rest(&format!("{} for another robot", kw.to_uppercase()))
                );
            }
            self.pos += 2;
        }
        let kind = match kw {
            "if" => {
                let cond = self.expr()?;
                if self.eat_word("then") {
                    self.expect_end(
                        "IF … THEN (the statements go on the following lines, up to END)",
                    )?;
                    return Ok(LineKind::IfThen(cond));
                }
                if self.eat_word("goto") {
                    let label = self.label_ref("GOTO")?;
                    self.expect_end("IF … GOTO")?;
                    return simple(StmtKind::IfGoto { cond, label });
                }
                // `IF cond` alone on its line opens a block as `IF cond THEN` does: controllers
                // accept the block form without THEN.
                if self.at_end() {
                    return Ok(LineKind::IfThen(cond));
                }
                return Err(self.err(format!(
                    "expected THEN or GOTO after the IF condition, found {}",
                    self.found()
                )));
            }
            "else" => LineKind::Else,
            "end" => LineKind::End,
            "while" => {
                let cond = self.expr()?;
                // `WHILE cond` without DO: controllers accept it.
                if !self.at_end() {
                    self.expect_word("do", "DO after the WHILE condition")?;
                }
                LineKind::While(cond)
            }
            "do" => LineKind::Do,
            "until" => LineKind::Until(self.expr()?),
            "for" => {
                let var = self.lvalue()?;
                if var.name.sigil != Sigil::None {
                    return Err(ParseError::new(
                        self.file,
                        var.span,
                        "the FOR variable must be a real variable",
                    ));
                }
                self.expect(&Tok::Assign, "\"=\" after the FOR variable")?;
                let from = self.expr()?;
                self.expect_word("to", "TO in the FOR statement")?;
                let to = self.expr()?;
                let step = if self.eat_word("step") {
                    Some(self.expr()?)
                } else {
                    None
                };
                LineKind::For {
                    var,
                    from,
                    to,
                    step,
                }
            }
            "case" | "scase" => {
                let e = self.expr()?;
                self.expect_word("of", "OF after the CASE value")?;
                LineKind::Case(e)
            }
            "value" | "svalue" => {
                let mut v = vec![self.expr()?];
                while self.eat(&Tok::Comma) {
                    v.push(self.expr()?);
                }
                self.expect(&Tok::Colon, "\":\" after the VALUE list")?;
                LineKind::Value(v)
            }
            "any" => {
                // The colon after ANY is optional (`ANY :`, `ANY`).
                self.eat(&Tok::Colon);
                LineKind::Any
            }
            "goto" => {
                let label = self.label_ref("GOTO")?;
                // `GOTO label IF cond`: a conditional jump.
                if self.eat_word("if") {
                    let cond = self.expr()?;
                    LineKind::Stmt(StmtKind::IfGoto { cond, label })
                } else {
                    LineKind::Stmt(StmtKind::Goto(label))
                }
            }
            "call" => {
                // `CALL p(.$data[], 1)`: a whole array as an argument.
                if whole_array_at(&self.toks[self.pos..]) {
                    return Ok(LineKind::Stmt(StmtKind::NotEmulated {
                        instruction: "CALL (a whole array as an argument)".into(),
                        stubbed: false,
                    }));
                }
                // A CALL without a program name: kept as controllers save it, not emulated.
                if self.at_end() {
                    return Ok(self.not_emulated_rest("CALL without a program"));
                }
                let program = self.program_name("CALL")?;
                let args = self.call_args()?;
                LineKind::Stmt(StmtKind::Call { program, args })
            }
            "return" => LineKind::Stmt(StmtKind::Return),
            "print" | "type" => {
                // An optional device: `PRINT 2: …`, `PRINT tyterm: …` (the terminal, here).
                if matches!(
                    (self.peek(), self.peek_at(1)),
                    (Some(Tok::Num(_) | Tok::Name(_)), Some(Tok::Colon))
                ) {
                    self.pos += 2;
                }
                let items = self.print_items(false)?;
                LineKind::Stmt(StmtKind::Print { items })
            }
            "twait" => LineKind::Stmt(StmtKind::Twait(self.expr()?)),
            "wait" => LineKind::Stmt(StmtKind::Wait(self.expr()?)),
            "halt" => LineKind::Stmt(StmtKind::Halt),
            "stop" => LineKind::Stmt(StmtKind::Stop),
            "pause" => LineKind::Stmt(StmtKind::Pause),
            "signal" => {
                let mut v = vec![self.expr()?];
                while self.eat(&Tok::Comma) {
                    v.push(self.expr()?);
                }
                LineKind::Stmt(StmtKind::Signal(v))
            }
            "swait" => {
                let mut v = vec![self.expr()?];
                while self.eat(&Tok::Comma) {
                    v.push(self.expr()?);
                }
                LineKind::Stmt(StmtKind::Swait(v))
            }
            "pulse" => {
                let signal = self.expr()?;
                let time = if self.eat(&Tok::Comma) {
                    Some(self.expr()?)
                } else {
                    None
                };
                LineKind::Stmt(StmtKind::Pulse { signal, time })
            }
            "runmask" => {
                let signal = self.expr()?;
                let count = if self.eat(&Tok::Comma) {
                    Some(self.expr()?)
                } else {
                    None
                };
                LineKind::Stmt(StmtKind::RunMask { signal, count })
            }
            "dlysig" => {
                let signal = self.expr()?;
                self.expect(&Tok::Comma, "\",\" and the delay after the DLYSIG signal")?;
                let time = self.expr()?;
                LineKind::Stmt(StmtKind::Dlysig { signal, time })
            }
            "bits" | "bits32" => {
                let start = self.expr()?;
                self.expect(
                    &Tok::Comma,
                    "\",\" and the count after the first BITS signal",
                )?;
                let count = self.expr()?;
                self.expect(&Tok::Assign, "\"= value\" after BITS start, count")?;
                let value = self.expr()?;
                LineKind::Stmt(StmtKind::Bits {
                    wide: kw == "bits32",
                    start,
                    count,
                    value,
                })
            }
            "open" | "openi" | "close" | "closei" | "relax" | "relaxi" => {
                let action = match kw.trim_end_matches('i') {
                    "open" => HandAction::Open,
                    "close" => HandAction::Close,
                    _ => HandAction::Relax,
                };
                let hand = if self.peek().is_some() {
                    Some(self.expr()?)
                } else {
                    None
                };
                LineKind::Stmt(StmtKind::Hand {
                    action,
                    immediate: kw.ends_with('i'),
                    hand,
                })
            }
            "on" | "oni" => {
                let signal = self.expr()?;
                let action = if self.eat_word("goto") {
                    OnAction::Goto(self.label_ref("GOTO")?)
                } else if self.eat_word("call") {
                    OnAction::Call(self.program_name("CALL")?)
                } else {
                    return Err(self.err(format!(
                        "expected GOTO or CALL after the {} signal, found {}",
                        kw.to_uppercase(),
                        self.found()
                    )));
                };
                // Arguments to the interrupt program, or a priority: not emulated.
                if !self.at_end() {
                    return Ok(self.not_emulated_rest(if kw == "oni" {
                        "ONI with arguments or a priority"
                    } else {
                        "ON with arguments or a priority"
                    }));
                }
                LineKind::Stmt(StmtKind::On {
                    immediate: kw == "oni",
                    signal,
                    action,
                })
            }
            "ignore" => LineKind::Stmt(StmtKind::Ignore(self.expr()?)),
            "mc" => {
                let span = self.span();
                let word = match self.next().map(|t| t.tok) {
                    Some(Tok::Name(n)) if !n.local && n.sigil == Sigil::None => n.text,
                    other => {
                        return Err(ParseError::new(
                            self.file,
                            span,
                            format!("expected a monitor command after MC (EXECUTE, ABORT, HOLD, CONTINUE, SPEED, ERESET, PCEXECUTE, PCABORT), found {}", other.map_or("the end of the line".into(), |t| t.describe())),
                        ))
                    }
                };
                let Some(cmd) = keywords::monitor(&word) else {
                    // A monitor command the emulator does not run (`MC ZPOWER ON`, `MC PRIME
                    // a.main`) or a word in no table: loads as not emulated, its arguments
                    // checked as any argument list.
                    while self.next().is_some() {}
                    return Ok(LineKind::Stmt(StmtKind::NotEmulated {
                        instruction: format!("MC {}", word.to_uppercase()),
                        stubbed: false,
                    }));
                };
                LineKind::Stmt(self.monitor(cmd)?)
            }
            "execute" | "pcexecute" | "pcabort" => LineKind::Stmt(self.monitor(kw)?),
            "enable" | "disable" => {
                let nspan = self.span();
                let name = match self.next().map(|t| t.tok) {
                    Some(Tok::Name(n)) if !n.local && n.sigil == Sigil::None => n.text,
                    other => {
                        return Err(ParseError::new(
                            self.file,
                            nspan,
                            format!(
                                "expected a system switch name after {}, found {}",
                                kw.to_uppercase(),
                                other.map_or("the end of the line".into(), |t| t.describe())
                            ),
                        ))
                    }
                };
                if keywords::system_switch_default(&name).is_none() {
                    return Err(ParseError::new(
                        self.file,
                        nspan,
                        format!(
                            "{} is not a system switch this interpreter knows",
                            name.to_uppercase()
                        ),
                    ));
                }
                LineKind::Stmt(StmtKind::SetSwitch {
                    name,
                    on: kw == "enable",
                })
            }
            "abs.speed" => {
                let on = self.on_off("ABS.SPEED")?;
                LineKind::Stmt(StmtKind::SetSwitch {
                    name: "abs.speed".into(),
                    on,
                })
            }
            "timer" => {
                let timer = self.expr()?;
                self.expect(
                    &Tok::Assign,
                    "\"=\" after the timer number (TIMER n = seconds)",
                )?;
                let value = self.expr()?;
                LineKind::Stmt(StmtKind::Timer { timer, value })
            }
            "decompose" => {
                let target = self.lvalue()?;
                self.expect(&Tok::Assign, "\"=\" after the DECOMPOSE array")?;
                let source = self.expr()?;
                LineKind::Stmt(StmtKind::Decompose { target, source })
            }
            "here" => {
                let target = self.lvalue()?;
                // `HERE a + b`: b is defined relative to a. Not emulated.
                if self.peek() == Some(&Tok::Plus) {
                    return Ok(self.not_emulated_rest("HERE with a compound pose"));
                }
                LineKind::Stmt(StmtKind::Here { target })
            }
            "point" => {
                // `POINT/X`, `POINT/OAT`, `POINT/7`: only some components. Not emulated.
                if self.peek() == Some(&Tok::Slash) {
                    return Ok(self.not_emulated_rest("POINT with a component qualifier"));
                }
                let target = self.lvalue()?;
                self.expect(&Tok::Assign, "\"=\" after the POINT variable")?;
                let value = self.expr()?;
                LineKind::Stmt(StmtKind::Point { target, value })
            }
            "jmove" | "lmove" => LineKind::Stmt(StmtKind::Move {
                linear: kw == "lmove",
                target: self.expr()?,
            }),
            "lefty" | "righty" | "above" | "below" | "uwrist" | "dwrist" => {
                LineKind::Stmt(StmtKind::Posture(match kw {
                    "lefty" => Posture::Lefty,
                    "righty" => Posture::Righty,
                    "above" => Posture::Above,
                    "below" => Posture::Below,
                    "uwrist" => Posture::Uwrist,
                    _ => Posture::Dwrist,
                }))
            }
            "tool" | "base" => {
                let null = matches!(self.peek(), Some(Tok::Name(n)) if n.text == "null" && !n.local && n.sigil == Sigil::None)
                    && self.peek_at(1).is_none();
                let value = if null {
                    self.pos += 1;
                    None
                } else {
                    Some(self.expr()?)
                };
                LineKind::Stmt(StmtKind::Frame {
                    base: kw == "base",
                    value,
                })
            }
            "appro" | "jappro" | "lappro" => {
                let target = self.expr()?;
                self.expect(
                    &Tok::Comma,
                    "\",\" and the distance (mm) after the location approached",
                )?;
                let distance = self.expr()?;
                LineKind::Stmt(StmtKind::Appro {
                    linear: kw == "lappro",
                    target,
                    distance,
                })
            }
            "depart" | "jdepart" | "ldepart" => LineKind::Stmt(StmtKind::Depart {
                linear: kw == "ldepart",
                distance: self.expr()?,
            }),
            "draw" | "tdraw" => {
                let mut values: [Option<Expr>; 6] = Default::default();
                for (k, slot) in values.iter_mut().enumerate() {
                    if k > 0 && !self.eat(&Tok::Comma) {
                        break;
                    }
                    if !self.at_end() && self.peek() != Some(&Tok::Comma) {
                        *slot = Some(self.expr()?);
                    }
                }
                // A seventh value: this motion's speed.
                let speed = if self.eat(&Tok::Comma) {
                    Some(Box::new(self.expr()?))
                } else {
                    None
                };
                let [x, y, z, o, a, t] = values;
                LineKind::Stmt(StmtKind::Draw {
                    tool: kw == "tdraw",
                    offset: [x, y, z],
                    rotation: [o, a, t],
                    speed,
                })
            }
            "drive" => {
                let joint = self.expr()?;
                self.expect(&Tok::Comma, "`,` after DRIVE's joint number")?;
                let degrees = self.expr()?;
                let speed = if self.eat(&Tok::Comma) {
                    Some(self.expr()?)
                } else {
                    None
                };
                LineKind::Stmt(StmtKind::Drive {
                    joint,
                    degrees,
                    speed,
                })
            }
            "c1move" => LineKind::Stmt(StmtKind::CircleVia(self.expr()?)),
            "c2move" => LineKind::Stmt(StmtKind::CircleEnd(self.expr()?)),
            "xmove" => {
                let target = self.expr()?;
                if !self.eat_word("till") {
                    return Err(self.err(format!(
                        "expected TILL and a signal number after the XMOVE destination, found {}",
                        self.found()
                    )));
                }
                LineKind::Stmt(StmtKind::Xmove {
                    target,
                    till: self.expr()?,
                })
            }
            "align" => LineKind::Stmt(StmtKind::Align),
            "hmove" => LineKind::Stmt(StmtKind::Hmove(self.expr()?)),
            "home" => LineKind::Stmt(StmtKind::Home(if self.at_end() {
                None
            } else {
                Some(self.expr()?)
            })),
            "delay" => LineKind::Stmt(StmtKind::Delay(self.expr()?)),
            "brake" => LineKind::Stmt(StmtKind::Brake),
            "break" => LineKind::Stmt(StmtKind::Break),
            "speed" => {
                let value = self.expr()?;
                let unit = if self.word() == Some("mm") && self.peek_at(1) == Some(&Tok::Slash) {
                    self.pos += 2;
                    if self.eat_word("s") {
                        SpeedUnit::MmPerS
                    } else if self.eat_word("min") {
                        SpeedUnit::MmPerMin
                    } else {
                        return Err(self.err(format!(
                            "expected S or MIN after MM/, found {}",
                            self.found()
                        )));
                    }
                } else if self.eat_word("s") {
                    SpeedUnit::Seconds
                } else {
                    SpeedUnit::Percent
                };
                // A rotational speed (`, 30 DEG/S`): not emulated.
                if self.peek() == Some(&Tok::Comma) {
                    return Ok(self.not_emulated_rest("SPEED with a rotational speed"));
                }
                let always = self.eat_word("always");
                LineKind::Stmt(StmtKind::Speed {
                    value,
                    unit,
                    always,
                })
            }
            "accuracy" => {
                let value = self.expr()?;
                let mut fine = false;
                let mut always = false;
                loop {
                    if self.eat_word("fine") {
                        fine = true;
                    } else if self.eat_word("always") {
                        always = true;
                    } else {
                        break;
                    }
                }
                LineKind::Stmt(StmtKind::Accuracy {
                    value,
                    fine,
                    always,
                })
            }
            "accel" | "decel" => {
                let value = self.expr()?;
                let always = self.eat_word("always");
                LineKind::Stmt(StmtKind::AccelDecel {
                    decel: kw == "decel",
                    value,
                    always,
                })
            }
            "cp" => LineKind::Stmt(StmtKind::Cp(self.on_off("CP")?)),
            k if k.starts_with("tcp_") => LineKind::Stmt(StmtKind::Tcp(self.tcp(k)?)),
            k if k.starts_with("udp_") => LineKind::Stmt(StmtKind::Udp(self.udp(k)?)),
            "one" => {
                if self.peek().is_none() || self.eat_word("off") {
                    LineKind::Stmt(StmtKind::OnError(None))
                } else {
                    LineKind::Stmt(StmtKind::OnError(Some(self.program_name("ONE")?)))
                }
            }
            other => {
                return Err(ParseError::new(
                    self.file,
                    span,
                    format!("{} cannot start a statement here", other.to_uppercase()),
                ))
            }
        };
        self.expect_end(&format!("the {} statement", kw.to_uppercase()))?;
        Ok(kind)
    }

    /// The rest of the line, read as any well-formed argument list, as a statement that loads
    /// as not emulated under the name `what`.
    fn not_emulated_rest(&mut self, what: &str) -> LineKind {
        self.pos = self.toks.len();
        LineKind::Stmt(StmtKind::NotEmulated {
            instruction: what.to_owned(),
            stubbed: false,
        })
    }

    fn on_off(&mut self, what: &str) -> PResult<bool> {
        if self.eat_word("on") {
            Ok(true)
        } else if self.eat_word("off") {
            Ok(false)
        } else {
            Err(self.err(format!(
                "expected ON or OFF after {what}, found {}",
                self.found()
            )))
        }
    }

    fn monitor(&mut self, cmd: &str) -> PResult<StmtKind> {
        Ok(StmtKind::Monitor(match cmd {
            "execute" => {
                // `EXECUTE 2: prog`: the robot number. The emulator has one robot.
                if let Some(robot) = self.task_prefix()? {
                    if !matches!(robot.kind, ExprKind::Num(n) if n == 1.0) {
                        self.pos = self.toks.len();
                        return Ok(StmtKind::NotEmulated {
                            instruction: "EXECUTE for another robot".into(),
                            stubbed: false,
                        });
                    }
                }
                let program = self.program_name("EXECUTE")?;
                let args = self.call_args()?;
                let cycles = if self.eat(&Tok::Comma) {
                    Some(self.expr()?)
                } else {
                    None
                };
                MonitorCommand::Execute {
                    program,
                    args,
                    cycles,
                }
            }
            "pcexecute" => {
                let task = self.task_prefix()?;
                let program = self.program_name("PCEXECUTE")?;
                let args = self.call_args()?;
                let cycles = if self.eat(&Tok::Comma) {
                    Some(self.expr()?)
                } else {
                    None
                };
                MonitorCommand::PcExecute {
                    task,
                    program,
                    args,
                    cycles,
                }
            }
            "pcabort" => MonitorCommand::PcAbort {
                task: self.task_prefix()?,
            },
            "abort" => MonitorCommand::Abort,
            "hold" => MonitorCommand::Hold,
            "continue" => MonitorCommand::Continue,
            "speed" => {
                // `SPEED 2: 100`: the robot number. The emulator has one robot.
                if let Some(robot) = self.task_prefix()? {
                    if !matches!(robot.kind, ExprKind::Num(n) if n == 1.0) {
                        self.pos = self.toks.len();
                        return Ok(StmtKind::NotEmulated {
                            instruction: "SPEED for another robot".into(),
                            stubbed: false,
                        });
                    }
                }
                MonitorCommand::Speed(self.expr()?)
            }
            "ereset" => MonitorCommand::Ereset,
            other => return Err(self.err(format!("MC {} is not supported", other.to_uppercase()))),
        }))
    }

    /// `n:` before a program name (PC task number).
    fn task_prefix(&mut self) -> PResult<Option<Expr>> {
        if self.toks[self.pos.min(self.toks.len())..]
            .iter()
            .any(|t| t.tok == Tok::Colon)
        {
            let e = self.expr()?;
            self.expect(&Tok::Colon, "\":\" after the PC task number")?;
            return Ok(Some(e));
        }
        Ok(None)
    }

    fn call_args(&mut self) -> PResult<Vec<Expr>> {
        let mut args = Vec::new();
        if self.eat(&Tok::LParen) {
            if self.eat(&Tok::RParen) {
                return Ok(args);
            }
            loop {
                // `&a`, `.&a`: a transformation argument (the manual marks pose parameters
                // with `&`); the value is the same.
                self.eat(&Tok::Amp);
                args.push(self.expr()?);
                if self.eat(&Tok::RParen) {
                    break;
                }
                self.expect(&Tok::Comma, "\",\" or \")\" in the argument list")?;
            }
        }
        Ok(args)
    }

    fn tcp(&mut self, kw: &str) -> PResult<TcpStmt> {
        let ret = self.lvalue()?;
        let comma = |c: &mut Cur, what: &str| c.expect(&Tok::Comma, &format!("\",\" then {what}"));
        let opt = |c: &mut Cur| -> PResult<Option<Expr>> {
            if c.eat(&Tok::Comma) {
                Ok(Some(c.expr()?))
            } else {
                Ok(None)
            }
        };
        Ok(match kw {
            "tcp_listen" => {
                comma(self, "the port")?;
                TcpStmt::Listen {
                    ret,
                    port: self.expr()?,
                }
            }
            "tcp_end_listen" => {
                comma(self, "the port")?;
                TcpStmt::EndListen {
                    ret,
                    port: self.expr()?,
                }
            }
            "tcp_accept" => {
                comma(self, "the port")?;
                let port = self.expr()?;
                let timeout = opt(self)?;
                let ip = if self.eat(&Tok::Comma) {
                    Some(self.lvalue()?)
                } else {
                    None
                };
                TcpStmt::Accept {
                    ret,
                    port,
                    timeout,
                    ip,
                }
            }
            "tcp_recv" => {
                comma(self, "the socket id")?;
                let sock = self.expr()?;
                comma(self, "the string array element to fill")?;
                let buf = self.lvalue()?;
                comma(self, "the variable that receives the element count")?;
                let count = self.lvalue()?;
                let timeout = opt(self)?;
                let max = opt(self)?;
                TcpStmt::Recv {
                    ret,
                    sock,
                    buf,
                    count,
                    timeout,
                    max,
                }
            }
            "tcp_send" => {
                comma(self, "the socket id")?;
                let sock = self.expr()?;
                comma(self, "the string array element to send")?;
                let buf = self.lvalue()?;
                comma(self, "the number of elements")?;
                let n = self.expr()?;
                let timeout = opt(self)?;
                TcpStmt::Send {
                    ret,
                    sock,
                    buf,
                    n,
                    timeout,
                }
            }
            "tcp_status" => {
                comma(self, "the port array element")?;
                let port = self.lvalue()?;
                comma(self, "the socket id array element")?;
                let sock = self.lvalue()?;
                comma(self, "the error code array element")?;
                let err = self.lvalue()?;
                comma(self, "the sub-error code array element")?;
                let sub = self.lvalue()?;
                comma(self, "the IP address string array element")?;
                let ip = self.lvalue()?;
                TcpStmt::Status {
                    ret,
                    arrays: [port, sock, err, sub, ip],
                }
            }
            "tcp_close" => {
                comma(self, "the socket id")?;
                TcpStmt::Close {
                    ret,
                    sock: self.expr()?,
                }
            }
            "tcp_connect" => {
                comma(self, "the port")?;
                let port = self.expr()?;
                comma(self, "the IP address array element")?;
                let ip = self.lvalue()?;
                let timeout = opt(self)?;
                TcpStmt::Connect {
                    ret,
                    port,
                    ip,
                    timeout,
                }
            }
            other => return Err(self.err(format!("{} is not supported", other.to_uppercase()))),
        })
    }

    fn udp(&mut self, kw: &str) -> PResult<UdpStmt> {
        let ret = self.lvalue()?;
        let comma = |c: &mut Cur, what: &str| c.expect(&Tok::Comma, &format!("\",\" then {what}"));
        Ok(match kw {
            "udp_sendto" => {
                comma(self, "the IP address array element")?;
                let ip = self.lvalue()?;
                comma(self, "the port")?;
                let port = self.expr()?;
                comma(self, "the string array element to send")?;
                let buf = self.lvalue()?;
                comma(self, "the number of elements")?;
                let n = self.expr()?;
                let timeout = if self.eat(&Tok::Comma) {
                    Some(self.expr()?)
                } else {
                    None
                };
                UdpStmt::SendTo {
                    ret,
                    ip,
                    port,
                    buf,
                    n,
                    timeout,
                }
            }
            "udp_recvfrom" => {
                comma(self, "the port")?;
                let port = self.expr()?;
                comma(self, "the string array element to fill")?;
                let buf = self.lvalue()?;
                comma(self, "the variable that receives the element count")?;
                let count = self.lvalue()?;
                let mut timeout = None;
                let mut ip = None;
                let mut max = None;
                if self.eat(&Tok::Comma) {
                    timeout = Some(self.expr()?);
                    if self.eat(&Tok::Comma) {
                        ip = Some(self.lvalue()?);
                        if self.eat(&Tok::Comma) {
                            max = Some(self.expr()?);
                        }
                    }
                }
                UdpStmt::RecvFrom {
                    ret,
                    port,
                    buf,
                    count,
                    timeout,
                    ip,
                    max,
                }
            }
            other => return Err(self.err(format!("{} is not supported", other.to_uppercase()))),
        })
    }

    fn lvalue(&mut self) -> PResult<LValue> {
        let span = self.span();
        let name = match self.next().map(|t| t.tok) {
            Some(Tok::Name(n)) => n,
            other => {
                return Err(ParseError::new(
                    self.file,
                    span,
                    format!(
                        "expected a variable, found {}",
                        other.map_or("the end of the line".into(), |t| t.describe())
                    ),
                ))
            }
        };
        let indices = self.indices()?;
        Ok(LValue {
            name,
            indices,
            span,
        })
    }

    fn indices(&mut self) -> PResult<Vec<Expr>> {
        let mut v = Vec::new();
        if self.eat(&Tok::LBracket) {
            if self.peek() == Some(&Tok::RBracket) {
                return Err(self.err("expected an array index between [ and ]"));
            }
            loop {
                if v.len() == 3 {
                    return Err(self.err("an array has at most 3 dimensions"));
                }
                v.push(self.expr()?);
                if self.eat(&Tok::RBracket) {
                    break;
                }
                self.expect(&Tok::Comma, "\",\" or \"]\" in the array index")?;
            }
        }
        Ok(v)
    }

    /// Items of PRINT/TYPE (`in_call`: inside `$ENCODE(…)`, ending at `)`).
    fn print_items(&mut self, in_call: bool) -> PResult<Vec<PrintItem>> {
        let mut items = Vec::new();
        let at_stop = |c: &Cur| c.at_end() || (in_call && c.peek() == Some(&Tok::RParen));
        if at_stop(self) {
            return Ok(items);
        }
        loop {
            if self.peek() == Some(&Tok::Slash) {
                let span = self.span();
                self.pos += 1;
                items.push(PrintItem::Format(self.format_code(span)?, span));
            } else {
                items.push(PrintItem::Expr(self.expr()?));
            }
            if at_stop(self) {
                break;
            }
            self.expect(
                &Tok::Comma,
                if in_call {
                    "\",\" or \")\""
                } else {
                    "\",\" between PRINT items"
                },
            )?;
        }
        Ok(items)
    }

    fn format_code(&mut self, span: Span) -> PResult<FormatCode> {
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

    // ------------------------------------------------------------------ expressions

    fn expr(&mut self) -> PResult<Expr> {
        self.depth += 1;
        if self.depth > MAX_NESTING {
            return Err(self.err(format!(
                "expression nested deeper than {MAX_NESTING} levels"
            )));
        }
        let r = self.xor_expr();
        self.depth -= 1;
        r
    }

    fn binary_level(
        &mut self,
        ops: &[(&str, BinOp)],
        sym: &[(Tok, BinOp)],
        next: fn(&mut Self) -> PResult<Expr>,
    ) -> PResult<Expr> {
        let mut left = next(self)?;
        loop {
            let span = self.span();
            let op = if let Some(w) = self.word() {
                ops.iter().find(|(k, _)| *k == w).map(|(_, o)| *o)
            } else {
                self.peek()
                    .and_then(|t| sym.iter().find(|(k, _)| k == t).map(|(_, o)| *o))
            };
            let Some(op) = op else { break };
            self.pos += 1;
            let right = next(self)?;
            left = Expr {
                kind: ExprKind::Binary(op, Box::new(left), Box::new(right)),
                span,
            };
        }
        Ok(left)
    }

    // Precedence, lowest first, as AS-E p.3-22 lists it (highest first there): XOR, OR, AND,
    // BXOR, BOR, BAND, the relational operators, + and -, MOD, * and /, the unary operators
    // (-, NOT, COM), ^, then functions and array references. Parentheses override.

    fn xor_expr(&mut self) -> PResult<Expr> {
        self.binary_level(&[("xor", BinOp::Xor)], &[], Self::or_expr)
    }

    fn or_expr(&mut self) -> PResult<Expr> {
        self.binary_level(
            &[("or", BinOp::Or)],
            &[(Tok::Bar, BinOp::Or)],
            Self::and_expr,
        )
    }

    fn and_expr(&mut self) -> PResult<Expr> {
        self.binary_level(&[("and", BinOp::And)], &[], Self::bxor_expr)
    }

    fn bxor_expr(&mut self) -> PResult<Expr> {
        self.binary_level(&[("bxor", BinOp::Bxor)], &[], Self::bor_expr)
    }

    fn bor_expr(&mut self) -> PResult<Expr> {
        self.binary_level(&[("bor", BinOp::Bor)], &[], Self::band_expr)
    }

    fn band_expr(&mut self) -> PResult<Expr> {
        self.binary_level(&[("band", BinOp::Band)], &[], Self::rel_expr)
    }

    fn rel_expr(&mut self) -> PResult<Expr> {
        let e = self.binary_level(
            &[],
            &[
                (Tok::Eq, BinOp::Eq),
                (Tok::Ne, BinOp::Ne),
                (Tok::Lt, BinOp::Lt),
                (Tok::Gt, BinOp::Gt),
                (Tok::Le, BinOp::Le),
                (Tok::Ge, BinOp::Ge),
            ],
            Self::add_expr,
        )?;
        Ok(e)
    }

    fn add_expr(&mut self) -> PResult<Expr> {
        self.binary_level(
            &[],
            &[(Tok::Plus, BinOp::Add), (Tok::Minus, BinOp::Sub)],
            Self::mod_expr,
        )
    }

    fn mod_expr(&mut self) -> PResult<Expr> {
        self.binary_level(&[("mod", BinOp::Mod)], &[], Self::mul_expr)
    }

    fn mul_expr(&mut self) -> PResult<Expr> {
        self.binary_level(
            &[],
            &[(Tok::Star, BinOp::Mul), (Tok::Slash, BinOp::Div)],
            Self::unary_expr,
        )
    }

    fn unary_expr(&mut self) -> PResult<Expr> {
        let span = self.span();
        let op = if self.eat(&Tok::Minus) {
            Some(UnOp::Neg)
        } else if self.eat(&Tok::Plus) {
            return self.unary_expr_nested();
        } else if self.eat_word("com") {
            Some(UnOp::Com)
        } else if self.eat_word("not") {
            Some(UnOp::Not)
        } else {
            None
        };
        match op {
            Some(op) => {
                let e = self.unary_expr_nested()?;
                Ok(Expr {
                    kind: ExprKind::Unary(op, Box::new(e)),
                    span,
                })
            }
            None => self.pow_expr(),
        }
    }

    fn unary_expr_nested(&mut self) -> PResult<Expr> {
        self.depth += 1;
        if self.depth > MAX_NESTING {
            return Err(self.err(format!(
                "expression nested deeper than {MAX_NESTING} levels"
            )));
        }
        let r = self.unary_expr();
        self.depth -= 1;
        r
    }

    fn pow_expr(&mut self) -> PResult<Expr> {
        let base = self.primary()?;
        let span = self.span();
        if self.eat(&Tok::Caret) {
            // Right-associative; the exponent may carry a sign.
            let exp = self.unary_expr_nested()?;
            return Ok(Expr {
                kind: ExprKind::Binary(BinOp::Pow, Box::new(base), Box::new(exp)),
                span,
            });
        }
        Ok(base)
    }

    fn primary(&mut self) -> PResult<Expr> {
        let span = self.span();
        let Some(tok) = self.next() else {
            return Err(ParseError::new(
                self.file,
                span,
                "expected a value, found the end of the line",
            ));
        };
        let kind = match tok.tok {
            Tok::Num(v) => ExprKind::Num(v),
            Tok::Str(s) => ExprKind::Str(s),
            // `#[j1, j2, …]`: a joint-value constant, the same as `#PPOINT(j1, j2, …)`
            // (omitted values are 0).
            Tok::HashBracket => {
                let name = Name {
                    local: false,
                    sigil: Sigil::Hash,
                    text: "ppoint".into(),
                };
                let mut args = Vec::new();
                if !self.eat(&Tok::RBracket) {
                    loop {
                        args.push(self.arg_or_omitted(&[Tok::Comma, Tok::RBracket])?);
                        if self.eat(&Tok::RBracket) {
                            break;
                        }
                        self.expect(&Tok::Comma, "\",\" or \"]\" in the joint values #[…]")?;
                    }
                }
                ExprKind::Call { name, args }
            }
            Tok::LParen => {
                let e = self.expr()?;
                self.expect(&Tok::RParen, "\")\" to close the parenthesis")?;
                return Ok(e);
            }
            Tok::Name(mut name) => {
                let name_span = span;
                // `INRANGE:2(…)`, `#S_HERE:2`: a function of robot n. Robot 1 is this robot;
                // another's is a function the emulator does not compute (not emulated).
                if !name.local
                    && self.peek() == Some(&Tok::Colon)
                    && matches!(self.peek_at(1), Some(Tok::Num(_) | Tok::Name(_)))
                {
                    let at = self.pos;
                    let robot_one = self.peek_at(1) == Some(&Tok::Num(1.0));
                    self.pos += 1;
                    // The robot number: a number or a variable (`CVPOS2:arm[.i](…)`).
                    let robot = match self.next().map(|t| t.tok) {
                        Some(Tok::Name(_)) => self.indices().map(|_| ()),
                        _ => Ok(()),
                    };
                    // A function without arguments may take its robot too (`SACHK:.rno`).
                    let function = keywords::get(&name.to_string())
                        .is_some_and(|k| k.roles.contains(keywords::Role::FUNCTION));
                    if robot.is_ok() && self.peek() == Some(&Tok::LParen) {
                        if !robot_one {
                            name.text.push_str(":n");
                        }
                    } else if robot.is_ok() && function {
                        if !robot_one {
                            name.text.push_str(":n");
                        }
                        let span = name_span;
                        return Ok(Expr {
                            kind: ExprKind::Call {
                                name,
                                args: Vec::new(),
                            },
                            span,
                        });
                    } else {
                        self.pos = at;
                    }
                }
                if !name.local && self.peek() == Some(&Tok::LParen) {
                    self.pos += 1;
                    let args = self.func_args(&name)?;
                    ExprKind::Call { name, args }
                } else {
                    if !name.local && name.sigil == Sigil::None && is_operator_word(&name.text) {
                        return Err(ParseError::new(
                            self.file,
                            span,
                            format!(
                                "expected a value, found the operator {}",
                                name.text.to_uppercase()
                            ),
                        ));
                    }
                    let indices = self.indices()?;
                    ExprKind::Var(LValue {
                        name,
                        indices,
                        span,
                    })
                }
            }
            Tok::Assign => {
                return Err(ParseError::new(
                    self.file,
                    span,
                    "expected a value, found \"=\" (a comparison is written ==)",
                ));
            }
            other => {
                return Err(ParseError::new(
                    self.file,
                    span,
                    format!("expected a value, found {}", other.describe()),
                ));
            }
        };
        Ok(Expr { kind, span })
    }

    fn func_args(&mut self, name: &Name) -> PResult<Vec<Arg>> {
        let mut args = Vec::new();
        if self.eat(&Tok::RParen) {
            return Ok(args);
        }
        let formats = name.sigil == Sigil::Dollar && name.text == "encode";
        // `SHIFT(location BY dx, dy, dz)`: BY separates the location from the offsets.
        let shift = name.sigil == Sigil::None && name.text == "shift";
        // `SYSDATA(STEP)`, `$SYSDATA(ZROB.NAME, 1)`: the first argument is a keyword.
        let sysdata = name.text == "sysdata" && !name.local;
        loop {
            if formats && self.peek() == Some(&Tok::Slash) {
                let span = self.span();
                self.pos += 1;
                // A format code this loader does not know (`/I` without a width): kept as a
                // word; the statement loads as not emulated.
                let at = self.pos;
                match self.format_code(span) {
                    Ok(f) => args.push(Arg::Format(f, span)),
                    Err(e) => match self.toks.get(at).map(|t| &t.tok) {
                        Some(Tok::Name(n)) if !n.local && n.sigil == Sigil::None => {
                            args.push(Arg::Keyword(format!("/{}", n.text), span))
                        }
                        _ => return Err(e),
                    },
                }
            } else if sysdata && args.is_empty() {
                let span = self.span();
                match self.next().map(|t| t.tok) {
                    Some(Tok::Name(n)) if !n.local && n.sigil == Sigil::None => {
                        args.push(Arg::Keyword(n.text, span))
                    }
                    other => {
                        return Err(ParseError::new(
                            self.file,
                            span,
                            format!(
                                "expected a SYSDATA keyword such as STEP or M.SPEED, found {}",
                                other.map_or("the end of the line".into(), |t| t.describe())
                            ),
                        ))
                    }
                }
            } else {
                args.push(self.arg_or_omitted(&[Tok::Comma, Tok::RParen])?);
            }
            if self.eat(&Tok::RParen) {
                break;
            }
            if shift && args.len() == 1 && self.eat_word("by") {
                continue;
            }
            self.expect(
                &Tok::Comma,
                &format!("\",\" or \")\" in the arguments of {name}"),
            )?;
        }
        Ok(args)
    }

    /// A function argument, or an omitted one (`TRANS(, -100)`, `SHIFT(p BY , , 50)`): the
    /// next token is one of `enders`.
    fn arg_or_omitted(&mut self, enders: &[Tok]) -> PResult<Arg> {
        match self.peek() {
            Some(t) if enders.contains(t) => Ok(Arg::Omitted(self.span())),
            _ => Ok(Arg::Expr(self.expr()?)),
        }
    }

    fn signed_number(&mut self, what: &str) -> PResult<f64> {
        let neg = if self.eat(&Tok::Minus) {
            true
        } else {
            self.eat(&Tok::Plus);
            false
        };
        let span = self.span();
        match self.next().map(|t| t.tok) {
            Some(Tok::Num(v)) => Ok(if neg { -v } else { v }),
            other => Err(ParseError::new(
                self.file,
                span,
                format!(
                    "expected {what} (a number), found {}",
                    other.map_or("the end of the line".into(), |t| t.describe())
                ),
            )),
        }
    }

    fn data_item(&mut self, section: &str) -> PResult<DataItem> {
        let span = self.span();
        let name = match self.next().map(|t| t.tok) {
            Some(Tok::Name(n)) if !n.local => n,
            other => {
                return Err(ParseError::new(
                    self.file,
                    span,
                    format!(
                        "expected a global variable name, found {}",
                        other.map_or("the end of the line".into(), |t| t.describe())
                    ),
                ))
            }
        };
        let (want, what) = match section {
            "reals" => (Sigil::None, "a real variable such as count = 1"),
            "strings" => (Sigil::Dollar, "a string variable such as $name = \"text\""),
            "joints" => (Sigil::Hash, "a joint point such as #home 0 0 -90 0 -90 0"),
            _ => (
                Sigil::None,
                "a transformation such as pick 850 0 1153.5 0 180 0",
            ),
        };
        if name.sigil != want {
            return Err(ParseError::new(
                self.file,
                span,
                format!(
                    "the .{} section holds {what}, found {name}",
                    section.to_uppercase()
                ),
            ));
        }
        let mut indices = Vec::new();
        if self.eat(&Tok::LBracket) {
            loop {
                let v = self.signed_number("an array index")?;
                if v.fract() != 0.0 || !(0.0..=9999.0).contains(&v) {
                    return Err(self.err("an array index is an integer from 0 to 9999"));
                }
                indices.push(v as i32);
                if indices.len() > 3 {
                    return Err(self.err("an array has at most 3 dimensions"));
                }
                if self.eat(&Tok::RBracket) {
                    break;
                }
                self.expect(&Tok::Comma, "\",\" or \"]\" in the array index")?;
            }
        }
        let value = match section {
            "reals" => {
                self.expect(&Tok::Assign, "\"=\" after the variable")?;
                DataValue::Real(self.signed_number("the value")?)
            }
            "strings" => {
                self.expect(&Tok::Assign, "\"=\" after the variable")?;
                let sspan = self.span();
                match self.next().map(|t| t.tok) {
                    Some(Tok::Str(s)) => DataValue::Str(s),
                    other => {
                        return Err(ParseError::new(
                            self.file,
                            sspan,
                            format!(
                                "expected a string in quotes, found {}",
                                other.map_or("the end of the line".into(), |t| t.describe())
                            ),
                        ))
                    }
                }
            }
            _ => {
                let mut v = [0.0; 6];
                let mut n = 0;
                while !self.at_end() {
                    self.eat(&Tok::Comma);
                    if n == 6 {
                        return Err(self.err("expected at most 6 values"));
                    }
                    v[n] = self.signed_number("a value")?;
                    n += 1;
                }
                if n == 0 {
                    return Err(self.err("expected the values after the name"));
                }
                if section == "joints" {
                    DataValue::Joints(v)
                } else {
                    DataValue::Trans(v)
                }
            }
        };
        self.expect_end("the data line")?;
        Ok(DataItem {
            name,
            indices,
            value,
            span,
        })
    }
}

fn is_operator_word(w: &str) -> bool {
    matches!(
        w,
        "and"
            | "or"
            | "xor"
            | "mod"
            | "band"
            | "bor"
            | "bxor"
            | "then"
            | "do"
            | "to"
            | "step"
            | "of"
            | "goto"
    )
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

#[cfg(test)]
mod tests {
    use super::*;

    fn ok(text: &str) -> Module {
        match parse("t.as", text) {
            Ok(m) => m,
            Err(e) => panic!("{e}"),
        }
    }

    fn err(text: &str) -> String {
        parse("t.as", text).unwrap_err().to_string()
    }

    #[test]
    fn programs_blocks_and_data() {
        let m = ok(".PROGRAM main(.a, .$b)\r\n\
                    ; comment — ünïcode\r\n\
                    start:\r\n\
                      IF .a > 1 THEN\r\n\
                        .a = .a - 1\r\n\
                      ELSE\r\n\
                        WHILE .a < 5 DO\r\n\
                          .a = .a + 1\r\n\
                        END\r\n\
                      END\r\n\
                      CASE .a OF\r\n\
                        VALUE 1, 2:\r\n\
                          PRINT \"one or two\", /F5.1, .a\r\n\
                        ANY :\r\n\
                          GOTO start\r\n\
                      END\r\n\
                      DO\r\n\
                        TWAIT 0.1\r\n\
                      UNTIL .a == 3\r\n\
                      FOR .i = 1 TO 3 STEP 2\r\n\
                        SIGNAL 2001, -2002\r\n\
                      END\r\n\
                      MC EXEC ros_move\r\n\
                    .END\r\n\
                    .REALS\r\n\
                    count = -2.5\r\n\
                    tab[1,2] = 3\r\n\
                    .END\r\n\
                    .STRINGS\r\n\
                    $s = \"a;b\"\r\n\
                    .END\r\n\
                    .JOINTS\r\n\
                    #home 0 0 -90 0 -90 0\r\n\
                    .END\r\n\
                    .TRANS\r\n\
                    pick 850 0 1153.5 0 180 0\r\n\
                    .END\r\n");
        let p = &m.programs[0];
        assert_eq!(p.name, "main");
        assert_eq!(p.params.len(), 2);
        assert_eq!(p.body.len(), 6);
        assert_eq!(p.body[0].label.as_ref().unwrap().name, "start");
        assert!(matches!(p.body[1].kind, StmtKind::If { .. }));
        let StmtKind::Case { arms, .. } = &p.body[2].kind else {
            panic!()
        };
        assert_eq!(arms.len(), 2);
        assert!(arms[1].values.is_none());
        assert!(matches!(
            &p.body[5].kind,
            StmtKind::Monitor(MonitorCommand::Execute { program, .. }) if program == "ros_move"
        ));
        assert_eq!(m.data.len(), 5);
        assert_eq!(m.data[1].indices, vec![1, 2]);
        assert_eq!(m.data[2].value, DataValue::Str(b"a;b".to_vec()));
        assert_eq!(
            m.data[3].value,
            DataValue::Joints([0.0, 0.0, -90.0, 0.0, -90.0, 0.0])
        );
    }

    #[test]
    fn errors_say_where_and_what() {
        assert_eq!(
            err(".PROGRAM p()\n  IF a THEN\n.END\n"),
            "t.as:2:3: expected END to close this IF before .END"
        );
        assert_eq!(
            err(".PROGRAM p()\n  WHILE a b\n  END\n.END\n"),
            "t.as:2:11: expected DO after the WHILE condition, found \"b\""
        );
        assert_eq!(
            err(".PROGRAM p()\n  a = (1 + 2\n.END\n"),
            "t.as:2:13: expected \")\" to close the parenthesis, found the end of the line"
        );
        assert_eq!(err(".PROGRAM p()\n  IF a = 1 THEN\n  END\n.END\n"), "t.as:2:8: expected THEN or GOTO after the IF condition, found \"=\" (a comparison is written ==)");
        // A stray END, a word in no table and a monitor command MC does not run load as
        // not emulated, each named in a warning.
        for (text, warning) in [
            (
                ".PROGRAM p()\n  END\n.END\n",
                "t.as:2:3: END without an open block loads but is not emulated",
            ),
            (
                ".PROGRAM p()\n  JAPPRX a, 10\n.END\n",
                "t.as:2:3: JAPPRX loads but is not emulated",
            ),
            (
                ".PROGRAM p()\n  MC FOO\n.END\n",
                "t.as:2:3: MC FOO loads but is not emulated",
            ),
        ] {
            let m = ok(text);
            assert!(
                m.warnings[0].to_string().starts_with(warning),
                "{}",
                m.warnings[0]
            );
        }
        // Unbalanced brackets in a line that loads without being parsed: a controller
        // refuses it too.
        assert_eq!(
            err(".PROGRAM p()\n  JAPPRX (a, 10\n.END\n"),
            "t.as:2:10: this bracket is not closed: a controller refuses this line too"
        );
        // A form of an instruction the emulator runs that it cannot read, but well formed:
        // loads as not emulated, and the warning says why and asks for a report.
        let m = ok(".PROGRAM p()\n  PRINT /Q3, a\n.END\n");
        assert!(m.warnings.iter().any(|w| w.to_string().starts_with(
            "t.as:2:9: PRINT: this form is not read by the emulator yet (/Q3 is not a format code"
        )));
        // The same with more values than the instruction takes: a controller refuses it too.
        assert_eq!(
            err(".PROGRAM p()\n  JMOVE a, 1, 2\n.END\n"),
            "t.as:2:10: unexpected \",\" after the end of the JMOVE statement"
        );
        assert_eq!(
            err(".PROGRAM p()\n"),
            "t.as:1:1: expected .END to close this .PROGRAM (the file ends at line 2)"
        );
        assert_eq!(err("x = 1\n"), "t.as:1:1: expected .PROGRAM or a data section (.REALS, .STRINGS, .JOINTS, .TRANS), found \"x = 1\"");
        assert_eq!(
            err(".PROGRAM p()\n  a[1,2,3,4] = 0\n.END\n"),
            "t.as:2:11: an array has at most 3 dimensions"
        );
        assert_eq!(
            err(".PROGRAM p()\n.END\n.PROGRAM p()\n.END\n"),
            "t.as:3:1: program p is defined twice (first at line 1)"
        );
        // Several errors at once.
        assert_eq!(
            err(".PROGRAM p()\n  a = \n  b = )\n.END\n").lines().count(),
            2
        );
    }

    #[test]
    fn nesting_is_bounded() {
        let deep = format!(
            ".PROGRAM p()\n  a = {}1{}\n.END\n",
            "(".repeat(200),
            ")".repeat(200)
        );
        assert!(err(&deep).contains("nested deeper"));
        let mut blocks = String::from(".PROGRAM p()\n");
        for _ in 0..100 {
            blocks.push_str("IF 1 THEN\n");
        }
        for _ in 0..100 {
            blocks.push_str("END\n");
        }
        blocks.push_str(".END\n");
        assert!(err(&blocks).contains("nested deeper"));
        assert!(err(".PROGRAM p()\n a = ----------------------------------------------------------1\n.END\n").contains("nested deeper"));
    }

    #[test]
    fn skipped_sections_and_comments() {
        let m = ok(".*=== header ===\n.AUXDATA\nwhatever 1 2\n.END\n.PROGRAM q() ;c\n.END\n");
        assert_eq!(m.programs.len(), 1);
        assert_eq!(m.warnings.len(), 1);
        assert_eq!(
            m.warnings[0].to_string(),
            "t.as:2:1: section .AUXDATA (lines 2–4) is kept as it is: the emulator does not use it"
        );
    }

    #[test]
    fn formats() {
        assert_eq!(parse_format("f10.3"), Some(FormatCode::F(10, 3)));
        assert_eq!(parse_format("f8"), Some(FormatCode::F(8, 0)));
        assert_eq!(parse_format("x"), Some(FormatCode::X(1)));
        assert_eq!(parse_format("i"), None);
        assert_eq!(parse_format("dd"), None);
    }
}
