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

mod block;
mod bytes;
mod cursor;
mod data;
mod expr;
mod file;
mod format;
mod statement;

use crate::ast::*;
use crate::error::{LoadError, ParseError, MAX_REPORTED};
use crate::lexer::{columns, strip_comment_bytes};
use crate::options::LoadOptions;
use crate::sections::{directive, section, SectionEnd, SectionUse};
use crate::span::Span;

use bytes::{is_end_line, trim_blanks, truncate};
use file::FileParser;

pub(crate) use bytes::header_end;
pub use bytes::split_lines;
pub use cursor::MAX_NESTING;
pub use format::parse_format;

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
