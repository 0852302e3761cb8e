//! A lint against the real controller's limits: what loads in the emulator but would not load,
//! or would behave differently, on a Kawasaki controller. Every rule is in [`RULES`] with its
//! source; `fs020n as check` prints the findings.

use std::collections::HashMap;

use crate::ast::{
    Expr, ExprKind, Module, MonitorCommand, OnAction, Stmt, StmtKind, TcpStmt, UdpStmt, UnOp,
};
use crate::keywords::{self, Generations, Lookup, Role};
use crate::lexer::{columns, strip_comment_bytes, tokenize_bytes, Tok};
use crate::parser::split_lines;
use crate::sections::SectionUse;
use crate::span::Span;

/// A controller generation (`--controller c|d|e|f`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, serde::Serialize)]
pub enum Generation {
    /// C series.
    C,
    /// D series.
    D,
    /// E series.
    E,
    /// F series.
    F,
}

impl std::str::FromStr for Generation {
    type Err = String;
    fn from_str(s: &str) -> Result<Generation, String> {
        match s.to_ascii_lowercase().as_str() {
            "c" => Ok(Generation::C),
            "d" => Ok(Generation::D),
            "e" => Ok(Generation::E),
            "f" => Ok(Generation::F),
            other => Err(format!(
                "{other:?} is not a controller generation (c, d, e or f)"
            )),
        }
    }
}

/// How serious a finding is: an error means the controller would refuse the program or run it
/// differently from the emulator (`fs020n as check` exits 1).
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Severity {
    /// The controller would refuse it, or it changes what the program does.
    Error,
    /// Likely a problem on the controller.
    Warning,
}

/// One lint rule.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Rule {
    /// Its name in the findings (`name-length`).
    pub id: &'static str,
    /// How serious its findings are.
    pub severity: Severity,
    /// The generations it applies to (empty: all, and when no generation is given).
    pub generations: &'static [Generation],
    /// What it checks.
    pub checks: &'static str,
    /// Where the limit comes from.
    pub source: &'static str,
}

/// The longest name the controller keeps, characters.
pub const CONTROLLER_NAME_LIMIT: usize = 15;

/// The longest program line checked, bytes (a choice: no manual found states a limit for a
/// program step; the terminal takes commands of at most 128 characters).
pub const LINE_LIMIT: usize = 128;

/// Every lint rule, with its source.
pub const RULES: &[Rule] = &[
    Rule {
        id: "name-length",
        severity: Severity::Warning,
        generations: &[],
        checks: "a variable, program or label name longer than 15 characters",
        source: "AS manuals: names of up to 15 characters; a controller SAVE keeps the first 15",
    },
    Rule {
        id: "name-collision",
        severity: Severity::Error,
        generations: &[],
        checks: "two different names that share their first 15 characters (one variable on the controller)",
        source: "follows from name-length: the controller keeps 15 characters",
    },
    Rule {
        id: "non-ascii-code",
        severity: Severity::Error,
        generations: &[],
        checks: "a byte outside ASCII outside comments and strings (a no-break or ideographic space the emulator reads as a blank)",
        source: "AS names, numbers and operators are ASCII (AS manuals); comments and strings may hold any bytes",
    },
    Rule {
        id: "line-length",
        severity: Severity::Warning,
        generations: &[],
        checks: "a program or data line longer than 128 bytes",
        source: "chosen: no limit found for a step; the terminal takes commands of at most 128 characters (research: anchors.md, kawasaki-robots-rest-api)",
    },
    Rule {
        id: "tcp-timeout-range",
        severity: Severity::Warning,
        generations: &[],
        checks: "a constant TCP_ACCEPT/RECV/SEND/CONNECT or UDP_SENDTO/RECVFROM timeout outside 1–60 s (0–60 s on E)",
        source: "TCP/IP Communication Manuals E and F: timeout range 0–60 s (E), 1–60 s (F) (research: as-language.md §3); UDP: 'the same style' as TCP ([COM-F] §1.5), the range assumed",
    },
    Rule {
        id: "tcp-port-range",
        severity: Severity::Error,
        generations: &[],
        checks: "a constant TCP_LISTEN/ACCEPT/END_LISTEN or UDP_RECVFROM port outside 8192–65535",
        source: "TCP/IP Communication Manual E: TCP_LISTEN port 8192–65535, else an error (research: as-language.md §3); UDP_RECVFROM's port assumed the same (the emulator refuses others)",
    },
    Rule {
        id: "d-tcp-recv-arguments",
        severity: Severity::Warning,
        generations: &[Generation::D],
        checks: "TCP_RECV without both its timeout and max-bytes arguments on a D controller",
        source: "the one known D-controller program passes both only in its D variant (research: as-language.md, generation caveat; low confidence). An earlier reading, 'D takes no optional arguments', contradicts that program and would leave a server without its receive timeout",
    },
    Rule {
        id: "d-integer-timeout",
        severity: Severity::Warning,
        generations: &[Generation::D],
        checks: "a constant TCP timeout that is not a whole number of seconds on a D controller",
        source: "D-series timeouts are whole seconds (low confidence; research: as-language.md, generation caveat)",
    },
    Rule {
        id: "unknown-word",
        severity: Severity::Warning,
        generations: &[],
        checks: "a program line whose first word is in no keyword table (a typo, or an option of another controller); did-you-mean when one edit from a keyword",
        source: "the keyword table (fs020n_as::keywords: the E manual's language list and the keywords of real files)",
    },
    Rule {
        id: "monitor-command-in-program",
        severity: Severity::Warning,
        generations: &[],
        checks: "a monitor command written as a program step without MC (`ZPOWER ON`, `KILL`)",
        source: "AS-E p.6-121: a PC program gives monitor commands through MC",
    },
    Rule {
        id: "generation-keyword",
        severity: Severity::Warning,
        generations: &[Generation::C, Generation::D, Generation::E],
        checks: "an instruction known only from F-series controllers and newer tools, on an older generation",
        source: "the keyword table's generations (E manual; F-series saves and tools)",
    },
    Rule {
        id: "undefined-program",
        severity: Severity::Warning,
        generations: &[],
        checks: "CALL, EXECUTE, PCEXECUTE or ON … CALL of a program that none of the files checked together defines (the task stops with E0119 there)",
        source: "AS-E: programs are found when a task reaches them (E0119 Nonexistent subroutine.)",
    },
];

/// The rule called `id`.
pub fn rule(id: &str) -> Option<&'static Rule> {
    RULES.iter().find(|r| r.id == id)
}

/// One finding of the lint.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct Finding {
    /// The rule ([`RULES`]).
    pub rule: &'static str,
    /// How serious.
    pub severity: Severity,
    /// Line (from 1).
    pub line: u32,
    /// Column (from 1).
    pub column: u32,
    /// What is wrong and what to do.
    pub message: String,
}

/// Lints a parsed file (`bytes` are its bytes, `module` what [`crate::parse_bytes`] made of
/// them) for `generation` (`None`: rules for every generation, the strictest ranges).
pub fn lint(bytes: &[u8], module: &Module, generation: Option<Generation>) -> Vec<Finding> {
    let defined: Vec<&str> = module.programs.iter().map(|p| p.name.as_str()).collect();
    lint_in_memory(bytes, module, generation, &defined)
}

/// [`lint`] for a file loaded into a controller memory with others: `defined` names every
/// program of the memory (the `undefined-program` rule reads it).
pub fn lint_in_memory(
    bytes: &[u8],
    module: &Module,
    generation: Option<Generation>,
    defined: &[&str],
) -> Vec<Finding> {
    let mut out = Vec::new();
    let mut add = |id: &'static str, span: Span, message: String| {
        let Some(r) = rule(id) else { return };
        if !r.generations.is_empty() && !generation.is_some_and(|c| r.generations.contains(&c)) {
            return;
        }
        out.push(Finding {
            rule: id,
            severity: r.severity,
            line: span.line,
            column: span.col,
            message,
        });
    };
    let lines = split_lines(bytes);
    // Names seen: (scope, sigil, first 15 characters) → (full name, where first seen).
    let mut names: HashMap<(String, u8, String), Vec<(String, Span)>> = HashMap::new();
    for s in &module.sections {
        if !matches!(s.reads, SectionUse::Program | SectionUse::Data) {
            continue;
        }
        let scope = module
            .programs
            .iter()
            .find(|p| p.span.line == s.first_line)
            .map(|p| p.name.clone())
            .unwrap_or_default();
        for n in s.first_line..=s.last_line {
            let Some(line) = lines.get(n as usize - 1) else {
                break;
            };
            let cols = columns(line);
            if line.len() > LINE_LIMIT {
                add(
                    "line-length",
                    Span::new(n, cols[LINE_LIMIT]),
                    format!(
                        "this line has {} bytes; keep program lines to {LINE_LIMIT}",
                        line.len()
                    ),
                );
            }
            let code = strip_comment_bytes(line);
            let mut in_str = false;
            for (k, &b) in code.iter().enumerate() {
                if b == b'"' {
                    in_str = !in_str;
                } else if b >= 0x80 && !in_str {
                    add(
                        "non-ascii-code",
                        Span::new(n, cols[k]),
                        format!("byte 0x{b:02X} outside a comment or a string: the controller reads only ASCII here (retype the blank or the name)"),
                    );
                    break;
                }
            }
            // Names: on the first line of a program, those after `.PROGRAM` and before a
            // step marker; none on the first line of a data section.
            let (from, to) = if n == s.first_line {
                if s.reads != SectionUse::Program {
                    continue;
                }
                let dot = code.iter().position(|b| *b == b'.').unwrap_or(0);
                let from = (dot + 1..code.len())
                    .find(|&k| !(code[k].is_ascii_alphanumeric() || code[k] == b'_'))
                    .unwrap_or(code.len());
                let to = crate::parser::header_end(&code[from..]).map_or(code.len(), |k| from + k);
                (from, to)
            } else {
                (0, code.len())
            };
            let (code, offset) = (&code[from..to], from);
            let Ok(toks) = tokenize_bytes(&module.file, n, code, &cols[offset..]) else {
                continue;
            };
            for t in toks {
                let Tok::Name(name) = t.tok else { continue };
                if name.text.chars().count() <= CONTROLLER_NAME_LIMIT {
                    continue;
                }
                let shown = name.to_string();
                add(
                    "name-length",
                    t.span,
                    format!(
                        "{shown} has {} characters; the controller keeps {CONTROLLER_NAME_LIMIT} ({})",
                        name.text.chars().count(),
                        &name.text[..CONTROLLER_NAME_LIMIT]
                    ),
                );
                let key = (
                    if name.local {
                        scope.clone()
                    } else {
                        String::new()
                    },
                    name.sigil as u8,
                    name.text[..CONTROLLER_NAME_LIMIT].to_owned(),
                );
                let seen = names.entry(key).or_default();
                if !seen.iter().any(|(t, _)| *t == name.text) {
                    if let Some((other, at)) = seen.first() {
                        add(
                            "name-collision",
                            t.span,
                            format!(
                                "{shown} and {other} (line {}) share their first {CONTROLLER_NAME_LIMIT} characters: on the controller they are one variable — rename one",
                                at.line
                            ),
                        );
                    }
                    seen.push((name.text.clone(), t.span));
                }
            }
        }
    }
    for p in &module.programs {
        walk(&p.body, &mut |s| net_lint(s, generation, &mut add));
        walk(&p.body, &mut |s| word_lint(s, generation, &mut add));
        walk(&p.body, &mut |s| program_lint(s, defined, &mut add));
    }
    out.sort_by_key(|f| (f.line, f.column));
    out
}

fn walk(stmts: &[Stmt], f: &mut dyn FnMut(&Stmt)) {
    for s in stmts {
        f(s);
        match &s.kind {
            StmtKind::If {
                then, otherwise, ..
            } => {
                walk(then, f);
                walk(otherwise, f);
            }
            StmtKind::While { body, .. }
            | StmtKind::DoUntil { body, .. }
            | StmtKind::For { body, .. } => walk(body, f),
            StmtKind::Case { arms, .. } => {
                for a in arms {
                    walk(&a.body, f);
                }
            }
            _ => {}
        }
    }
}

/// The keyword-table rules of a line that loads as not emulated: a word in no table, a
/// monitor command without MC, a keyword of a newer generation.
fn word_lint(
    s: &Stmt,
    generation: Option<Generation>,
    add: &mut dyn FnMut(&'static str, Span, String),
) {
    let StmtKind::NotEmulated { instruction, .. } = &s.kind else {
        return;
    };
    let Some(first) = instruction.split([' ', '(']).next() else {
        return;
    };
    // Descriptions (`HERE with a compound pose`) name a keyword first; anything else that
    // is not a word in upper case is not a word of the file.
    if first == "MC"
        || first.is_empty()
        || first.bytes().any(|b| b.is_ascii_lowercase())
        || instruction.ends_with("(block-teaching step)")
    {
        return;
    }
    let word = first.to_ascii_lowercase();
    let any_role = Role::INSTRUCTION
        .or(Role::MONITOR)
        .or(Role::SWITCH)
        .or(Role::FUNCTION)
        .or(Role::EDITOR)
        .or(Role::WORD);
    match keywords::lookup(&word, any_role) {
        Lookup::Unknown => {
            let hint = match keywords::did_you_mean(&word, Role::INSTRUCTION) {
                Some(k) => format!("did you mean {}? ", k.name.to_uppercase()),
                None => String::new(),
            };
            if !word.starts_with("fn") {
                add(
                    "unknown-word",
                    s.span,
                    format!("{first} is in no AS keyword table: {hint}a controller refuses it unless an option of its own defines it"),
                );
            }
        }
        Lookup::Found(k)
            if !k.roles.contains(Role::INSTRUCTION) && k.roles.contains(Role::MONITOR) =>
        {
            add(
                "monitor-command-in-program",
                s.span,
                format!("{first} is a monitor command: in a PC program write MC {first}"),
            );
        }
        Lookup::Found(k) => {
            let newer_only = !k.generations.has(Generations::E);
            let older = matches!(
                generation,
                Some(Generation::C | Generation::D | Generation::E)
            );
            if newer_only && older {
                add(
                    "generation-keyword",
                    s.span,
                    format!(
                        "{first} is known only from {} controllers and tools: this generation may refuse it",
                        k.generations.letters()
                    ),
                );
            }
        }
        Lookup::Ambiguous(..) => {}
    }
}

/// The `undefined-program` rule: a program named by a statement that no file defines.
fn program_lint(s: &Stmt, defined: &[&str], add: &mut dyn FnMut(&'static str, Span, String)) {
    let named: Option<(&str, &str)> = match &s.kind {
        StmtKind::Call { program, .. } => Some(("CALL", program.as_str())),
        StmtKind::On {
            action: OnAction::Call(program),
            ..
        } => Some(("ON … CALL", program.as_str())),
        StmtKind::Monitor(MonitorCommand::Execute { program, .. }) => {
            Some(("EXECUTE", program.as_str()))
        }
        StmtKind::Monitor(MonitorCommand::PcExecute { program, .. }) => {
            Some(("PCEXECUTE", program.as_str()))
        }
        _ => None,
    };
    if let Some((what, program)) = named {
        if !defined.contains(&program) {
            add(
                "undefined-program",
                s.span,
                format!("{what} {program}: no file checked defines program {program}; a task that gets here stops with E0119 (check the file that holds it together with this one)"),
            );
        }
    }
}

/// The value of a constant expression (`5`, `-1`).
fn constant(e: &Expr) -> Option<f64> {
    match &e.kind {
        ExprKind::Num(v) => Some(*v),
        ExprKind::Unary(UnOp::Neg, inner) => constant(inner).map(|v| -v),
        _ => None,
    }
}

fn net_lint(
    s: &Stmt,
    generation: Option<Generation>,
    add: &mut dyn FnMut(&'static str, Span, String),
) {
    let t = match &s.kind {
        StmtKind::Tcp(t) => t,
        StmtKind::Udp(UdpStmt::SendTo { timeout, .. }) => {
            return net_ranges("UDP_SENDTO", None, timeout.as_ref(), generation, add)
        }
        StmtKind::Udp(UdpStmt::RecvFrom { port, timeout, .. }) => {
            return net_ranges(
                "UDP_RECVFROM",
                Some(port),
                timeout.as_ref(),
                generation,
                add,
            )
        }
        _ => return,
    };
    let (name, port, timeout) = match t {
        TcpStmt::Listen { port, .. } => ("TCP_LISTEN", Some(port), None),
        TcpStmt::EndListen { port, .. } => ("TCP_END_LISTEN", Some(port), None),
        TcpStmt::Accept { port, timeout, .. } => ("TCP_ACCEPT", Some(port), timeout.as_ref()),
        TcpStmt::Recv { timeout, max, .. } => {
            if timeout.is_none() || max.is_none() {
                add(
                    "d-tcp-recv-arguments",
                    s.span,
                    "give TCP_RECV both its timeout and its max-bytes argument (`…, .n, 5, 255`): \
                     the one known D-controller program does"
                        .into(),
                );
            }
            ("TCP_RECV", None, timeout.as_ref())
        }
        TcpStmt::Send { timeout, .. } => ("TCP_SEND", None, timeout.as_ref()),
        TcpStmt::Connect { timeout, .. } => ("TCP_CONNECT", None, timeout.as_ref()),
        TcpStmt::Close { .. } | TcpStmt::Status { .. } => return,
    };
    net_ranges(name, port, timeout, generation, add);
}

/// The port and timeout rules of a TCP or UDP instruction `name`.
fn net_ranges(
    name: &str,
    port: Option<&Expr>,
    timeout: Option<&Expr>,
    generation: Option<Generation>,
    add: &mut dyn FnMut(&'static str, Span, String),
) {
    if let Some(p) = port {
        if let Some(v) = constant(p) {
            if !(8192.0..=65535.0).contains(&v) {
                add(
                    "tcp-port-range",
                    p.span,
                    format!("{name} port {v}: the controller listens on ports 8192–65535 only"),
                );
            }
        }
    }
    if let Some(e) = timeout {
        if let Some(v) = constant(e) {
            let low = if generation == Some(Generation::E) {
                0.0
            } else {
                1.0
            };
            if !(low..=60.0).contains(&v) {
                add(
                    "tcp-timeout-range",
                    e.span,
                    format!("{name} timeout {v} s: the controller takes {low}–60 s"),
                );
            }
            if v.fract() != 0.0 {
                add(
                    "d-integer-timeout",
                    e.span,
                    format!("{name} timeout {v} s: a D controller takes whole seconds"),
                );
            }
        }
    }
}
