//! Statements: one program line after its label, into a [`LineKind`] — a statement, or a line
//! that opens, divides or closes a block.

use crate::ast::*;
use crate::error::ParseError;
use crate::keywords;
use crate::lexer::{Sigil, Tok};
use crate::span::Span;

use super::cursor::{describe, Cur, PResult, RobotNumber};

#[derive(Debug)]
pub(super) enum LineKind {
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
    pub(super) fn name(&self) -> &'static str {
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

/// Instructions whose own grammar has `n:` after the keyword (a device, a PC task number, a
/// CASE value).
const OWN_COLON: &[&str] = &[
    "print",
    "type",
    "pcexecute",
    "pcabort",
    "pcend",
    "execute",
    "mc",
    "value",
    "svalue",
    "any",
];

impl Cur<'_> {
    /// The statement after an optional label.
    pub(super) fn statement(&mut self) -> PResult<LineKind> {
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
                if let (Some(robot), Some(Tok::Colon), Some(Tok::Name(v))) =
                    (self.robot_number_at(1), self.peek_at(2), self.peek_at(3))
                {
                    if matches!(v.text.as_str(), "on" | "off") && self.toks.len() == self.pos + 4 {
                        if robot == RobotNumber::Other {
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

    pub(super) fn keyword_statement(&mut self, kw: &'static str, span: Span) -> PResult<LineKind> {
        let simple = |k: StmtKind| Ok(LineKind::Stmt(k));
        // `POINT .rno: …`, `DECOMPOSE 2: …`: the robot number first, as multi-robot
        // controllers write it. Robot 1 is this robot; another is not emulated.
        if let (false, Some(robot), Some(Tok::Colon)) = (
            OWN_COLON.contains(&kw),
            self.robot_number_at(0),
            self.peek_at(1),
        ) {
            if robot == RobotNumber::Other {
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
                // A CALL without a program name: kept as controllers save it, not emulated.
                if self.at_end() {
                    return Ok(self.not_emulated_rest("CALL without a program"));
                }
                let program = self.program_name("CALL")?;
                let args = self.call_args()?;
                LineKind::Stmt(StmtKind::Call { program, args })
            }
            "return" => LineKind::Stmt(StmtKind::Return),
            "returne" => LineKind::Stmt(StmtKind::ReturnAfterError),
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
            "weight" => {
                let mut values = Vec::new();
                if !self.at_end() {
                    values.push(self.expr()?);
                    while values.len() < 7 && self.eat(&Tok::Comma) {
                        values.push(self.expr()?);
                    }
                }
                LineKind::Stmt(StmtKind::Weight { values })
            }
            "sout" => {
                let signal = self.expr()?;
                self.expect(
                    &Tok::Assign,
                    "`=` and the signal expression after SOUT's signal",
                )?;
                let logic = self.expr()?;
                LineKind::Stmt(StmtKind::Sout { signal, logic })
            }
            "ifpwprint" | "ifpwoverwrite" => {
                let window = self.expr()?;
                // `[, row, column, background, label colour]`: each may be omitted.
                let mut place: [Option<Expr>; 4] = Default::default();
                for slot in place.iter_mut() {
                    if !self.eat(&Tok::Comma) {
                        break;
                    }
                    if self.peek() != Some(&Tok::Comma) && self.peek() != Some(&Tok::Assign) {
                        *slot = Some(self.expr()?);
                    }
                }
                self.expect(
                    &Tok::Assign,
                    &format!(
                        "`=` and the strings after {}'s window and place",
                        kw.to_uppercase()
                    ),
                )?;
                let mut texts = vec![self.expr()?];
                while self.eat(&Tok::Comma) {
                    texts.push(self.expr()?);
                }
                LineKind::Stmt(StmtKind::IfpWrite {
                    overwrite: kw == "ifpwoverwrite",
                    window,
                    place,
                    texts,
                })
            }
            "ifplabel" => {
                let position = self.expr()?;
                let mut labels = Vec::new();
                while labels.len() < 4 && self.eat(&Tok::Comma) {
                    if self.at_end() || self.peek() == Some(&Tok::Comma) {
                        labels.push(None);
                    } else {
                        labels.push(Some(self.expr()?));
                    }
                }
                LineKind::Stmt(StmtKind::IfpLabel { position, labels })
            }
            "ifptitle" => {
                let page = self.expr()?;
                self.expect(&Tok::Comma, "\",\" and the title after IFPTITLE's page")?;
                let title = self.expr()?;
                LineKind::Stmt(StmtKind::IfpTitle { page, title })
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
            "execute" | "pcexecute" | "pcabort" | "pcend" => LineKind::Stmt(self.monitor(kw)?),
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
            "utimer" => {
                let timer = self.lvalue()?;
                self.expect(
                    &Tok::Assign,
                    "\"=\" after the timer variable (UTIMER @timer = seconds)",
                )?;
                let value = self.expr()?;
                LineKind::Stmt(StmtKind::UTimer { timer, value })
            }
            "decompose" => {
                let target = self.lvalue()?;
                self.expect(&Tok::Assign, "\"=\" after the DECOMPOSE array")?;
                let source = self.expr()?;
                LineKind::Stmt(StmtKind::Decompose { target, source })
            }
            "here" => {
                // `HERE a+b+c`: c is defined relative to a+b.
                let mut target = self.lvalue()?;
                let mut relative_to = Vec::new();
                while self.peek() == Some(&Tok::Plus) {
                    self.pos += 1;
                    relative_to.push(std::mem::replace(&mut target, self.lvalue()?));
                }
                LineKind::Stmt(StmtKind::Here {
                    target,
                    relative_to,
                })
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
    pub(super) fn not_emulated_rest(&mut self, what: &str) -> LineKind {
        self.pos = self.toks.len();
        LineKind::Stmt(StmtKind::NotEmulated {
            instruction: what.to_owned(),
            stubbed: false,
        })
    }

    pub(super) fn on_off(&mut self, what: &str) -> PResult<bool> {
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

    pub(super) fn monitor(&mut self, cmd: &str) -> PResult<StmtKind> {
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
            "pcend" => {
                // `PCEND`, `PCEND 2`, `PCEND 2:`, `PCEND 2: -1`.
                let (task, mode) = match self.task_prefix()? {
                    Some(task) => {
                        let mode = if self.at_end() {
                            None
                        } else {
                            Some(self.expr()?)
                        };
                        (Some(task), mode)
                    }
                    None if self.at_end() => (None, None),
                    None => (Some(self.expr()?), None),
                };
                MonitorCommand::PcEnd { task, mode }
            }
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
            "zpower" => MonitorCommand::Zpower(self.on_off("ZPOWER")?),
            other => return Err(self.err(format!("MC {} is not supported", other.to_uppercase()))),
        }))
    }

    /// `n:` before a program name (PC task number).
    pub(super) fn task_prefix(&mut self) -> PResult<Option<Expr>> {
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

    pub(super) fn call_args(&mut self) -> PResult<Vec<CallArg>> {
        let mut args = Vec::new();
        if self.eat(&Tok::LParen) {
            if self.eat(&Tok::RParen) {
                return Ok(args);
            }
            loop {
                // `&a`, `.&a`: a transformation argument (the manual marks pose parameters
                // with `&`); the value is the same.
                self.eat(&Tok::Amp);
                args.push(match self.whole_array()? {
                    Some(value) => CallArg {
                        value,
                        whole_array: true,
                    },
                    None => CallArg {
                        value: self.expr()?,
                        whole_array: false,
                    },
                });
                if self.eat(&Tok::RParen) {
                    break;
                }
                self.expect(&Tok::Comma, "\",\" or \")\" in the argument list")?;
            }
        }
        Ok(args)
    }

    /// `name[]` or `name[,]` (a whole array, as saved programs pass one to a subroutine),
    /// up to the `,` or `)` after it: the variable without indices.
    fn whole_array(&mut self) -> PResult<Option<Expr>> {
        let (Some(Tok::Name(_)), Some(Tok::LBracket)) = (self.peek(), self.peek_at(1)) else {
            return Ok(None);
        };
        let commas = (2..)
            .take_while(|&k| self.peek_at(k) == Some(&Tok::Comma))
            .count();
        if self.peek_at(commas + 2) != Some(&Tok::RBracket)
            || !matches!(self.peek_at(commas + 3), Some(Tok::Comma | Tok::RParen))
        {
            return Ok(None);
        }
        let span = self.span();
        let Some(Tok::Name(name)) = self.peek().cloned() else {
            return Ok(None);
        };
        self.pos += commas + 3;
        Ok(Some(Expr {
            kind: ExprKind::Var(LValue {
                name,
                indices: Vec::new(),
                span,
            }),
            span,
        }))
    }

    pub(super) fn tcp(&mut self, kw: &str) -> PResult<TcpStmt> {
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

    pub(super) fn udp(&mut self, kw: &str) -> PResult<UdpStmt> {
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

    /// Items of PRINT/TYPE (`in_call`: inside `$ENCODE(…)`, ending at `)`).
    pub(super) fn print_items(&mut self, in_call: bool) -> PResult<Vec<PrintItem>> {
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
}
