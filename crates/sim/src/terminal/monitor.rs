//! The monitor commands on the emulated controller: the [`Monitor`] a terminal session runs
//! its command lines, questions and transfers on. Keywords are case-insensitive and may be
//! abbreviated as the AS keyword table says (the manual's abbreviations).

use fs020n_as::keywords::{self, Lookup, Role};
use fs020n_as::{ImmediateError, ListKind, TaskId};
use fs020n_term::server::split_word;
use fs020n_term::text::{self, MonitorError};
use fs020n_term::{LoadAnswer, Monitor, Reply, SyntaxError};

use crate::controller::{
    split_program, split_task, Abort, Controller, ImmediateRefusal, PoseValue,
};

/// What the answer to the session's question acts on.
#[derive(Debug, Clone, PartialEq)]
pub(crate) enum Pending {
    /// `KILL` (robot task) or `PCKILL n:`: what `1` confirms.
    Kill(TaskId),
    /// `DELETE/P name`: what `1` confirms.
    Delete(String),
    /// `HERE name`: the pose variable offered for editing after `Change?`, and its value.
    Edit { name: String, value: PoseValue },
    /// `WEIGHT`: the payload offered for editing after `Change?` (mass, centre of gravity,
    /// inertia).
    EditWeight([f32; 7]),
    /// `SYSINIT`: what `1` confirms.
    Initialize,
}

/// What one session keeps between its command lines.
#[derive(Debug)]
pub(crate) struct SessionState {
    /// The question this session asked (`Are you sure ?`) and what `1` does.
    pub(crate) pending: Option<Pending>,
    /// `MESSAGES ON` (the default): program output reaches this session.
    pub(crate) messages: bool,
    /// The statement of the last `DO` (a `DO` alone runs it again, AS-E p.5-45).
    pub(crate) last_do: Option<String>,
}

impl Default for SessionState {
    fn default() -> Self {
        SessionState {
            pending: None,
            messages: true,
            last_do: None,
        }
    }
}

/// The controller seen by one session.
pub(crate) struct ControllerMonitor<'a> {
    pub(crate) c: &'a mut Controller,
    pub(crate) state: &'a mut SessionState,
}

/// The headings of joint values (`WHERE`, `HERE #name`).
const JOINT_HEADINGS: [&str; 6] = ["JT1", "JT2", "JT3", "JT4", "JT5", "JT6"];

/// The headings of transformation values (`WHERE`, `HERE name`).
const TRANS_HEADINGS: [&str; 6] = ["X[mm]", "Y[mm]", "Z[mm]", "O[deg]", "A[deg]", "T[deg]"];

fn lines<I: IntoIterator<Item = S>, S: Into<String>>(l: I) -> Reply {
    Reply::Lines(l.into_iter().map(Into::into).collect())
}

fn done(r: Result<(), MonitorError>) -> Reply {
    match r {
        Ok(()) => Reply::Lines(Vec::new()),
        Err(e) => Reply::Error(e),
    }
}

/// `program[, cycles[, step]]` of `EXECUTE`/`PCEXECUTE`/`PRIME` ([`split_program`]), as the
/// monitor judges it: arguments in brackets dropped, the cycle count 1 when not given. A count
/// that is not a whole number is refused (the emulator does not evaluate expressions at the
/// monitor).
fn program_and_cycles(spec: &str) -> Result<(&str, i64), Reply> {
    let (name, cycles) = split_program(spec);
    let name = name.split('(').next().unwrap_or("").trim();
    if name.is_empty() {
        return Err(Reply::Error(text::P1038_NO_PROGRAM));
    }
    let cycles = match cycles {
        None => 1,
        Some(n) => match n.parse::<i64>() {
            Ok(n) => n,
            Err(_) => return Err(lines([text::EMULATOR_CYCLES_NOT_A_NUMBER])),
        },
    };
    Ok((name, cycles))
}

/// `[n:] rest` ([`split_task`]) as the monitor judges it: task 1 without a number, P0117 for
/// a number outside 1–5.
fn task_and_rest(rest: &str) -> Result<(u8, &str), MonitorError> {
    match split_task(rest) {
        (Some(n), tail) => match n.parse::<u8>() {
            Ok(n @ 1..=5) => Ok((n, tail)),
            _ => Err(text::P0117_INVALID_NAME),
        },
        (None, rest) => Ok((1, rest)),
    }
}

/// A real as `TYPE` prints it: one blank, then the `/D` digits (as the AS instruction).
fn format_real(v: f32) -> String {
    format!(" {}", fs020n_proto::format::format_default(f64::from(v)))
}

/// `(E0103) Location data is not defined: name` (the manual's text, the name after it as
/// `TYPE` names an undefined variable).
fn location_undefined(name: &str) -> Reply {
    let text = fs020n_proto::ErrorCode::LOCATION_NOT_DEFINED
        .message()
        .unwrap_or_default();
    lines([format!("(E0103) {text}: {name}")])
}

/// `values` with the fields of a line after `Change?` (comma-separated, an empty field keeping
/// its value: `,,,-15` changes the fourth); `None` when a field is not a number.
fn edited<const N: usize>(mut values: [f32; N], line: &str) -> Option<[f32; N]> {
    for (slot, field) in values.iter_mut().zip(line.split(',')) {
        let field = field.trim();
        if field.is_empty() {
            continue;
        }
        match field.parse::<f32>() {
            Ok(v) if v.is_finite() => *slot = v,
            _ => return None,
        }
    }
    Some(values)
}

/// The reply to a statement run at once: the lines it printed; P0108 for one that does not
/// parse; else its error line, as a program's error is printed.
fn statement_reply(result: Result<Vec<String>, ImmediateRefusal>) -> Reply {
    match result {
        Ok(printed) => Reply::Lines(printed),
        Err(ImmediateRefusal::Monitor(e)) => Reply::Error(e),
        Err(ImmediateRefusal::Statement(ImmediateError::Syntax(_))) => {
            Reply::Error(text::P0108_SYNTAX_ERROR)
        }
        Err(ImmediateRefusal::Statement(e)) => lines([e.to_string()]),
    }
}

/// `NAME(n)` or `NAME (n)` → n.
fn call_arg(expr: &str, name: &str) -> Option<i32> {
    let upper = expr.to_ascii_uppercase();
    let rest = upper.strip_prefix(name)?.trim_start();
    let inner = rest.strip_prefix('(')?.strip_suffix(')')?;
    inner.trim().parse::<f32>().ok().map(|v| v as i32)
}

impl ControllerMonitor<'_> {
    fn command(&mut self, keyword: &str, options: &str, rest: &str) -> Reply {
        match keyword {
            "DIRECTORY" => self.directory(),
            "LIST" => match options {
                "/R" => self.list_variables(ListKind::Reals, rest),
                "/INT" => self.list_variables(ListKind::Integers, rest),
                "/L" => self.list_variables(ListKind::Poses, rest),
                "/S" => self.list_variables(ListKind::Strings, rest),
                _ => self.list(rest),
            },
            // The instruction, with every expression a program may TYPE; the monitor's own
            // reading where no AS interpreter runs (the native server).
            "TYPE" => match self.c.program_mut().immediate(&format!("TYPE {rest}")) {
                Err(ImmediateRefusal::Monitor(_)) => self.type_expr(rest),
                result => statement_reply(result),
            },
            "DO" => self.do_statement(rest),
            "WEIGHT" if rest.trim().is_empty() => self.weight(),
            "POINT" if options.is_empty() && !rest.contains('=') => self.point(rest.trim()),
            "SYSINIT" => self.ask(Pending::Initialize),
            "ERRLOG" => self.error_log(),
            "KILL" => self.ask(Pending::Kill(TaskId::Robot)),
            "PCKILL" => match task_and_rest(rest) {
                Ok((n, _)) => self.ask(Pending::Kill(TaskId::Pc(n))),
                Err(e) => Reply::Error(e),
            },
            "DELETE" if options.contains('P') || !rest.is_empty() => {
                self.ask(Pending::Delete(rest.to_owned()))
            }
            "PCEXECUTE" => self.pc_execute(rest),
            "PCABORT" => match task_and_rest(rest) {
                // Stopped now: said now; after the current step: said when it stops.
                Ok((n, _)) => match self.c.program_mut().pc_abort(n) {
                    Abort::Stopped => lines([text::pc_aborted(n)]),
                    Abort::AfterStep | Abort::NotRunning => Reply::Lines(Vec::new()),
                },
                Err(e) => Reply::Error(e),
            },
            "PCSTATUS" => match task_and_rest(rest) {
                Ok((n, _)) => self.pc_status(n),
                Err(e) => Reply::Error(e),
            },
            "STATUS" => self.status(),
            "EXECUTE" => match program_and_cycles(rest) {
                Ok((name, cycles)) => done(self.c.program_mut().execute(name, cycles)),
                Err(reply) => reply,
            },
            "ABORT" => {
                self.c.program_mut().abort();
                Reply::Lines(Vec::new())
            }
            "HOLD" => {
                self.c.program_mut().hold(true);
                Reply::Lines(Vec::new())
            }
            "CONTINUE" => done(self.c.program_mut().resume()),
            "PRIME" => {
                let (name, cycles) = if rest.trim().is_empty() {
                    (None, 1)
                } else {
                    match program_and_cycles(rest) {
                        Ok((name, cycles)) => (Some(name), cycles),
                        Err(reply) => return reply,
                    }
                };
                done(self.c.program_mut().prime(name, cycles))
            }
            "MESSAGES" => match rest.to_ascii_uppercase().as_str() {
                "ON" => {
                    self.state.messages = true;
                    Reply::Lines(Vec::new())
                }
                "OFF" => {
                    self.state.messages = false;
                    Reply::Lines(Vec::new())
                }
                "" => lines([format!(
                    "MESSAGES {}",
                    if self.state.messages { "ON" } else { "OFF" }
                )]),
                _ => Reply::Error(text::P0117_INVALID_NAME),
            },
            "SIGNAL" => self.signal(rest),
            "WHERE" => self.where_(),
            "HERE" => self.here(rest),
            "SWITCH" => self.switch(rest),
            "ID" => self.id(),
            "ERESET" => self.ereset(),
            "ZPOWER" => {
                let on = rest.eq_ignore_ascii_case("ON");
                let _ = self.c.set_power(on);
                Reply::Lines(Vec::new())
            }
            // A monitor command that is also a program instruction (`POINT a = b`, `SOUT`,
            // `BITS`, `PRINT`, `IFPWPRINT`…): run as the instruction, at once. `SPEED 50` at
            // the prompt is the monitor speed: the instruction's `MC` form.
            _ => match keywords::get(&keyword.to_ascii_lowercase()) {
                Some(k) if k.roles.contains(Role::INSTRUCTION) => {
                    let prefix = if k.runs.contains(Role::AFTER_MC) {
                        "MC "
                    } else {
                        ""
                    };
                    self.statement(&format!("{prefix}{keyword}{options} {rest}"))
                }
                _ => Reply::Error(text::UNKNOWN_COMMAND),
            },
        }
    }

    /// `DO statement` (AS-E p.5-45): one program instruction run at once; `DO` alone runs
    /// the last one again. A motion is refused (E1095, as in a PC program): the emulator
    /// moves the arm only from programs.
    fn do_statement(&mut self, rest: &str) -> Reply {
        let statement = if rest.trim().is_empty() {
            match self.state.last_do.clone() {
                Some(s) => s,
                None => return Reply::Lines(Vec::new()),
            }
        } else {
            rest.trim().to_owned()
        };
        self.state.last_do = Some(statement.clone());
        self.statement(&statement)
    }

    /// A statement run at once against the programs in memory: the lines it printed, or
    /// its error as a program's error line.
    fn statement(&mut self, statement: &str) -> Reply {
        statement_reply(self.c.program_mut().immediate(statement))
    }

    /// `SIGNAL n, -m, …`: outputs (1…) and internal signals (2001…) on (`n`) or off (`-n`);
    /// external inputs (1001…) cannot be set from the terminal.
    fn signal(&mut self, rest: &str) -> Reply {
        let mut numbers = Vec::new();
        for part in rest.split(',').map(str::trim).filter(|p| !p.is_empty()) {
            // `SIGNAL (-2010)`, `signal(5)`: a number in brackets.
            let part = part.trim_start_matches('(').trim_end_matches(')').trim();
            match part.parse::<i32>() {
                Ok(n) if n != 0 && !(1001..=1999).contains(&n.abs()) => numbers.push(n),
                _ => return Reply::Error(text::P0117_INVALID_NAME),
            }
        }
        if numbers.is_empty() {
            return Reply::Error(text::P0117_INVALID_NAME);
        }
        for n in numbers {
            self.c.program_mut().set_input(n.abs(), n > 0);
        }
        Reply::Lines(Vec::new())
    }

    /// `WHERE`: the joints, then the tool's XYZOAT, each under its heading (**L**: the layout
    /// is the emulator's reading of the manual's description, not a capture).
    fn where_(&self) -> Reply {
        let j = self.c.joints().0;
        let x = self
            .c
            .model()
            .forward(&self.c.joints().to_rad())
            .to_xyzoat();
        let row = |v: &[f64]| v.iter().map(|v| format!("{v:>10.3}")).collect::<String>();
        let heading = |h: &[&str]| h.iter().map(|h| format!("{h:>10}")).collect::<String>();
        lines([
            heading(&JOINT_HEADINGS),
            row(&j),
            heading(&TRANS_HEADINGS),
            row(&[x.x_mm, x.y_mm, x.z_mm, x.o_deg, x.a_deg, x.t_deg]),
        ])
    }

    /// `HERE name` (`#name`: joint values): the current pose is stored in the variable at
    /// once and offered for editing (AS-E p.5-47): the values under their headings, then
    /// `Change?`. A transformation is the tool in the world, with the BASE and TOOL the
    /// programs set (a bare controller: the flange in the robot's base frame).
    fn here(&mut self, rest: &str) -> Reply {
        // `HERE a+b`: b is defined so that a+b is the current pose; a must exist (p.6-108).
        let mut parts: Vec<&str> = rest.split('+').map(str::trim).collect();
        let name = parts.pop().unwrap_or_default();
        let joints = self.c.joints().0;
        let value = if name.starts_with('#') && parts.is_empty() {
            PoseValue::Joints(joints.map(|v| v as f32))
        } else if name.starts_with('#') || parts.iter().any(|p| p.starts_with('#')) {
            return Reply::Error(text::P0117_INVALID_NAME);
        } else {
            let flange = fs020n_as::flange::forward(self.c.model(), &joints);
            PoseValue::Trans(match self.c.interpreter() {
                Some(i) => match i.here_relative(&parts, &flange) {
                    Ok(t) => t,
                    Err(undefined) => return location_undefined(&undefined),
                },
                None if parts.is_empty() => flange.map(|v| v as f32),
                None => return location_undefined(parts[0]),
            })
        };
        self.define(name.to_owned(), value)
    }

    /// Stores `value` in `name` and offers it for editing again.
    fn define(&mut self, name: String, value: PoseValue) -> Reply {
        if let Err(e) = self.c.memory_mut().define_pose(&name, value) {
            self.state.pending = None;
            return Reply::Error(e);
        }
        let headings = match value {
            PoseValue::Joints(_) => JOINT_HEADINGS,
            PoseValue::Trans(_) => TRANS_HEADINGS,
        };
        let values = value.values();
        self.state.pending = Some(Pending::Edit { name, value });
        Reply::Change(vec![
            headings.iter().map(|h| format!("{h:>10}")).collect(),
            values.iter().map(|v| format!("{v:>10.3}")).collect(),
        ])
    }

    /// `POINT name` without `=` (AS-E p.5-48): the variable's value (zeros when it has none,
    /// which it then takes) offered for editing after `Change?`, as `HERE` offers it.
    fn point(&mut self, name: &str) -> Reply {
        let interp = self.c.interpreter();
        let value = match name.strip_prefix('#') {
            Some(joints) => {
                PoseValue::Joints(interp.and_then(|i| i.joints(joints)).unwrap_or([0.0; 6]))
            }
            None => PoseValue::Trans(interp.and_then(|i| i.trans(name)).unwrap_or([0.0; 6])),
        };
        self.define(name.to_owned(), value)
    }

    /// `ERRLOG` (AS-E p.5-69): the errors raised, oldest first, numbered, each as
    /// `n-[time]` and the code with its message on the next line. The manual's lines carry
    /// the date and time of the controller's clock; the emulator has no wall clock, so the
    /// time is the controller's since it started, `h:mm:ss.mmm` (**M**).
    fn error_log(&self) -> Reply {
        let log = self.c.error_log();
        if log.is_empty() {
            return lines(["No error."]);
        }
        let mut out = Vec::with_capacity(log.len() * 2);
        for (n, (at, code)) in log.iter().enumerate() {
            let ms = at.as_millis();
            out.push(format!(
                "{}-[{}:{:02}:{:02}.{:03}]",
                n + 1,
                ms / 3_600_000,
                ms / 60_000 % 60,
                ms / 1000 % 60,
                ms % 1000
            ));
            out.push(format!("  ({code}){}", code.message().unwrap_or("")));
        }
        Reply::Lines(out)
    }

    /// `WEIGHT` without values (AS-E p.5-85): the payload under its headings, then `Change?`
    /// (the layout is the emulator's, as `HERE`'s: **M**); a line of values changes it. A
    /// controller no program has run on yet carries the rated payload.
    fn weight(&mut self) -> Reply {
        let p = self
            .c
            .interpreter()
            .map(fs020n_as::Interpreter::payload)
            .unwrap_or_default();
        let values = [
            p.mass_kg,
            p.cog_mm[0],
            p.cog_mm[1],
            p.cog_mm[2],
            p.inertia_kg_m2[0],
            p.inertia_kg_m2[1],
            p.inertia_kg_m2[2],
        ];
        self.state.pending = Some(Pending::EditWeight(values));
        let headings = [
            "Mass[kg]", "X[mm]", "Y[mm]", "Z[mm]", "Ix[kgm2]", "Iy[kgm2]", "Iz[kgm2]",
        ];
        Reply::Change(vec![
            headings.iter().map(|h| format!("{h:>10}")).collect(),
            values.iter().map(|v| format!("{v:>10.3}")).collect(),
        ])
    }

    fn ask(&mut self, p: Pending) -> Reply {
        self.state.pending = Some(p);
        Reply::AreYouSure
    }

    /// `DIRECTORY/P`: the names, a running program's with a `*` after it (AS-E p.10-3).
    fn directory(&self) -> Reply {
        let running: Vec<String> = std::iter::once(TaskId::Robot)
            .chain((1..=5).map(TaskId::Pc))
            .filter(|t| self.c.program().task_running(*t))
            .filter_map(|t| self.c.program().task_program(t))
            .collect();
        let names: Vec<String> = self
            .c
            .memory()
            .programs()
            .into_iter()
            .map(|n| {
                if running.contains(&n) {
                    format!("{n}*")
                } else {
                    n
                }
            })
            .collect();
        lines([text::DIRECTORY_HEADER.to_owned(), names.join(" ")])
    }

    /// `LIST/R`, `/INT`, `/L`, `/S [name, …]` (AS-E p.5-18): the variables and the values
    /// the programs hold now, as data-section lines (the manual does not print the form:
    /// the emulator's choice, the saves' form).
    fn list_variables(&self, kind: ListKind, rest: &str) -> Reply {
        let names: Vec<&str> = rest
            .split(',')
            .map(str::trim)
            .filter(|n| !n.is_empty())
            .collect();
        match self.c.interpreter() {
            Some(i) => Reply::Lines(i.list_lines(kind, &names)),
            None => Reply::Lines(Vec::new()),
        }
    }

    fn list(&self, rest: &str) -> Reply {
        let names: Vec<String> = if rest.is_empty() {
            self.c.memory().programs()
        } else {
            rest.split(',').map(|n| n.trim().to_owned()).collect()
        };
        let mut out = Vec::new();
        for n in names {
            match self.c.memory().program(&n) {
                Some(t) => out.extend(String::from_utf8_lossy(t).lines().map(str::to_owned)),
                None => return Reply::Error(text::P1038_NO_PROGRAM),
            }
        }
        Reply::Lines(out)
    }

    /// `TYPE` where no AS interpreter runs (the native server): the simple forms the monitor
    /// reads itself (`TASK(n)`, `TIMER(n)`, `SIG(n)`, a number, a variable).
    fn type_expr(&self, expr: &str) -> Reply {
        let expr = expr.trim();
        let interp = self.c.interpreter();
        if let Some(n) = call_arg(expr, "TASK") {
            let state = self
                .c
                .program()
                .tasks()
                .and_then(|tasks| {
                    let i = match n {
                        1 => 0,
                        1001..=1005 => (n - 1000) as usize,
                        _ => return None,
                    };
                    tasks.get(i).map(|t| t.state.number())
                })
                .unwrap_or(0.0);
            return lines([format_real(state)]);
        }
        if let Some(n) = call_arg(expr, "TIMER") {
            let v = interp.map_or(0.0, |i| i.timer(n.max(0) as usize));
            return lines([format_real(v)]);
        }
        if let Some(n) = call_arg(expr, "SIG") {
            let on = self.c.program().signal(n.abs()).unwrap_or(false) == (n > 0);
            return lines([format_real(if on { -1.0 } else { 0.0 })]);
        }
        if let Ok(v) = expr.parse::<f32>() {
            return lines([format_real(v)]);
        }
        let undefined = || lines([format!("(E0102) Variable not defined: {expr}")]);
        let Some(interp) = interp else {
            return undefined();
        };
        if let Some(name) = expr.strip_prefix('$') {
            return match interp.string(name) {
                Some(b) => lines([String::from_utf8_lossy(&b).into_owned()]),
                None => lines([format!("(E0104) String variable not defined: {expr}")]),
            };
        }
        let (name, idx) = match expr.split_once('[') {
            Some((n, i)) => {
                let idx: Option<Vec<i32>> = i
                    .trim_end_matches(']')
                    .split(',')
                    .map(|x| x.trim().parse::<i32>().ok())
                    .collect();
                match idx {
                    Some(idx) => (n.trim(), idx),
                    None => return undefined(),
                }
            }
            None => (expr, Vec::new()),
        };
        match interp.real_at(name, &idx) {
            Some(v) => lines([format_real(v)]),
            None => undefined(),
        }
    }

    fn pc_execute(&mut self, rest: &str) -> Reply {
        let (task, tail) = match task_and_rest(rest) {
            Ok(t) => t,
            Err(e) => return Reply::Error(e),
        };
        match program_and_cycles(tail) {
            Ok((name, cycles)) => {
                let started = self.c.program_mut().pc_execute(task, name, cycles);
                if started.is_ok() {
                    // The program has run its first steps (a TCP_LISTEN, say) by the time the
                    // prompt comes back.
                    self.c.program_mut().run_first_steps(TaskId::Pc(task));
                }
                done(started)
            }
            Err(reply) => reply,
        }
    }

    /// The program line of `STATUS`/`PCSTATUS`: its name, priority 0 and step.
    fn program_table(&self, task: TaskId) -> Vec<String> {
        let Some(name) = self.c.program().task_program(task) else {
            return vec![text::NO_PROGRAM_RUNNING.to_owned()];
        };
        let i = match task {
            TaskId::Robot => 0,
            TaskId::Pc(n) => usize::from(n),
        };
        let line = self
            .c
            .program()
            .tasks()
            .and_then(|t| t.get(i).and_then(|t| t.line))
            .unwrap_or(0);
        // The task's line is in the memory's whole text: the step counts from the program's
        // `.PROGRAM` line.
        let mut start = 1u32;
        for p in self.c.stored_programs() {
            if p.name == name {
                break;
            }
            start += p.text.iter().filter(|&&b| b == b'\n').count() as u32;
        }
        let step = line.saturating_sub(start);
        vec![
            text::PROGRAM_TABLE_HEADER.to_owned(),
            format!("{name:<14} {:>8} {step:>10}", 0),
        ]
    }

    fn pc_status(&self, n: u8) -> Reply {
        let running = self.c.program().task_running(TaskId::Pc(n));
        let mut out = vec![text::pc_status_line(running).to_owned()];
        let (completed, remaining) = self.c.program().task_cycles(TaskId::Pc(n));
        out.extend(text::cycle_lines(completed, remaining));
        out.extend(self.program_table(TaskId::Pc(n)));
        Reply::Lines(out)
    }

    fn status(&self) -> Reply {
        let panel = self.c.panel();
        let running = self.c.program().task_running(TaskId::Robot);
        let mut out = vec!["Robot status:".to_owned()];
        out.push(
            if panel.power {
                "  Motor power ON"
            } else {
                "  Motor power OFF"
            }
            .to_owned(),
        );
        out.push(
            if panel.repeat {
                "  REPEAT mode"
            } else {
                "  TEACH mode"
            }
            .to_owned(),
        );
        if running {
            out.push("  CYCLE START ON".to_owned());
        }
        if !self.c.error().is_none() {
            out.push("  During error condition".to_owned());
        }
        if !self.c.arm().is_still() {
            out.push("  Now moving program".to_owned());
        }
        out.push("Environment:".to_owned());
        out.push(format!(
            "  Monitor speed(%) = {:.1}",
            self.c.monitor_speed()
        ));
        out.push(format!(
            "Stepper status: {}",
            if running {
                "Program is running."
            } else {
                "Program is not running."
            }
        ));
        let (completed, remaining) = self.c.program().task_cycles(TaskId::Robot);
        out.extend(text::cycle_lines(completed, remaining));
        out.extend(self.program_table(TaskId::Robot));
        Reply::Lines(out)
    }

    fn switch(&mut self, rest: &str) -> Reply {
        let rest = rest.trim();
        if rest.is_empty() {
            let all = self.c.memory().switches();
            let out = all
                .chunks(2)
                .map(|pair| {
                    pair.iter()
                        .map(|(n, v)| format!("{n:<16}{:<6}", if *v { "ON" } else { "OFF" }))
                        .collect::<String>()
                        .trim_end()
                        .to_owned()
                })
                .collect::<Vec<_>>();
            return Reply::Lines(out);
        }
        // `name`, `name = ON|OFF` (the manual's form) or `name ON|OFF` (accepted too).
        let spaced = rest.replace('=', " = ");
        let words: Vec<&str> = spaced.split_whitespace().filter(|w| *w != "=").collect();
        let name = words.first().copied().unwrap_or("");
        let state = match words.get(1).map(|w| w.to_ascii_uppercase()) {
            None => None,
            Some(w) if w == "ON" => Some(true),
            Some(w) if w == "OFF" => Some(false),
            Some(_) => return Reply::Error(text::P0117_INVALID_NAME),
        };
        match state {
            Some(on) => {
                if self.c.memory_mut().set_switch(name, on) {
                    Reply::Lines(Vec::new())
                } else {
                    Reply::Error(text::P0117_INVALID_NAME)
                }
            }
            None => match self.c.memory().switch(name) {
                Some(v) => lines([format!(
                    "{:<16}{}",
                    name.to_ascii_uppercase(),
                    if v { "ON" } else { "OFF" }
                )]),
                None => Reply::Error(text::P0117_INVALID_NAME),
            },
        }
    }

    fn id(&self) -> Reply {
        let axes = self.c.joints().0.len();
        lines([
            format!(
                "Robot name: {} (emulator)   Num of axes: {axes}   Serial No. EMULATOR",
                text::EMULATOR_ROBOT_NAME
            ),
            "[Software version]".to_owned(),
            format!(
                "AS: {} {}",
                text::EMULATOR_AS_VERSION,
                env!("CARGO_PKG_VERSION")
            ),
        ])
    }

    fn ereset(&mut self) -> Reply {
        if self.c.error().is_none() {
            return Reply::Lines(Vec::new());
        }
        match self.c.reset_error() {
            Ok(()) => lines([text::CLEARED_ERROR]),
            Err(_) => lines([text::EMULATOR_ESTOP_PRESSED]),
        }
    }

    /// The file a `SAVE` spec asks for: `[/P] file[=prog,…]`; CR LF line ends.
    fn save_file(&self, spec: &str) -> Result<Vec<u8>, MonitorError> {
        let mut programs_only = false;
        let mut target = "";
        for w in spec.split_whitespace() {
            if let Some(opts) = w.strip_prefix('/') {
                programs_only |= opts.split('/').any(|o| o.eq_ignore_ascii_case("P"));
            } else {
                target = w;
            }
        }
        let names: Vec<String> = match target.split_once('=') {
            Some((_, list)) => list.split(',').map(|n| n.trim().to_owned()).collect(),
            None => self.c.memory().programs(),
        };
        let mut bytes = Vec::new();
        for n in &names {
            bytes.extend(self.c.memory().program(n).ok_or(text::P1038_NO_PROGRAM)?);
        }
        if !programs_only {
            for d in self.c.memory().data_sections() {
                bytes.extend(d);
            }
        }
        // The memory holds LF line ends; the file gets CR LF, as the controller saves.
        let mut file = Vec::with_capacity(bytes.len() + bytes.len() / 16);
        for b in bytes {
            if b == b'\n' {
                file.push(b'\r');
            }
            file.push(b);
        }
        Ok(file)
    }
}

impl Monitor for ControllerMonitor<'_> {
    fn open_session(&mut self) -> Option<String> {
        self.c.open_terminal()
    }

    fn close_session(&mut self, terminal: &str) {
        self.state.pending = None;
        self.c.close_terminal(terminal);
    }

    fn run(&mut self, line: &str) -> Reply {
        self.state.pending = None;
        let (word, rest) = split_word(line);
        // `signal(-2010)`: a bracket ends the command word; the argument starts with it.
        let (word, rest) = match word.find('(') {
            Some(i) if i > 0 => (&word[..i], line.trim()[i..].trim()),
            _ => (word, rest),
        };
        let (word, options) = match word.find('/') {
            Some(i) => (&word[..i], word[i..].to_ascii_uppercase()),
            None => (word, String::new()),
        };
        // `list /r x`: the switch after a blank, as telnet tools type it.
        let (options, rest) = match rest.trim_start().strip_prefix('/') {
            Some(tail) if options.is_empty() => {
                let (switch, rest) = split_word(tail);
                (format!("/{}", switch.to_ascii_uppercase()), rest)
            }
            _ => (options, rest),
        };
        // The word against the AS keyword table, with the manual's abbreviations (`PCEX`,
        // `DI`, `STA`); a word short for two commands is P0110.
        let lower = word.to_ascii_lowercase();
        // A monitor command, or a switch set at the prompt (`MESSAGES OFF`).
        let found = match keywords::lookup(&lower, Role::MONITOR) {
            Lookup::Unknown => keywords::lookup(&lower, Role::SWITCH),
            found => found,
        };
        let keyword = match found {
            Lookup::Found(k) => k.name.to_ascii_uppercase(),
            Lookup::Ambiguous(..) => return Reply::Error(text::P0110_FULL_SPELLING),
            Lookup::Unknown => return Reply::Error(text::UNKNOWN_COMMAND),
        };
        // `command` plays what the emulator plays and answers any other command unknown.
        self.command(&keyword, &options, rest)
    }

    fn confirmed(&mut self) -> Reply {
        match self.state.pending.take() {
            Some(Pending::Kill(task)) => done(self.c.program_mut().kill(task)),
            Some(Pending::Delete(name)) => done(self.c.memory_mut().delete(&name)),
            Some(Pending::Initialize) => done(self.c.memory_mut().initialize()),
            Some(Pending::Edit { .. } | Pending::EditWeight(_)) | None => Reply::Lines(Vec::new()),
        }
    }

    /// A line after `Change?`: new values separated by commas, an empty field keeping its
    /// value (`,,,-15` changes the fourth); an empty line ends the editing. A field that is
    /// not a number changes nothing and the values are offered again.
    fn change(&mut self, line: &str) -> Reply {
        let pending = self.state.pending.take();
        if line.trim().is_empty() {
            return Reply::Lines(Vec::new());
        }
        match pending {
            Some(Pending::Edit { name, value }) => match edited(value.values(), line) {
                Some(values) => self.define(name, value.with_values(values)),
                None => self.define(name, value),
            },
            Some(Pending::EditWeight(values)) => match edited(values, line) {
                Some(values) => {
                    let list: Vec<String> = values.iter().map(f32::to_string).collect();
                    match self
                        .c
                        .program_mut()
                        .immediate(&format!("WEIGHT {}", list.join(", ")))
                    {
                        Ok(_) => self.weight(),
                        Err(e) => statement_reply(Err(e)),
                    }
                }
                None => self.weight(),
            },
            _ => Reply::Lines(Vec::new()),
        }
    }

    fn transfer_blocked(&self) -> bool {
        self.c.memory().transfer_open()
    }

    fn transfer_abandoned(&mut self) {
        self.c.abandon_transfer();
    }

    fn check_load(&mut self, file: &[u8]) -> Vec<SyntaxError> {
        self.c
            .memory()
            .check(file)
            .into_iter()
            .map(|(_, line)| SyntaxError { line })
            .collect()
    }

    fn finish_load(&mut self, file: &[u8], answer: LoadAnswer) -> (Vec<String>, usize) {
        if answer == LoadAnswer::Abort {
            return (Vec::new(), 0);
        }
        let report = self.c.memory_mut().load(file, true);
        let mut out: Vec<String> = report
            .loaded
            .iter()
            .map(|(n, p)| text::program_loaded(n, p))
            .collect();
        for (name, e) in &report.refused {
            out.push(format!("{name}: {}", e.line()));
        }
        out.extend(report.notes.iter().cloned());
        (out, report.errors)
    }

    fn save(&mut self, spec: &str) -> Result<Vec<u8>, MonitorError> {
        self.save_file(spec)
    }
}
