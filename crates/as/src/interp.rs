//! The interpreter: tasks, scheduler, statements and expressions on a clock it is given.
//!
//! See the crate documentation for the model (tasks, cost model, look-ahead) and docs/AS.md
//! for every choice made where the AS manuals are silent.

use std::collections::{HashMap, VecDeque};
use std::sync::Arc;
use std::time::Duration;

use fs020n_kin::{Pose, Xyzoat};
use fs020n_proto::format as fmt;
use fs020n_proto::number::as_val;
use fs020n_proto::ErrorCode;
use serde::Serialize;

use crate::ast::{BinOp, DataValue, FormatCode, Module, SpeedUnit};
use crate::compile::{
    compile, var_display, CArg, CExpr, CProgram, Code, Item, JExpr, LRef, Loc, Op, RExpr, RFunc,
    SExpr, SwitchRef, TExpr, Ty, VarRef,
};
use crate::error::{error_message, LoadError, ParseError, RuntimeError};
use crate::keywords::SYSTEM_SWITCHES;
use crate::system::{
    Issued, MotionKind, MotionRequest, PanelState, SockPoll, Speed, System, Target, TaskId,
};
use crate::value::{Bytes, Store, Var, MAX_ELEMENTS, MAX_INDEX};

/// How long statements take (see docs/AS.md, "Cost model").
///
/// Every executed step costs [`CostModel::statement`]; `PRINT`/`TYPE` add
/// [`CostModel::print`] plus [`CostModel::print_per_byte`] for each byte printed (the terminal
/// line is the slowest thing an AS loop usually does: 100 µs per byte is a serial console at
/// about 115 200 baud). With these defaults the protocol-1040 server's motion loop has the
/// 4 ms loop overhead the native emulator assumes, and a request takes its communication task
/// about 1–3 ms. Tasks run concurrently, each on its own
/// timeline: a busy loop advances its own task's time, never freezes the clock, and does not
/// slow the other tasks.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
pub struct CostModel {
    /// One program step (at least 1 µs).
    pub statement: Duration,
    /// Extra time of a PRINT/TYPE.
    pub print: Duration,
    /// Extra time per byte printed.
    pub print_per_byte: Duration,
}

impl Default for CostModel {
    fn default() -> Self {
        CostModel {
            statement: Duration::from_micros(20),
            print: Duration::from_millis(1),
            print_per_byte: Duration::from_micros(100),
        }
    }
}

/// Interpreter settings.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Config {
    /// Statement costs.
    pub cost: CostModel,
    /// How often waiting conditions (`WAIT`, a planned motion, `BREAK`, HOLD) are checked; the
    /// controller's cycle. Default 2 ms.
    pub poll_period: Duration,
    /// How long a signal must stay in its new state before `ON`/`ONI` fires (50 ms on the
    /// controller).
    pub signal_debounce: Duration,
    /// Deepest `CALL` nesting before E0109.
    pub max_call_depth: usize,
    /// Terminal lines kept for [`Interpreter::terminal`].
    pub terminal_lines: usize,
    /// `false` (default): a program's dot-locals are created for each execution and each
    /// `CALL` and start undefined. `true`: they belong to the program in its task and keep
    /// their values across calls and new executions (the controller's behaviour is not
    /// documented; see docs/AS.md).
    pub persistent_locals: bool,
}

impl Default for Config {
    fn default() -> Self {
        Config {
            cost: CostModel::default(),
            poll_period: Duration::from_millis(2),
            signal_debounce: Duration::from_millis(50),
            max_call_depth: 32,
            terminal_lines: 1000,
            persistent_locals: false,
        }
    }
}

/// What `TASK(n)` returns.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum TaskState {
    /// 0: not executing.
    Idle,
    /// 1: running.
    Running,
    /// 2: paused (HOLD, `MC HOLD`, `PAUSE`).
    Paused,
    /// 3: every step done, waiting for the robot's motion to finish.
    WaitingMotion,
}

impl TaskState {
    /// The number `TASK(n)` returns.
    pub fn number(self) -> f32 {
        match self {
            TaskState::Idle => 0.0,
            TaskState::Running => 1.0,
            TaskState::Paused => 2.0,
            TaskState::WaitingMotion => 3.0,
        }
    }
}

/// A task as the pendant shows it.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct TaskInfo {
    /// `robot` or `pc1` … `pc5`.
    pub task: String,
    /// What `TASK(n)` returns.
    pub state: TaskState,
    /// The program (the innermost one when a CALL is in progress).
    pub program: Option<String>,
    /// The source line about to execute (or waiting).
    pub line: Option<u32>,
    /// Its text.
    pub text: Option<String>,
    /// What the task waits for, if anything.
    pub waiting: Option<String>,
    /// The error that last stopped it.
    pub last_error: Option<String>,
    /// Steps executed since start.
    pub steps: u64,
}

/// A terminal line (`PRINT`/`TYPE`, or a controller message).
#[derive(Debug, Clone, PartialEq, Eq, Serialize)]
pub struct TerminalLine {
    /// When, since the interpreter started.
    #[serde(serialize_with = "ser_secs")]
    pub at: Duration,
    /// Which task printed it.
    pub task: TaskId,
    /// The text.
    pub text: String,
}

/// One executed step (see [`Interpreter::set_trace`]).
#[derive(Debug, Clone, PartialEq, Eq, Serialize)]
pub struct TraceLine {
    /// When it executed.
    #[serde(serialize_with = "ser_secs")]
    pub at: Duration,
    /// The task.
    pub task: TaskId,
    /// The program.
    pub program: String,
    /// The source line.
    pub line: u32,
    /// Its text.
    pub text: String,
}

impl std::fmt::Display for TraceLine {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "{:>10.4} {:<5} {}:{} {}",
            self.at.as_secs_f64(),
            self.task.to_string(),
            self.program,
            self.line,
            self.text.trim()
        )
    }
}

fn ser_secs<S: serde::Serializer>(d: &Duration, s: S) -> Result<S::Ok, S::Error> {
    s.serialize_f64(d.as_secs_f64())
}

/// Why a monitor command (`EXECUTE`, `PCEXECUTE`, …) was refused.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum Refusal {
    /// The controller refuses with a P code (P1000 power off, P1001 TEACH, P1002 teach lock,
    /// P1013 in error, P1009 already running).
    #[error("({code}) {message}")]
    Controller {
        /// The code.
        code: ErrorCode,
        /// Its message.
        message: String,
    },
    /// No program of that name is loaded.
    #[error("program {0} is not loaded")]
    NoProgram(String),
    /// Another refusal (wrong task number, …).
    #[error("{0}")]
    Other(String),
}

fn p_code(code: i32, message: &str) -> Refusal {
    Refusal::Controller {
        code: ErrorCode(code),
        message: message.to_owned(),
    }
}

// ---------------------------------------------------------------------------- task internals

#[derive(Debug, Clone)]
struct ByRef {
    ty: Ty,
    param: u32,
    var: VarRef,
    idx: Vec<i32>,
    /// The caller's frame (index in the task's stack) for a local variable.
    frame: usize,
}

#[derive(Debug, Clone)]
struct Frame {
    prog: usize,
    pc: usize,
    locals: Store,
    byref: Vec<ByRef>,
}

#[derive(Debug, Clone)]
enum Wait {
    Until(Ns),
    Cond,
    MotionPlanned,
    MotionDone,
    Held,
    Paused,
    Accept {
        port: u16,
        deadline: Ns,
    },
    Connect {
        ip: [u8; 4],
        port: u16,
        deadline: Ns,
    },
    Recv {
        sock: i32,
        max: usize,
        deadline: Ns,
    },
    Send {
        sock: i32,
        data: Vec<u8>,
        deadline: Ns,
    },
}

impl Wait {
    fn polled(&self) -> bool {
        matches!(
            self,
            Wait::Cond | Wait::MotionPlanned | Wait::MotionDone | Wait::Held
        )
    }

    fn socket(&self) -> bool {
        matches!(
            self,
            Wait::Accept { .. } | Wait::Connect { .. } | Wait::Recv { .. } | Wait::Send { .. }
        )
    }

    fn describe(&self) -> String {
        match self {
            Wait::Until(_) => "TWAIT".into(),
            Wait::Cond => "WAIT condition".into(),
            Wait::MotionPlanned => {
                "motion: waiting for the current motion to come within ACCURACY".into()
            }
            Wait::MotionDone => "BREAK: waiting for the motion to finish".into(),
            Wait::Held => "HOLD".into(),
            Wait::Paused => "PAUSE (MC CONTINUE resumes)".into(),
            Wait::Accept { port, .. } => format!("TCP_ACCEPT on port {port}"),
            Wait::Connect { port, .. } => format!("TCP_CONNECT to port {port}"),
            Wait::Recv { sock, .. } => format!("TCP_RECV on socket {sock}"),
            Wait::Send { sock, .. } => format!("TCP_SEND on socket {sock}"),
        }
    }
}

#[derive(Debug, Clone, Copy)]
struct Interrupt {
    signal: i32,
    immediate: bool,
    goto: Option<usize>,
    call: Option<usize>,
    depth: usize,
    armed_at: Ns,
}

#[derive(Debug, Clone, Copy)]
struct MotionParams {
    speed: Speed,
    speed_once: Option<Speed>,
    accuracy: (f64, bool),
    accuracy_once: Option<(f64, bool)>,
    accel: f64,
    accel_once: Option<f64>,
    decel: f64,
    decel_once: Option<f64>,
}

impl Default for MotionParams {
    fn default() -> Self {
        MotionParams {
            speed: Speed::Percent(100.0),
            speed_once: None,
            accuracy: (1.0, false),
            accuracy_once: None,
            accel: 100.0,
            accel_once: None,
            decel: 100.0,
            decel_once: None,
        }
    }
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Run {
    Idle,
    Running,
    /// Robot task: the program ended, the motion is finishing (TASK = 3).
    Ending,
}

#[derive(Debug, Clone)]
struct Task {
    id: TaskId,
    run: Run,
    frames: Vec<Frame>,
    ready_at: Ns,
    wait: Option<Wait>,
    /// Re-check a socket wait now (another task used a socket).
    kick: bool,
    /// Next poll of a polled wait (a grid point of the poll period).
    poll_at: Ns,
    cycles_left: i64,
    motion: MotionParams,
    interrupts: Vec<Interrupt>,
    pending_on: Option<Interrupt>,
    last_error: Option<String>,
    steps: u64,
    line_buf: String,
}

impl Task {
    fn new(id: TaskId) -> Task {
        Task {
            id,
            run: Run::Idle,
            frames: Vec::new(),
            ready_at: 0,
            wait: None,
            kick: false,
            poll_at: 0,
            cycles_left: 0,
            motion: MotionParams::default(),
            interrupts: Vec::new(),
            pending_on: None,
            last_error: None,
            steps: 0,
            line_buf: String::new(),
        }
    }
}

#[derive(Debug, Clone, Copy)]
struct SignalState {
    on: bool,
    changed: Ns,
}

/// Flow after one step.
enum Flow {
    /// Go on (pc already set).
    Next,
    /// The task waits (pc already set to where it resumes). Boxed: a step's result stays
    /// two words.
    Wait(Box<Wait>),
    /// The step may have changed other tasks (sockets, signals, monitor commands).
    Shared,
}

/// Evaluated location.
#[derive(Debug, Clone, Copy)]
enum LocVal {
    J([f32; 6]),
    T([f32; 6]),
}

/// The AS interpreter: programs, variables and up to six tasks (robot task 1, PC tasks 1–5),
/// advanced on a clock it is given by [`Interpreter::run_until`].
///
/// ```
/// use std::time::Duration;
/// use fs020n_as::{Interpreter, Config};
/// use fs020n_as::testing::VirtualSystem;
///
/// let src = ".PROGRAM autostart.pc()\n  count = 0\n  WHILE TRUE DO\n    count = count + 1\n    TWAIT 0.1\n  END\n.END\n";
/// let mut interp = Interpreter::from_source("demo.as", src, Config::default())?;
/// let mut sys = VirtualSystem::new();
/// interp.start(&mut sys);
/// interp.run_until(&mut sys, Duration::from_millis(1050));
/// assert_eq!(interp.real("count"), Some(11.0));
/// # Ok::<(), fs020n_as::LoadError>(())
/// ```
#[derive(Debug, Clone)]
pub struct Interpreter {
    code: Arc<Code>,
    cfg: Config,
    now: Ns,
    globals: Store,
    /// With [`Config::persistent_locals`]: the locals of (task, program) between executions.
    kept: HashMap<(usize, usize), Store>,
    elements: usize,
    tasks: Vec<Task>,
    signals: HashMap<i32, SignalState>,
    /// TIMER n: the time (ns, may be negative) at which it read 0.
    timers: [Option<i128>; 11],
    switches: Vec<bool>,
    mc_hold: bool,
    /// Bumped whenever a signal or an armed interrupt changes.
    int_epoch: u64,
    /// `interrupt_time` per task, valid for `int_epoch`.
    int_cache_epoch: std::cell::Cell<u64>,
    int_cache: [std::cell::Cell<Option<Ns>>; 6],
    /// Bit `k` set while task `k` is not idle (the scheduler's pass visits only these).
    active: u8,
    /// The time the interpreter last brought the system to in this [`Self::run_until`]
    /// (`None` at its start: the system may have changed outside).
    sys_at: Option<Ns>,
    /// `cfg.cost.statement` and `cfg.poll_period` in [`Ns`] (the config never changes).
    stmt_ns: Ns,
    poll_ns: Ns,
    terminal: VecDeque<TerminalLine>,
    trace: Option<Vec<TraceLine>>,
}

/// Largest string, bytes.
pub const MAX_STRING: usize = 255;

/// Most bytes one `TCP_RECV` or `TCP_SEND` moves.
pub const MAX_TRANSFER: usize = 4096;

/// [`Interpreter::exec_hot`]'s answer for an op that is not pure computation (never a pc).
const NOT_PURE: usize = usize::MAX;

/// A runtime error, boxed: results stay two words (returned in registers) on the hot path.
type R<T> = Result<T, Box<RuntimeError>>;

#[inline]
fn check(v: f32, what: &str) -> R<f32> {
    if v.is_finite() {
        Ok(v)
    } else {
        Err(overflow(what))
    }
}

#[cold]
fn overflow(what: &str) -> Box<RuntimeError> {
    Box::new(RuntimeError::Overflow(what.to_owned()))
}

/// A constant or a defined real scalar (of `globals` or `locals`), `None` for anything else.
#[inline(always)]
fn simple_leaf(globals: &Store, locals: &Store, e: &RExpr) -> Option<f32> {
    match e {
        RExpr::Const(c) => Some(*c),
        RExpr::Var(v) if v.idx.is_empty() => {
            let store = if v.var.global { globals } else { locals };
            store.reals.get(v.var.slot as usize)?.scalar
        }
        _ => None,
    }
}

/// An index that is a [`simple_leaf`] or the sum of two, finite and in range, truncated.
#[inline(always)]
fn simple_index(globals: &Store, locals: &Store, e: &RExpr) -> Option<i32> {
    let v = match e {
        RExpr::Bin(BinOp::Add, a, b) => {
            let v = simple_leaf(globals, locals, a)? + simple_leaf(globals, locals, b)?;
            v.is_finite().then_some(v)?
        }
        _ => simple_leaf(globals, locals, e)?,
    };
    (v > -1.0 && v < (MAX_INDEX + 1) as f32).then_some(v as i32)
}

/// [`simple_index`] of each of up to three indices.
#[inline(always)]
fn simple_index_list(g: &Store, s: &Store, idx: &[RExpr]) -> Option<[i32; 3]> {
    Some(match idx {
        [] => [0; 3],
        [a] => [simple_index(g, s, a)?, 0, 0],
        [a, b] => [simple_index(g, s, a)?, simple_index(g, s, b)?, 0],
        [a, b, c, ..] => [
            simple_index(g, s, a)?,
            simple_index(g, s, b)?,
            simple_index(g, s, c)?,
        ],
    })
}

/// A binary operation on reals (AS reals: 32-bit; a result that is not finite is an overflow).
#[inline]
fn bin_r(op: BinOp, x: f32, y: f32) -> R<f32> {
    Ok(match op {
        BinOp::Add => check(x + y, "+")?,
        BinOp::Sub => check(x - y, "-")?,
        BinOp::Mul => check(x * y, "*")?,
        BinOp::Div => {
            if y == 0.0 {
                return Err(division_by_zero());
            }
            check(x / y, "/")?
        }
        BinOp::Mod => {
            if y == 0.0 {
                return Err(division_by_zero());
            }
            check(x % y, "MOD")?
        }
        BinOp::Pow => pow_r(x, y)?,
        BinOp::Eq => as_bool(x == y),
        BinOp::Ne => as_bool(x != y),
        BinOp::Lt => as_bool(x < y),
        BinOp::Gt => as_bool(x > y),
        BinOp::Le => as_bool(x <= y),
        BinOp::Ge => as_bool(x >= y),
        BinOp::And => as_bool(truthy(x) && truthy(y)),
        BinOp::Or => as_bool(truthy(x) || truthy(y)),
        BinOp::Xor => as_bool(truthy(x) != truthy(y)),
        BinOp::Band => (to_i32(x) & to_i32(y)) as f32,
        BinOp::Bor => (to_i32(x) | to_i32(y)) as f32,
        BinOp::Bxor => (to_i32(x) ^ to_i32(y)) as f32,
    })
}

#[cold]
fn division_by_zero() -> Box<RuntimeError> {
    Box::new(RuntimeError::DivisionByZero)
}

#[inline(never)]
fn pow_r(x: f32, y: f32) -> R<f32> {
    let r = x.powf(y);
    if r.is_nan() {
        return Err(Box::new(RuntimeError::IllegalValue(format!("{x} ^ {y}"))));
    }
    check(r, "^")
}

fn truthy(v: f32) -> bool {
    v != 0.0
}

fn as_bool(b: bool) -> f32 {
    if b {
        -1.0
    } else {
        0.0
    }
}

/// A signal number from a real (bounded, so that its absolute value always exists).
fn signal_number(v: f32) -> i32 {
    v.trunc().clamp(-1.0e6, 1.0e6) as i32
}

fn to_i32(v: f32) -> i32 {
    v as i32
}

/// Interpreter time in nanoseconds: the scheduler compares and adds times on every step, and
/// a `u64` does that in one instruction where a [`Duration`] takes two fields (584 years of
/// virtual time; every wait the language allows is far shorter).
type Ns = u64;

/// A duration in [`Ns`] (saturating).
#[inline]
fn ns(d: Duration) -> Ns {
    u64::try_from(d.as_nanos()).unwrap_or(u64::MAX)
}

fn secs(v: f32, what: &str) -> R<Duration> {
    if !(v.is_finite() && v >= 0.0) {
        return Err(Box::new(RuntimeError::IllegalValue(format!(
            "{what} {v} (expected seconds ≥ 0)"
        ))));
    }
    Ok(Duration::from_secs_f64(f64::from(v).min(1.0e7)))
}

impl Interpreter {
    /// Loads parsed modules (all programs share the globals; the data sections are loaded).
    pub fn new(modules: &[Module], config: Config) -> Result<Interpreter, LoadError> {
        let code = compile(modules)?;
        let mut globals = Store::with_sizes([
            code.globals[0].len(),
            code.globals[1].len(),
            code.globals[2].len(),
            code.globals[3].len(),
        ]);
        let mut elements = 0;
        for (ty, slot, idx, value) in &code.data {
            let s = *slot as usize;
            let created = match (ty, value) {
                (Ty::Real, DataValue::Real(v)) => globals.reals[s].set(idx, *v as f32),
                (Ty::Str, DataValue::Str(b)) => globals.strs[s].set(idx, Bytes::from(b.as_slice())),
                (Ty::Joint, DataValue::Joints(j)) => {
                    globals.joints[s].set(idx, j.map(|x| x as f32))
                }
                (Ty::Trans, DataValue::Trans(t)) => globals.trans[s].set(idx, t.map(|x| x as f32)),
                _ => false,
            };
            elements += usize::from(created);
        }
        let mut cfg = config;
        cfg.cost.statement = cfg.cost.statement.max(Duration::from_micros(1));
        if cfg.poll_period.is_zero() {
            cfg.poll_period = Duration::from_millis(2);
        }
        cfg.max_call_depth = cfg.max_call_depth.clamp(1, 1000);
        let (stmt_ns, poll_ns) = (ns(cfg.cost.statement), ns(cfg.poll_period));
        Ok(Interpreter {
            code: Arc::new(code),
            cfg,
            now: 0,
            globals,
            kept: HashMap::new(),
            elements,
            tasks: (0..6).map(|i| Task::new(TaskId::from_index(i))).collect(),
            signals: HashMap::new(),
            timers: [None; 11],
            switches: SYSTEM_SWITCHES.iter().map(|(_, v)| *v).collect(),
            mc_hold: false,
            int_epoch: 1,
            int_cache_epoch: std::cell::Cell::new(0),
            int_cache: Default::default(),
            active: 0,
            sys_at: None,
            stmt_ns,
            poll_ns,
            terminal: VecDeque::new(),
            trace: None,
        })
    }

    /// Parses and loads one file.
    pub fn from_source(file: &str, text: &str, config: Config) -> Result<Interpreter, LoadError> {
        let m = crate::parse(file, text)?;
        Interpreter::new(&[m], config)
    }

    /// Things skipped while loading (unknown sections).
    pub fn warnings(&self) -> &[ParseError] {
        &self.code.warnings
    }

    /// The settings.
    pub fn config(&self) -> &Config {
        &self.cfg
    }

    /// The loaded program names.
    pub fn programs(&self) -> Vec<&str> {
        self.code.programs.iter().map(|p| p.name.as_str()).collect()
    }

    /// Interpreter time (since it was created).
    pub fn now(&self) -> Duration {
        Duration::from_nanos(self.now)
    }

    /// Controller start: runs `autostart.pc` in PC task 1 and `autostart2.pc` …
    /// `autostart5.pc` in PC tasks 2–5, those that are loaded.
    pub fn start(&mut self, sys: &mut dyn System) {
        for n in 1..=5u8 {
            let name = if n == 1 {
                "autostart.pc".to_owned()
            } else {
                format!("autostart{n}.pc")
            };
            if let Some(&p) = self.code.by_name.get(&name) {
                self.start_task(usize::from(n), p, &[], 1);
                self.message(sys, TaskId::Pc(n), format!("{name} started in PC task {n}"));
            }
        }
    }

    /// `EXECUTE program` from outside (the pendant): starts it in robot task 1, with the
    /// controller's checks.
    pub fn execute(&mut self, program: &str, sys: &mut dyn System) -> Result<(), Refusal> {
        let p = *self
            .code
            .by_name
            .get(program)
            .ok_or_else(|| Refusal::NoProgram(program.to_owned()))?;
        self.execute_robot(p, Vec::new(), 1, sys)
    }

    /// `PCEXECUTE n: program` from outside.
    pub fn pc_execute(&mut self, task: u8, program: &str) -> Result<(), Refusal> {
        let p = *self
            .code
            .by_name
            .get(program)
            .ok_or_else(|| Refusal::NoProgram(program.to_owned()))?;
        self.pc_execute_at(task, p, Vec::new(), 1)
    }

    /// Stops a task at once (`ABORT`/`PCABORT` from outside, a panel switch that stops the
    /// robot program). The robot's motion is the system's business.
    pub fn abort(&mut self, task: TaskId) {
        let i = task.index();
        self.release_frames(i, 0);
        self.set_run(i, Run::Idle);
        let t = &mut self.tasks[i];
        t.wait = None;
        t.interrupts.clear();
        t.pending_on = None;
        self.int_epoch += 1;
    }

    // ------------------------------------------------------------------ observers

    /// The state of a task as `TASK(n)` reports it now.
    pub fn task_state(&self, task: TaskId, sys: &dyn System) -> TaskState {
        self.task_state_at(task, sys.panel(), sys.motion_in_progress())
    }

    /// The state of a task given the panel and whether the robot moves (for observers that
    /// hold the system's state rather than a [`System`]).
    pub fn task_state_at(&self, task: TaskId, panel: PanelState, moving: bool) -> TaskState {
        let i = task.index();
        let t = &self.tasks[i];
        match t.run {
            Run::Idle => TaskState::Idle,
            Run::Ending => {
                if moving {
                    TaskState::WaitingMotion
                } else {
                    TaskState::Idle
                }
            }
            Run::Running => {
                let held = i == 0 && (self.mc_hold || !panel.run);
                if held || matches!(t.wait, Some(Wait::Paused | Wait::Held)) {
                    TaskState::Paused
                } else {
                    TaskState::Running
                }
            }
        }
    }

    /// Every task: program, line, state, what it waits for.
    pub fn tasks(&self, sys: &dyn System) -> Vec<TaskInfo> {
        self.tasks_at(sys.panel(), sys.motion_in_progress())
    }

    /// [`Interpreter::tasks`] given the panel and whether the robot moves.
    pub fn tasks_at(&self, panel: PanelState, moving: bool) -> Vec<TaskInfo> {
        self.tasks
            .iter()
            .map(|t| {
                let frame = t.frames.last();
                let prog = frame.and_then(|f| self.code.programs.get(f.prog));
                let line = frame.and_then(|f| prog.and_then(|p| p.lines.get(f.pc).copied()));
                TaskInfo {
                    task: t.id.to_string(),
                    state: self.task_state_at(t.id, panel, moving),
                    program: prog.map(|p| p.name.clone()),
                    line,
                    text: match (frame, line) {
                        (Some(f), Some(l)) => {
                            Some(self.code.line_text(f.prog, l).trim().to_owned())
                        }
                        _ => None,
                    },
                    waiting: t.wait.as_ref().map(Wait::describe),
                    last_error: t.last_error.clone(),
                    steps: t.steps,
                }
            })
            .collect()
    }

    /// The latest terminal lines (oldest first).
    pub fn terminal(&self) -> impl Iterator<Item = &TerminalLine> {
        self.terminal.iter()
    }

    /// Records every executed step from now on (`true`), or stops (`false`); see
    /// [`Interpreter::take_trace`].
    pub fn set_trace(&mut self, on: bool) {
        self.trace = if on { Some(Vec::new()) } else { None };
    }

    /// The steps executed since the last call (empty unless tracing).
    pub fn take_trace(&mut self) -> Vec<TraceLine> {
        self.trace.as_mut().map(std::mem::take).unwrap_or_default()
    }

    fn global_slot(&self, ty: Ty, name: &str) -> Option<usize> {
        self.code.global_index[ty as usize]
            .get(&name.to_ascii_lowercase())
            .map(|&s| s as usize)
    }

    /// A global real (`None`: never assigned or unknown).
    pub fn real(&self, name: &str) -> Option<f32> {
        self.real_at(name, &[])
    }

    /// An element of a global real array.
    pub fn real_at(&self, name: &str, idx: &[i32]) -> Option<f32> {
        let s = self.global_slot(Ty::Real, name)?;
        self.globals.reals[s].get(idx).copied()
    }

    /// A global string (`name` without `$`).
    pub fn string(&self, name: &str) -> Option<Vec<u8>> {
        self.string_at(name, &[])
    }

    /// An element of a global string array.
    pub fn string_at(&self, name: &str, idx: &[i32]) -> Option<Vec<u8>> {
        let s = self.global_slot(Ty::Str, name)?;
        self.globals.strs[s].get(idx).map(|b| b.to_vec())
    }

    /// A global joint point (`name` without `#`).
    pub fn joints(&self, name: &str) -> Option<[f32; 6]> {
        let s = self.global_slot(Ty::Joint, name)?;
        self.globals.joints[s].get(&[]).copied()
    }

    /// Sets a global real that the programs use (returns `false` when no program names it).
    pub fn set_real(&mut self, name: &str, value: f32) -> bool {
        match self.global_slot(Ty::Real, name) {
            Some(s) => {
                self.globals.reals[s].set(&[], value);
                true
            }
            None => false,
        }
    }

    /// Every global real scalar and array element, by name (for dumps and tests).
    pub fn globals_dump(&self) -> Vec<(String, f32)> {
        let mut out = Vec::new();
        for (i, name) in self.code.globals[0].iter().enumerate() {
            if let Some(v) = self.globals.reals[i].get(&[]) {
                out.push((name.clone(), *v));
            }
            for (idx, v) in self.globals.reals[i].elements() {
                let idx: Vec<String> = idx.iter().map(|i| i.to_string()).collect();
                out.push((format!("{name}[{}]", idx.join(",")), v));
            }
        }
        out
    }

    /// `TIMER(n)` now (0 for a timer never set or out of range), seconds, 1 ms resolution.
    pub fn timer(&self, n: usize) -> f32 {
        let since = match n {
            0 => Some(0),
            1..=10 => self.timers[n],
            _ => None,
        };
        since.map_or(0.0, |s| {
            let ms = (i128::from(self.now) - s).div_euclid(1_000_000);
            (ms as f64 / 1000.0) as f32
        })
    }

    /// A signal's state (outputs 1–999, inputs 1001–1999, internal 2001–2960).
    pub fn signal(&self, n: i32) -> bool {
        self.signals.get(&n).is_some_and(|s| s.on)
    }

    /// Sets an external input (1001–1999) or any signal from outside, at the current time.
    pub fn set_signal(&mut self, n: i32, on: bool) {
        self.write_signal(n, on);
    }

    /// A system switch (`ABS.SPEED`, `CP`, …), `None` for an unknown name.
    pub fn system_switch(&self, name: &str) -> Option<bool> {
        let name = name.to_ascii_lowercase();
        SYSTEM_SWITCHES
            .iter()
            .position(|(n, _)| *n == name)
            .map(|i| self.switches[i])
    }

    /// Sets a system switch from outside (the pendant); `false` for an unknown name.
    pub fn set_system_switch(&mut self, name: &str, on: bool) -> bool {
        let name = name.to_ascii_lowercase();
        match SYSTEM_SWITCHES.iter().position(|(n, _)| *n == name) {
            Some(i) => {
                self.switches[i] = on;
                true
            }
            None => false,
        }
    }

    fn switch_on(&self, name: &str) -> bool {
        SYSTEM_SWITCHES
            .iter()
            .position(|(n, _)| *n == name)
            .is_some_and(|i| self.switches[i])
    }

    /// The time of the next thing the interpreter will do by itself (a step, a timeout, a
    /// poll of a waiting condition, an interrupt), `None` when every task is idle or waits
    /// only for outside events.
    pub fn next_event(&self) -> Option<Duration> {
        self.next_event_from(None)
            .map(|(t, _)| Duration::from_nanos(t))
    }

    // ------------------------------------------------------------------ scheduler

    fn next_tick(&self, after: Ns) -> Ns {
        let p = self.poll_ns.max(1);
        (after / p + 1).saturating_mul(p)
    }

    fn task_wake(&self, i: usize) -> Option<Ns> {
        self.wake_time(i, &self.tasks[i])
    }

    /// [`Self::task_wake`] of task `i`, given.
    #[inline]
    fn wake_time(&self, i: usize, t: &Task) -> Option<Ns> {
        if t.run == Run::Ending {
            return Some(t.poll_at);
        }
        if t.run != Run::Running {
            return None;
        }
        let Some(w) = &t.wait else {
            return Some(t.ready_at.max(self.now));
        };
        if t.kick && w.socket() {
            return Some(self.now);
        }
        let own = match w {
            Wait::Until(d) => Some((*d).max(t.ready_at)),
            Wait::Accept { deadline, .. }
            | Wait::Connect { deadline, .. }
            | Wait::Recv { deadline, .. }
            | Wait::Send { deadline, .. } => Some((*deadline).max(t.ready_at)),
            _ => None,
        };
        // The robot task also watches the panel and the error while it waits.
        let poll = (i == 0 || w.polled()).then_some(t.poll_at);
        match (own, poll) {
            (Some(a), Some(b)) => Some(a.min(b)),
            (a, b) => a.or(b),
        }
    }

    /// Stores a wait of task `i` and schedules its next poll.
    fn set_wait(&mut self, i: usize, w: Wait) {
        let base = self.now.max(self.tasks[i].ready_at.saturating_sub(1));
        let at = self.next_tick(base);
        let t = &mut self.tasks[i];
        t.poll_at = at;
        t.wait = Some(w);
    }

    /// When each task's earliest armed interrupt fires (idle tasks: never).
    fn interrupt_times(&self) -> [Option<Ns>; 6] {
        let mut times = self.interrupt_times_cached();
        for (k, t) in self.tasks.iter().enumerate().take(6) {
            if t.run == Run::Idle {
                times[k] = None;
            }
        }
        times
    }

    /// [`Self::interrupt_times`] without idle tasks set to `None` (the same for every task
    /// that is not idle).
    fn interrupt_times_cached(&self) -> [Option<Ns>; 6] {
        self.refresh_int_cache();
        std::array::from_fn(|k| self.int_cache[k].get())
    }

    /// Task `k`'s entry of [`Self::interrupt_times_cached`].
    #[inline]
    fn interrupt_time_cached(&self, k: usize) -> Option<Ns> {
        self.refresh_int_cache();
        self.int_cache.get(k).and_then(std::cell::Cell::get)
    }

    /// Recomputes the cached interrupt times when a signal or an armed interrupt changed.
    #[inline]
    fn refresh_int_cache(&self) {
        if self.int_cache_epoch.get() == self.int_epoch {
            return;
        }
        let debounce = ns(self.cfg.signal_debounce);
        for (k, t) in self.tasks.iter().enumerate().take(6) {
            let time = t
                .interrupts
                .iter()
                .filter_map(|int| {
                    let n = int.signal.abs();
                    let want = int.signal > 0;
                    let s = self.signals.get(&n)?;
                    (s.on == want && s.changed > int.armed_at)
                        .then(|| s.changed.saturating_add(debounce))
                })
                .min();
            self.int_cache[k].set(time);
        }
        self.int_cache_epoch.set(self.int_epoch);
    }

    /// Sets task `k`'s run state (and its bit in [`Self::active`]).
    fn set_run(&mut self, k: usize, run: Run) {
        if let Some(t) = self.tasks.get_mut(k) {
            t.run = run;
            let bit = 1u8 << (k & 7);
            if run == Run::Idle {
                self.active &= !bit;
            } else {
                self.active |= bit;
            }
        }
    }

    fn interrupt_time(&self, i: usize) -> Option<Ns> {
        self.interrupt_times().get(i).copied().flatten()
    }

    /// Earliest event, skipping task `skip`'s own steps; ties go to the lower task.
    fn next_event_from(&self, skip: Option<usize>) -> Option<(Ns, usize)> {
        let mut best: Option<(Ns, usize)> = None;
        let ints = if self.tasks.iter().any(|t| !t.interrupts.is_empty()) {
            self.interrupt_times()
        } else {
            [None; 6]
        };
        for i in 0..self.tasks.len() {
            let mut cands = [ints.get(i).copied().flatten(), None];
            if skip != Some(i) {
                cands[1] = self.task_wake(i);
            }
            for t in cands.into_iter().flatten() {
                if best.is_none_or(|(b, _)| t < b) {
                    best = Some((t, i));
                }
            }
        }
        best
    }

    /// The next event in one pass over the tasks: its time, its task, whether it is that
    /// task's interrupt, and the horizon — what [`Self::next_event_from`] gives with that task's
    /// own steps skipped (where a run of its steps must stop).
    fn next_event_and_horizon(&self) -> Option<(Ns, usize, bool, Option<Ns>)> {
        fn earlier(a: Option<Ns>, b: Option<Ns>) -> Option<Ns> {
            match (a, b) {
                (Some(x), Some(y)) => Some(x.min(y)),
                (x, y) => x.or(y),
            }
        }
        // Only tasks that are not idle (an idle task has no step and no armed interrupt);
        // interrupt times only for tasks with armed interrupts (a task without any has none).
        let mut best: Option<(Ns, usize, Option<Ns>)> = None;
        let mut others: Option<Ns> = None;
        let mut mask = self.active;
        while mask != 0 {
            let k = mask.trailing_zeros() as usize;
            mask &= mask - 1;
            let Some(t) = self.tasks.get(k) else { break };
            let int = if t.interrupts.is_empty() {
                None
            } else {
                self.interrupt_time_cached(k)
            };
            let Some(c) = earlier(int, self.wake_time(k, t)) else {
                continue;
            };
            match best {
                Some((b, _, _)) if c >= b => others = earlier(others, Some(c)),
                _ => {
                    others = earlier(others, best.map(|(b, _, _)| b));
                    best = Some((c, k, int));
                }
            }
        }
        let (at, i, int) = best?;
        let interrupt = int.is_some_and(|it| it <= at);
        Some((at, i, interrupt, earlier(others, int)))
    }

    /// Runs every task up to `until` (statements, timeouts, waits, interrupts), calling
    /// [`System::advance_to`] before each step. Events at exactly `until` run.
    pub fn run_until(&mut self, sys: &mut dyn System, until: Duration) {
        let until = ns(until);
        if until < self.now {
            return;
        }
        // Something outside may have changed since the last call (a client connected, data
        // arrived, a switch moved): look at every waiting task now.
        for t in &mut self.tasks {
            if t.wait.as_ref().is_some_and(Wait::socket) {
                t.kick = true;
            }
        }
        self.sys_at = None;
        // The code never changes once loaded: one handle for the whole run.
        let code = Arc::clone(&self.code);
        let mut guard: u64 = 0;
        while let Some((t, i, interrupt, horizon)) = self.next_event_and_horizon() {
            if t > until {
                break;
            }
            guard += 1;
            if guard > 50_000_000 {
                break;
            }
            if t > self.now {
                self.now = t;
                self.advance_sys(sys, t);
            }
            // The system cannot change the interpreter's signals: the interrupt due at `t` is
            // still due now.
            if interrupt {
                self.fire_interrupt(i, sys);
                continue;
            }
            self.wake(i, sys, until, horizon, &code);
        }
        if until > self.now {
            self.now = until;
            self.advance_sys(sys, until);
        }
    }

    /// Brings the system to `t` (once: a second call for the same time does nothing).
    #[inline]
    fn advance_sys(&mut self, sys: &mut dyn System, t: Ns) {
        if self.sys_at != Some(t) {
            sys.advance_to(Duration::from_nanos(t));
            self.sys_at = Some(t);
        }
    }

    /// Task `i` is due: poll its wait, then run its steps until another event is due
    /// (`horizon`: the earliest event other than this task's steps, as found before the poll).
    fn wake(
        &mut self,
        i: usize,
        sys: &mut dyn System,
        until: Ns,
        horizon: Option<Ns>,
        code: &Arc<Code>,
    ) {
        let epoch = self.int_epoch;
        // The robot task's poll without a wait checks the panel and the error (at `self.now`,
        // with the system there) and changes nothing in the system: its first step at that
        // time need not check them again.
        let t = &self.tasks[i];
        let plain = t.run == Run::Running && t.wait.is_none() && t.pending_on.is_none();
        let checked_at = (i == 0 && plain && self.sys_at == Some(self.now)).then_some(self.now);
        if plain {
            // The poll of a task without a wait or a pending ON, in place.
            if i == 0 && !self.robot_allowed(sys) {
                return;
            }
            self.tasks[i].kick = false;
        } else if !self.poll(i, sys) {
            return;
        }
        // The poll changes only this task (its steps are not in the horizon) — unless it
        // changed a signal or an interrupt.
        let mut horizon = if self.int_epoch == epoch {
            horizon.map_or(until, |t| t.min(until))
        } else {
            self.next_event_from(Some(i))
                .map_or(until, |(t, _)| t.min(until))
        };
        let poll = self.poll_ns;
        // The system is brought to a step's time only when the step touches it, or once per
        // poll period (pure computation does not need the arm's state).
        let mut synced = self.now;
        let mut first = true;
        let mut epoch = self.int_epoch;
        loop {
            let now = self.now;
            let t = &self.tasks[i];
            // (A pending ON is delivered at the next wake: the poll above took any earlier
            // one.)
            if t.run != Run::Running || t.wait.is_some() || t.pending_on.is_some() {
                return;
            }
            let at = t.ready_at.max(now);
            if at > now {
                // Another task (or the same instant of a lower task) goes first.
                if at >= horizon || at > until {
                    return;
                }
                self.now = at;
            }
            let (prog, pc) = t.frames.last().map_or((usize::MAX, 0), |f| (f.prog, f.pc));
            let p = code.programs.get(prog);
            let touches = p.and_then(|p| p.touches.get(pc).copied()).unwrap_or(true);
            let sync = first || touches || at >= synced.saturating_add(poll);
            let checked = first && checked_at == Some(at);
            if sync {
                self.advance_sys(sys, at);
                synced = at;
                first = false;
            }
            // A PC task's step that meets the system needs nothing more than the system at
            // its time; the robot task's checks the panel, the error and HOLD (in `step`).
            if (!sync || i != 0) && self.trace.is_none() {
                if let Some(p) = p {
                    // A run of pure computation between two syncs: the ops run here, with the
                    // pc, the time and the step count in locals (written back when the run
                    // ends), without the checks of a step that meets the system. Each op
                    // sees what a step would give it (its time in `self.now`).
                    let (mut pc, mut at, mut steps) = (pc, at, 0u64);
                    let mut ready = at;
                    let cost = self.stmt_ns;
                    let poll_end = synced.saturating_add(poll);
                    let failed = loop {
                        let Some(op) = p.ops.get(pc) else { break None };
                        match self.exec_hot(i, sys, op, pc) {
                            // Not pure computation: a step below runs it.
                            Ok(NOT_PURE) => break None,
                            Ok(next) => pc = next,
                            Err(e) => {
                                steps += 1;
                                break Some(e);
                            }
                        }
                        steps += 1;
                        ready = at.saturating_add(cost);
                        if ready >= horizon
                            || ready > until
                            || ready >= poll_end
                            || p.touches.get(pc).copied().unwrap_or(true)
                        {
                            break None;
                        }
                        self.now = ready;
                        at = ready;
                    };
                    if steps > 0 {
                        let t = &mut self.tasks[i];
                        t.steps += steps;
                        if let Some(f) = t.frames.last_mut() {
                            f.pc = pc;
                        }
                        // A failed step leaves the time where the previous one put it.
                        if failed.is_none() || steps > 1 {
                            t.ready_at = ready;
                        }
                        if let Some(e) = failed {
                            self.fail(i, e, sys);
                            return;
                        }
                        continue;
                    }
                }
            }
            match self.step(i, sys, code, sync, checked, p, pc) {
                Ok(Flow::Next) => {}
                Ok(Flow::Shared) => {
                    for (k, t) in self.tasks.iter_mut().enumerate() {
                        if k != i && t.wait.as_ref().is_some_and(Wait::socket) {
                            t.kick = true;
                        }
                    }
                    horizon = self
                        .next_event_from(Some(i))
                        .map_or(until, |(t, _)| t.min(until));
                }
                Ok(Flow::Wait(w)) => {
                    self.set_wait(i, *w);
                    return;
                }
                Err(e) => {
                    self.fail(i, e, sys);
                    return;
                }
            }
            if self.int_epoch != epoch {
                // A signal or an interrupt changed: an interrupt may be due, others may run.
                epoch = self.int_epoch;
                if self.interrupt_time(i).is_some_and(|it| it <= self.now) {
                    return;
                }
                horizon = self
                    .next_event_from(Some(i))
                    .map_or(until, |(t, _)| t.min(until));
            }
        }
    }

    /// Robot task: stop it when the controller cannot run a program (error, power off, TEACH,
    /// teach lock); `true` when it may go on.
    fn robot_allowed(&mut self, sys: &mut dyn System) -> bool {
        let panel = sys.panel();
        let err = sys.error();
        if !err.is_none() || !panel.power || !panel.repeat || panel.teach_lock {
            let why = if !err.is_none() {
                format!("program stopped: controller error {err}")
            } else if !panel.power {
                "program stopped: motor power OFF".into()
            } else if !panel.repeat {
                "program stopped: TEACH mode".into()
            } else {
                "program stopped: TEACH LOCK ON".into()
            };
            self.abort(TaskId::Robot);
            self.message(sys, TaskId::Robot, why);
            return false;
        }
        true
    }

    /// Polls task `i`'s wait; `true` when it may run steps now.
    #[inline(never)]
    fn poll(&mut self, i: usize, sys: &mut dyn System) -> bool {
        if self.tasks[i].run == Run::Ending {
            // TASK(1) = 3 until the last motion is done.
            if !self.robot_allowed(sys) {
                return false;
            }
            if sys.motion_in_progress() {
                self.tasks[i].poll_at = self.next_tick(self.now);
            } else {
                self.abort(TaskId::Robot);
            }
            return false;
        }
        if self.tasks[i].run != Run::Running {
            return false;
        }
        if i == 0 && !self.robot_allowed(sys) {
            return false;
        }
        self.tasks[i].kick = false;
        let now = self.now;
        let Some(wait) = self.tasks[i].wait.take() else {
            return self.deliver_on(i, sys);
        };
        let done: R<Option<Wait>> = (|| -> R<Option<Wait>> {
            Ok(match wait {
                Wait::Until(t) => (now < t).then_some(Wait::Until(t)),
                Wait::Cond => {
                    let e = match self.current_op(i) {
                        Some(Op::Wait(e)) => e.clone(),
                        _ => return Ok(None),
                    };
                    if truthy(self.eval_r(i, &e, sys)?) {
                        self.advance_pc(i);
                        None
                    } else {
                        Some(Wait::Cond)
                    }
                }
                Wait::MotionPlanned => sys.motion_planned().then_some(Wait::MotionPlanned),
                Wait::MotionDone => sys.motion_in_progress().then_some(Wait::MotionDone),
                Wait::Held => (self.mc_hold || !sys.panel().run).then_some(Wait::Held),
                Wait::Paused => Some(Wait::Paused),
                Wait::Accept { port, deadline } => match sys.tcp_accept(port) {
                    SockPoll::Ready(r) => {
                        self.finish_accept(i, r, sys)?;
                        None
                    }
                    SockPoll::Pending if now >= deadline => {
                        self.finish_accept(i, Err(-34024), sys)?;
                        None
                    }
                    SockPoll::Pending => Some(Wait::Accept { port, deadline }),
                },
                Wait::Connect { ip, port, deadline } => match sys.tcp_connect(ip, port) {
                    SockPoll::Ready(r) => {
                        self.finish_ret(i, r.unwrap_or_else(|e| e) as f32, sys)?;
                        None
                    }
                    SockPoll::Pending if now >= deadline => {
                        self.finish_ret(i, -34024.0, sys)?;
                        None
                    }
                    SockPoll::Pending => Some(Wait::Connect { ip, port, deadline }),
                },
                Wait::Recv {
                    sock,
                    max,
                    deadline,
                } => match sys.tcp_recv(sock, MAX_TRANSFER) {
                    SockPoll::Ready(r) => {
                        self.finish_recv(i, r, max, sys)?;
                        None
                    }
                    SockPoll::Pending if now >= deadline => {
                        self.finish_recv(i, Err(-34024), max, sys)?;
                        None
                    }
                    SockPoll::Pending => Some(Wait::Recv {
                        sock,
                        max,
                        deadline,
                    }),
                },
                Wait::Send {
                    sock,
                    data,
                    deadline,
                } => match sys.tcp_send(sock, &data) {
                    SockPoll::Ready(r) => {
                        self.finish_ret(i, r.map_or_else(|e| e as f32, |()| 0.0), sys)?;
                        None
                    }
                    SockPoll::Pending if now >= deadline => {
                        self.finish_ret(i, -34024.0, sys)?;
                        None
                    }
                    SockPoll::Pending => Some(Wait::Send {
                        sock,
                        data,
                        deadline,
                    }),
                },
            })
        })();
        match done {
            Ok(Some(w)) => {
                self.set_wait(i, w);
                false
            }
            Ok(None) => {
                let t = &mut self.tasks[i];
                t.ready_at = t.ready_at.max(now);
                self.deliver_on(i, sys)
            }
            Err(e) => {
                self.fail(i, e, sys);
                false
            }
        }
    }

    /// Delivers a pending `ON` interrupt at a step boundary; `true` when the task may run.
    fn deliver_on(&mut self, i: usize, sys: &mut dyn System) -> bool {
        if let Some(int) = self.tasks[i].pending_on.take() {
            self.branch(i, int, sys);
        }
        self.tasks[i].run == Run::Running && self.tasks[i].wait.is_none()
    }

    fn fire_interrupt(&mut self, i: usize, sys: &mut dyn System) {
        let now = self.now;
        let debounce = ns(self.cfg.signal_debounce);
        let signals = &self.signals;
        let pos = self.tasks[i].interrupts.iter().position(|int| {
            let n = int.signal.abs();
            signals.get(&n).is_some_and(|s| {
                s.on == (int.signal > 0)
                    && s.changed > int.armed_at
                    && s.changed.saturating_add(debounce) <= now
            })
        });
        let Some(pos) = pos else { return };
        let int = self.tasks[i].interrupts.remove(pos);
        self.int_epoch += 1;
        if int.immediate {
            // ONI: the motion stops at once (the planned one is dropped), the program
            // branches now — also while it was finishing (TASK(1) = 3).
            sys.cut_motion();
            self.tasks[i].wait = None;
            self.set_run(i, Run::Running);
            self.branch(i, int, sys);
        } else if self.tasks[i].run == Run::Ending {
            // ON while finishing: the program branches after the last motion is done…
            // which ends it first: the interrupt is lost.
        } else if self.tasks[i].wait.is_some() {
            // ON: after the current wait (a motion in progress completes first).
            self.tasks[i].pending_on = Some(int);
        } else {
            self.branch(i, int, sys);
        }
    }

    fn branch(&mut self, i: usize, int: Interrupt, sys: &mut dyn System) {
        self.release_frames(i, int.depth.max(1));
        let t = &mut self.tasks[i];
        t.ready_at = self.now;
        if let Some(target) = int.goto {
            if let Some(f) = t.frames.last_mut() {
                f.pc = target;
            }
        } else if let Some(p) = int.call {
            if let Err(e) = self.push_frame(i, p, &[]) {
                self.fail(i, e, sys);
            }
        }
    }

    fn current_op(&self, i: usize) -> Option<&Op> {
        let f = self.tasks[i].frames.last()?;
        self.code.programs.get(f.prog)?.ops.get(f.pc)
    }

    fn advance_pc(&mut self, i: usize) {
        if let Some(f) = self.tasks[i].frames.last_mut() {
            f.pc += 1;
        }
    }

    fn fail(&mut self, i: usize, e: Box<RuntimeError>, sys: &mut dyn System) {
        self.advance_sys(sys, self.now);
        let id = self.tasks[i].id;
        let where_ = self.tasks[i].frames.last().map(|f| {
            let p = &self.code.programs[f.prog];
            format!(
                "{} line {}",
                p.name,
                p.lines.get(f.pc).copied().unwrap_or(0)
            )
        });
        let text = match &where_ {
            Some(w) => format!("{e} ({w})"),
            None => e.to_string(),
        };
        self.abort(id);
        self.tasks[i].last_error = Some(text.clone());
        self.message(sys, id, text);
        sys.raise_error(e.code());
    }

    fn message(&mut self, sys: &mut dyn System, task: TaskId, text: String) {
        sys.terminal(task, &text);
        self.terminal.push_back(TerminalLine {
            at: Duration::from_nanos(self.now),
            task,
            text,
        });
        while self.terminal.len() > self.cfg.terminal_lines {
            self.terminal.pop_front();
        }
    }

    // ------------------------------------------------------------------ starting programs

    fn new_locals(&mut self, task: usize, prog: usize) -> Store {
        if self.cfg.persistent_locals {
            if let Some(s) = self.kept.remove(&(task, prog)) {
                return s;
            }
        }
        Store::with_sizes(self.code.programs[prog].locals)
    }

    /// Pops task `i`'s frames down to `keep`, releasing their locals.
    fn release_frames(&mut self, i: usize, keep: usize) {
        while self.tasks[i].frames.len() > keep {
            let Some(f) = self.tasks[i].frames.pop() else {
                break;
            };
            self.release(i, f);
        }
    }

    fn release(&mut self, i: usize, f: Frame) {
        if self.cfg.persistent_locals {
            self.kept.insert((i, f.prog), f.locals);
        } else {
            self.elements = self.elements.saturating_sub(f.locals.element_count());
        }
    }

    /// Arguments evaluated in the caller: values, and for by-reference parameters where the
    /// value goes back.
    fn push_frame(
        &mut self,
        i: usize,
        prog: usize,
        args: &[(ArgVal, Option<ByRefTarget>)],
    ) -> R<()> {
        if self.tasks[i].frames.len() >= self.cfg.max_call_depth {
            return Err(Box::new(RuntimeError::CallDepth(self.cfg.max_call_depth)));
        }
        let mut store = self.new_locals(i, prog);
        let code = self.code.clone();
        let p = &code.programs[prog];
        let mut byref = Vec::new();
        for (k, param) in p.params.iter().enumerate() {
            let Some((val, target)) = args.get(k) else {
                continue;
            };
            let store = &mut store;
            let s = param.slot as usize;
            match (param.ty, val) {
                (Ty::Real, ArgVal::R(v)) => {
                    store.reals[s].set(&[], *v);
                }
                (Ty::Str, ArgVal::S(v)) => {
                    store.strs[s].set(&[], v.clone());
                }
                (Ty::Joint, ArgVal::J(v)) => {
                    store.joints[s].set(&[], *v);
                }
                (Ty::Trans, ArgVal::T(v)) => {
                    store.trans[s].set(&[], *v);
                }
                _ => {
                    return Err(Box::new(RuntimeError::IllegalValue(format!(
                        "argument {} of {} has the wrong type for parameter {}",
                        k + 1,
                        p.name,
                        var_display(param.ty, false, &p.local_names[param.ty as usize][s])
                    ))))
                }
            }
            if param.by_ref {
                if let Some(t) = target {
                    byref.push(ByRef {
                        ty: param.ty,
                        param: param.slot,
                        var: t.var,
                        idx: t.idx.clone(),
                        frame: t.frame,
                    });
                }
            }
        }
        self.tasks[i].frames.push(Frame {
            prog,
            pc: 0,
            locals: store,
            byref,
        });
        Ok(())
    }

    fn start_task(
        &mut self,
        i: usize,
        prog: usize,
        args: &[(ArgVal, Option<ByRefTarget>)],
        cycles: i64,
    ) -> bool {
        let now = self.now;
        self.release_frames(i, 0);
        self.set_run(i, Run::Running);
        {
            let t = &mut self.tasks[i];
            t.wait = None;
            t.kick = false;
            t.interrupts.clear();
            t.pending_on = None;
            t.ready_at = now;
            t.cycles_left = if cycles == 0 { 1 } else { cycles };
            t.motion = MotionParams::default();
            t.last_error = None;
            t.line_buf.clear();
        }
        self.int_epoch += 1;
        match self.push_frame(i, prog, args) {
            Ok(()) => true,
            Err(_) => {
                self.set_run(i, Run::Idle);
                false
            }
        }
    }

    fn execute_robot(
        &mut self,
        prog: usize,
        args: Vec<(ArgVal, Option<ByRefTarget>)>,
        cycles: i64,
        sys: &mut dyn System,
    ) -> Result<(), Refusal> {
        let panel = sys.panel();
        if !panel.power {
            return Err(p_code(-11000, "Motor power OFF, cannot execute program."));
        }
        if !panel.repeat {
            return Err(p_code(-11001, "Cannot execute program in TEACH mode."));
        }
        if panel.teach_lock {
            return Err(p_code(-11002, "Teach lock ON, cannot execute program."));
        }
        if !sys.error().is_none() {
            return Err(p_code(
                -11013,
                "In error, cannot execute program. Reset the error first.",
            ));
        }
        if self.task_state(TaskId::Robot, sys) != TaskState::Idle {
            return Err(p_code(-11009, "Program is already running."));
        }
        self.mc_hold = false;
        if self.start_task(0, prog, &args, cycles) {
            Ok(())
        } else {
            Err(Refusal::Other(
                "the program could not start (argument types)".into(),
            ))
        }
    }

    fn pc_execute_at(
        &mut self,
        task: u8,
        prog: usize,
        args: Vec<(ArgVal, Option<ByRefTarget>)>,
        cycles: i64,
    ) -> Result<(), Refusal> {
        if !(1..=5).contains(&task) {
            return Err(Refusal::Other(format!(
                "PC task {task} does not exist (1 to 5)"
            )));
        }
        if self.tasks[usize::from(task)].run != Run::Idle {
            return Err(Refusal::Other(format!("PC task {task} is already running")));
        }
        if self.start_task(usize::from(task), prog, &args, cycles) {
            Ok(())
        } else {
            Err(Refusal::Other(
                "the program could not start (argument types)".into(),
            ))
        }
    }

    /// The program of task `i` ended (`.END` or `RETURN` of its first program, `HALT`).
    /// A robot program whose last motion still runs is "finishing" (TASK(1) = 3): its
    /// interrupts stay armed until the motion is done.
    fn end_program(&mut self, i: usize, sys: &mut dyn System, repeat: bool) {
        let t = &mut self.tasks[i];
        if repeat && t.cycles_left != 1 {
            if t.cycles_left > 1 {
                t.cycles_left -= 1;
            }
            self.release_frames(i, 1);
            if let Some(f) = self.tasks[i].frames.first_mut() {
                f.pc = 0;
            }
            return;
        }
        if i == 0 && sys.motion_in_progress() {
            self.release_frames(i, 1);
            let at = self.next_tick(self.now);
            self.set_run(0, Run::Ending);
            let t = &mut self.tasks[0];
            t.wait = None;
            t.pending_on = None;
            t.poll_at = at;
            return;
        }
        let id = self.tasks[i].id;
        self.abort(id);
    }

    // ------------------------------------------------------------------ variables

    fn store(&mut self, i: usize, global: bool) -> &mut Store {
        if global {
            &mut self.globals
        } else {
            match self.tasks[i].frames.last_mut() {
                Some(f) => &mut f.locals,
                None => &mut self.globals,
            }
        }
    }

    fn indices(&mut self, i: usize, l: &LRef, sys: &mut dyn System) -> R<[i32; 3]> {
        if let Some(out) = self.simple_indices(i, l) {
            return Ok(out);
        }
        let mut out = [0i32; 3];
        match &*l.idx {
            [] => {}
            [a] => out[0] = self.index(i, l, a, sys)?,
            [a, b] => {
                out[0] = self.index(i, l, a, sys)?;
                out[1] = self.index(i, l, b, sys)?;
            }
            [a, b, c, ..] => {
                out[0] = self.index(i, l, a, sys)?;
                out[1] = self.index(i, l, b, sys)?;
                out[2] = self.index(i, l, c, sys)?;
            }
        }
        Ok(out)
    }

    /// The indices of `l` when each is a constant, a defined real scalar or the sum of two
    /// such (`.i+1`), finite and in range, read with one lookup of the task's locals; `None`
    /// otherwise (then [`Self::indices`] evaluates them in full, with the same values or
    /// its errors: these reads change nothing).
    #[inline]
    fn simple_indices(&self, i: usize, l: &LRef) -> Option<[i32; 3]> {
        let globals = &self.globals;
        let locals = match self.tasks.get(i)?.frames.last() {
            Some(f) => &f.locals,
            None => globals,
        };
        simple_index_list(globals, locals, &l.idx)
    }

    /// A real array element whose indices are [`Self::simple_indices`], when it exists
    /// (`None`: [`Self::read_r`] reads it in full, with its errors).
    #[inline]
    fn simple_element_r(&self, i: usize, l: &LRef) -> Option<f32> {
        let globals = &self.globals;
        let locals = match self.tasks.get(i)?.frames.last() {
            Some(f) => &f.locals,
            None => globals,
        };
        let idx = simple_index_list(globals, locals, &l.idx)?;
        let store = if l.var.global { globals } else { locals };
        store
            .reals
            .get(l.var.slot as usize)?
            .get(&idx[..l.idx.len().min(3)])
            .copied()
    }

    /// One array index of `l`: 0 to [`MAX_INDEX`] after truncation.
    #[inline(always)]
    fn index(&mut self, i: usize, l: &LRef, e: &RExpr, sys: &mut dyn System) -> R<i32> {
        // `.i+1`, the common computed index, is added here (as `eval_r` adds).
        let v = match e {
            RExpr::Bin(BinOp::Add, a, b) => {
                let x = self.operand_r(i, a, sys)?;
                let y = self.operand_r(i, b, sys)?;
                check(x + y, "+")?
            }
            _ => self.operand_r(i, e, sys)?,
        };
        // `0 <= trunc(v) <= MAX_INDEX` without a call of `truncf` (NaN fails both).
        if !(v > -1.0 && v < (MAX_INDEX + 1) as f32) {
            return Err(self.index_range(i, l, v));
        }
        Ok(v as i32)
    }

    #[cold]
    fn index_range(&self, i: usize, l: &LRef, v: f32) -> Box<RuntimeError> {
        Box::new(RuntimeError::IndexRange(format!(
            "{} in {}",
            v,
            self.lref_name(i, l, Ty::Real)
        )))
    }

    fn lref_name(&self, i: usize, l: &LRef, ty: Ty) -> String {
        let name = if l.var.global {
            self.code.global_name(ty, l.var.slot).to_owned()
        } else {
            self.tasks[i]
                .frames
                .last()
                .and_then(|f| self.code.programs.get(f.prog))
                .and_then(|p| p.local_names[ty as usize].get(l.var.slot as usize))
                .cloned()
                .unwrap_or_else(|| "?".into())
        };
        var_display(ty, l.var.global, &name)
    }

    fn undefined(&self, i: usize, l: &LRef, ty: Ty, idx: &[i32]) -> Box<RuntimeError> {
        let mut s = self.lref_name(i, l, ty);
        if !idx.is_empty() {
            let v: Vec<String> = idx.iter().map(|x| x.to_string()).collect();
            s.push_str(&format!("[{}]", v.join(",")));
        }
        Box::new(RuntimeError::Undefined(s))
    }

    fn count_element(&mut self, created: bool) -> R<()> {
        if created {
            self.elements += 1;
            if self.elements > MAX_ELEMENTS {
                return Err(Box::new(RuntimeError::MemoryFull(MAX_ELEMENTS)));
            }
        }
        Ok(())
    }

    /// A real scalar's value; `None` when it was never assigned.
    #[inline]
    fn scalar_r(&self, i: usize, var: VarRef) -> Option<f32> {
        let store = if var.global {
            &self.globals
        } else {
            match self.tasks[i].frames.last() {
                Some(f) => &f.locals,
                None => &self.globals,
            }
        };
        store.reals.get(var.slot as usize).and_then(|v| v.scalar)
    }

    /// A real operand: a constant or a scalar read in place (the common leaves of an
    /// expression and of array indices), anything else through the evaluator.
    #[inline(always)]
    fn operand_r(&mut self, i: usize, e: &RExpr, sys: &mut dyn System) -> R<f32> {
        match e {
            RExpr::Const(v) => Ok(*v),
            RExpr::Var(l) if l.idx.is_empty() => match self.scalar_r(i, l.var) {
                Some(v) => Ok(v),
                None => Err(self.undefined(i, l, Ty::Real, &[])),
            },
            _ => self.eval_r(i, e, sys),
        }
    }

    /// A real variable or element (a scalar read in place).
    #[inline(always)]
    fn operand_r_var(&mut self, i: usize, l: &LRef, sys: &mut dyn System) -> R<f32> {
        if l.idx.is_empty() {
            match self.scalar_r(i, l.var) {
                Some(v) => Ok(v),
                None => Err(self.undefined(i, l, Ty::Real, &[])),
            }
        } else {
            self.read_r(i, l, sys)
        }
    }

    fn read_r(&mut self, i: usize, l: &LRef, sys: &mut dyn System) -> R<f32> {
        if l.idx.is_empty() {
            let slot = l.var.slot as usize;
            return match self
                .store(i, l.var.global)
                .reals
                .get(slot)
                .and_then(|v| v.scalar)
            {
                Some(v) => Ok(v),
                None => Err(self.undefined(i, l, Ty::Real, &[])),
            };
        }
        if let Some(v) = self.simple_element_r(i, l) {
            return Ok(v);
        }
        let n = l.idx.len().min(3);
        let idx = self.indices(i, l, sys)?;
        let slot = l.var.slot as usize;
        match self
            .store(i, l.var.global)
            .reals
            .get(slot)
            .and_then(|v| v.get(&idx[..n]))
        {
            Some(v) => Ok(*v),
            None => Err(self.undefined(i, l, Ty::Real, &idx[..n])),
        }
    }

    fn write_r(&mut self, i: usize, l: &LRef, v: f32, sys: &mut dyn System) -> R<()> {
        if l.idx.is_empty() {
            if let Some(x) = self
                .store(i, l.var.global)
                .reals
                .get_mut(l.var.slot as usize)
            {
                x.scalar = Some(v);
            }
            return Ok(());
        }
        let n = l.idx.len().min(3);
        let idx = match self.simple_indices(i, l) {
            Some(idx) => idx,
            None => self.indices(i, l, sys)?,
        };
        self.write_r_at(i, l.var, &idx[..n], v)
    }

    #[inline]
    fn write_r_at(&mut self, i: usize, var: VarRef, idx: &[i32], v: f32) -> R<()> {
        let created = match self.store(i, var.global).reals.get_mut(var.slot as usize) {
            Some(x) => x.set(idx, v),
            None => false,
        };
        self.count_element(created)
    }

    /// `dst = $DECODE(src, d, mode)` for string scalars, constant delimiters and mode: what
    /// [`Self::eval_s`] and [`Self::write_s`] do (the rest is written to `src` first, then
    /// the token to `dst`; the same errors), without copies of the string's handle.
    fn decode_scalar(&mut self, i: usize, dst: &LRef, src: &LRef, d: &[u8], mode: f32) -> R<()> {
        let store = self.store(i, src.var.global);
        let Some(var) = store.strs.get_mut(src.var.slot as usize) else {
            return Err(self.undefined(i, src, Ty::Str, &[]));
        };
        let Some(s) = &var.scalar else {
            return Err(self.undefined(i, src, Ty::Str, &[]));
        };
        let text: &[u8] = s;
        let cut = decode_cut(text, d, mode).min(text.len());
        if text.len() - cut > MAX_STRING {
            return Err(Box::new(RuntimeError::StringTooLong(text.len() - cut)));
        }
        let Some(s) = var.scalar.take() else {
            return Err(self.undefined(i, src, Ty::Str, &[]));
        };
        let (head, rest) = s.split_off_head(cut);
        var.scalar = Some(rest);
        if head.len() > MAX_STRING {
            return Err(Box::new(RuntimeError::StringTooLong(head.len())));
        }
        // The token's variable, in the same scope (the usual case) without a second lookup.
        let strs = if dst.var.global == src.var.global {
            &mut store.strs
        } else {
            &mut self.store(i, dst.var.global).strs
        };
        if let Some(x) = strs.get_mut(dst.var.slot as usize) {
            x.scalar = Some(head);
        }
        Ok(())
    }

    fn read_s(&mut self, i: usize, l: &LRef, sys: &mut dyn System) -> R<Bytes> {
        if l.idx.is_empty() {
            let slot = l.var.slot as usize;
            return match self
                .store(i, l.var.global)
                .strs
                .get(slot)
                .and_then(|v| v.scalar.clone())
            {
                Some(v) => Ok(v),
                None => Err(self.undefined(i, l, Ty::Str, &[])),
            };
        }
        let n = l.idx.len().min(3);
        let idx = self.indices(i, l, sys)?;
        let slot = l.var.slot as usize;
        match self
            .store(i, l.var.global)
            .strs
            .get(slot)
            .and_then(|v| v.get(&idx[..n]))
        {
            Some(v) => Ok(v.clone()),
            None => Err(self.undefined(i, l, Ty::Str, &idx[..n])),
        }
    }

    fn write_s_at(&mut self, i: usize, var: VarRef, idx: &[i32], v: Bytes) -> R<()> {
        if v.len() > MAX_STRING {
            return Err(Box::new(RuntimeError::StringTooLong(v.len())));
        }
        let created = match self.store(i, var.global).strs.get_mut(var.slot as usize) {
            Some(x) => x.set(idx, v),
            None => false,
        };
        self.count_element(created)
    }

    fn write_s(&mut self, i: usize, l: &LRef, v: Bytes, sys: &mut dyn System) -> R<()> {
        if l.idx.is_empty() {
            if v.len() > MAX_STRING {
                return Err(Box::new(RuntimeError::StringTooLong(v.len())));
            }
            if let Some(x) = self
                .store(i, l.var.global)
                .strs
                .get_mut(l.var.slot as usize)
            {
                x.scalar = Some(v);
            }
            return Ok(());
        }
        let n = l.idx.len().min(3);
        let idx = self.indices(i, l, sys)?;
        self.write_s_at(i, l.var, &idx[..n], v)
    }

    fn read_loc_var(&mut self, i: usize, l: &LRef, ty: Ty, sys: &mut dyn System) -> R<[f32; 6]> {
        let n = l.idx.len().min(3);
        let idx = self.indices(i, l, sys)?;
        let slot = l.var.slot as usize;
        let store = self.store(i, l.var.global);
        let v = if ty == Ty::Joint {
            store
                .joints
                .get(slot)
                .and_then(|v| v.get(&idx[..n]))
                .copied()
        } else {
            store
                .trans
                .get(slot)
                .and_then(|v| v.get(&idx[..n]))
                .copied()
        };
        v.ok_or_else(|| self.undefined(i, l, ty, &idx[..n]))
    }

    fn write_loc_var(
        &mut self,
        i: usize,
        l: &LRef,
        ty: Ty,
        v: [f32; 6],
        sys: &mut dyn System,
    ) -> R<()> {
        let n = l.idx.len().min(3);
        let idx = self.indices(i, l, sys)?;
        let slot = l.var.slot as usize;
        let store = self.store(i, l.var.global);
        let created = if ty == Ty::Joint {
            store
                .joints
                .get_mut(slot)
                .is_some_and(|x| x.set(&idx[..n], v))
        } else {
            store
                .trans
                .get_mut(slot)
                .is_some_and(|x| x.set(&idx[..n], v))
        };
        self.count_element(created)
    }

    /// `VAL` of a string scalar, read in place.
    fn val_scalar(&self, i: usize, l: &LRef) -> R<f32> {
        let store = if l.var.global {
            &self.globals
        } else {
            match self.tasks[i].frames.last() {
                Some(f) => &f.locals,
                None => &self.globals,
            }
        };
        match store.strs.get(l.var.slot as usize) {
            Some(Var {
                scalar: Some(b), ..
            }) => val(b, 0.0),
            _ => Err(self.undefined(i, l, Ty::Str, &[])),
        }
    }

    fn hidden_r(&mut self, i: usize, slot: u32) -> f32 {
        let s = slot as usize;
        self.store(i, false)
            .reals
            .get(s)
            .and_then(|v| v.scalar)
            .unwrap_or(0.0)
    }

    fn set_hidden_r(&mut self, i: usize, slot: u32, v: f32) {
        if let Some(x) = self.store(i, false).reals.get_mut(slot as usize) {
            x.scalar = Some(v);
        }
    }

    // ------------------------------------------------------------------ signals

    fn signal_number_ok(n: i32, output: bool) -> bool {
        let n = n.abs();
        (1..=999).contains(&n)
            || (2001..=2960).contains(&n)
            || (!output && (1001..=1999).contains(&n))
    }

    fn write_signal(&mut self, n: i32, on: bool) {
        let now = self.now;
        let e = self.signals.entry(n).or_insert(SignalState {
            on: false,
            changed: 0,
        });
        if e.on != on {
            e.on = on;
            e.changed = now;
            self.int_epoch += 1;
        }
    }

    // ------------------------------------------------------------------ expressions

    /// [`Self::eval_r`] with a binary operation on constants and scalars in place (the
    /// usual statement: `.i == 1`, `.n = .n + 1`).
    #[inline(always)]
    fn eval_r_top(&mut self, i: usize, e: &RExpr, sys: &mut dyn System) -> R<f32> {
        match e {
            RExpr::Bin(op, a, b) => {
                let x = self.operand_r(i, a, sys)?;
                let y = self.operand_r(i, b, sys)?;
                bin_r(*op, x, y)
            }
            RExpr::Var(l) if !l.idx.is_empty() => match self.simple_element_r(i, l) {
                Some(v) => Ok(v),
                None => self.eval_r(i, e, sys),
            },
            _ => self.operand_r(i, e, sys),
        }
    }

    /// A real expression: constants, variables and arithmetic here (a small function), the
    /// rest in [`Self::eval_r_other`].
    fn eval_r(&mut self, i: usize, e: &RExpr, sys: &mut dyn System) -> R<f32> {
        match e {
            RExpr::Const(v) => Ok(*v),
            RExpr::Var(l) => self.operand_r_var(i, l, sys),
            RExpr::Bin(op, a, b) => {
                let x = self.operand_r(i, a, sys)?;
                // AND/OR evaluate both sides (AS has no short circuit).
                let y = self.operand_r(i, b, sys)?;
                bin_r(*op, x, y)
            }
            RExpr::Val(s, None) => match &**s {
                SExpr::Var(l) if l.idx.is_empty() => self.val_scalar(i, l),
                _ => self.eval_r_other(i, e, sys),
            },
            _ => self.eval_r_other(i, e, sys),
        }
    }

    #[inline(never)]
    fn eval_r_other(&mut self, i: usize, e: &RExpr, sys: &mut dyn System) -> R<f32> {
        Ok(match e {
            RExpr::Const(_) | RExpr::Var(_) | RExpr::Bin(..) => self.eval_r(i, e, sys)?,
            RExpr::Neg(a) => -self.eval_r(i, a, sys)?,
            RExpr::Not(a) => as_bool(!truthy(self.eval_r(i, a, sys)?)),
            RExpr::Com(a) => !to_i32(self.eval_r(i, a, sys)?) as f32,
            RExpr::StrCmp(op, a, b) => {
                let x = self.eval_s(i, a, sys)?;
                let y = self.eval_s(i, b, sys)?;
                let o = (*x).cmp(&*y);
                as_bool(match op {
                    BinOp::Eq => o.is_eq(),
                    BinOp::Ne => o.is_ne(),
                    BinOp::Lt => o.is_lt(),
                    BinOp::Gt => o.is_gt(),
                    BinOp::Le => o.is_le(),
                    _ => o.is_ge(),
                })
            }
            RExpr::Func(f, args) => self.eval_func(i, *f, args, sys)?,
            RExpr::Val(s, radix) => {
                // VAL of a string scalar (the server's tokens) reads it in place.
                if let (SExpr::Var(l), None) = (&**s, radix) {
                    if l.idx.is_empty() {
                        return self.val_scalar(i, l);
                    }
                }
                let s = self.eval_s(i, s, sys)?;
                let radix = match radix {
                    Some(r) => self.eval_r(i, r, sys)?,
                    None => 0.0,
                };
                val(&s, radix)?
            }
            RExpr::Len(s) => self.eval_s(i, s, sys)?.len() as f32,
            RExpr::Asc(s, n) => {
                let s = self.eval_s(i, s, sys)?;
                let n = match n {
                    Some(n) => self.eval_r(i, n, sys)?.trunc() as i64,
                    None => 1,
                };
                if n >= 1 && (n as usize) <= s.len() {
                    f32::from(s[n as usize - 1])
                } else {
                    -1.0
                }
            }
            RExpr::Instr(start, s, sub) => {
                let start = match start {
                    Some(x) => self.eval_r(i, x, sys)?.trunc().max(1.0) as usize,
                    None => 1,
                };
                let s = self.eval_s(i, s, sys)?;
                let sub = self.eval_s(i, sub, sys)?;
                instr(&s, &sub, start) as f32
            }
            RExpr::Dext(l, n) => {
                let v = match self.eval_loc(i, l, sys)? {
                    LocVal::J(v) | LocVal::T(v) => v,
                };
                let n = self.eval_r(i, n, sys)?.trunc();
                if !(1.0..=6.0).contains(&n) {
                    return Err(Box::new(RuntimeError::IllegalValue(format!(
                        "DEXT element {n} (1 to 6)"
                    ))));
                }
                v[n as usize - 1]
            }
            RExpr::Switch(s) => {
                let p = sys.panel();
                as_bool(match s {
                    SwitchRef::Power => p.power,
                    SwitchRef::Run => p.run,
                    SwitchRef::Repeat => p.repeat,
                    SwitchRef::TeachLock => p.teach_lock,
                    SwitchRef::CycleStart => self.tasks[0].run == Run::Running,
                    SwitchRef::InError => !sys.error().is_none(),
                    SwitchRef::System(k) => self.switches.get(*k).copied().unwrap_or(false),
                })
            }
            RExpr::Error => sys.error().raw() as f32,
        })
    }

    fn eval_func(&mut self, i: usize, f: RFunc, args: &[RExpr], sys: &mut dyn System) -> R<f32> {
        let mut v = [0f32; 32];
        let n = args.len().min(32);
        for (k, a) in args.iter().enumerate().take(32) {
            v[k] = self.eval_r(i, a, sys)?;
        }
        let x = v[0];
        Ok(match f {
            RFunc::Abs => x.abs(),
            RFunc::Sqrt => {
                if x < 0.0 {
                    return Err(Box::new(RuntimeError::IllegalValue(format!("SQRT({x})"))));
                }
                x.sqrt()
            }
            RFunc::Sin => (f64::from(x).to_radians().sin()) as f32,
            RFunc::Cos => (f64::from(x).to_radians().cos()) as f32,
            RFunc::Tan => check(f64::from(x).to_radians().tan() as f32, "TAN")?,
            RFunc::Atan2 => (f64::from(x).atan2(f64::from(v[1])).to_degrees()) as f32,
            RFunc::Int => x.trunc(),
            RFunc::MaxVal => v[..n].iter().copied().fold(f32::NEG_INFINITY, f32::max),
            RFunc::MinVal => v[..n].iter().copied().fold(f32::INFINITY, f32::min),
            RFunc::Sig => {
                let mut all = true;
                for s in &v[..n] {
                    let s = signal_number(*s);
                    if s == 0 || !Self::signal_number_ok(s, false) {
                        return Err(Box::new(RuntimeError::IllegalValue(format!(
                            "signal number {s}"
                        ))));
                    }
                    all &= self.signal(s.abs()) == (s > 0);
                }
                as_bool(all)
            }
            RFunc::Task => {
                let id = match x.trunc() as i64 {
                    1 => Some(TaskId::Robot),
                    n @ 1001..=1005 => Some(TaskId::Pc((n - 1000) as u8)),
                    _ => None,
                };
                match id {
                    Some(id) => {
                        if id == TaskId::Robot
                            && self.tasks[0].run == Run::Ending
                            && !sys.motion_in_progress()
                        {
                            self.set_run(0, Run::Idle);
                        }
                        self.task_state(id, sys).number()
                    }
                    None => 0.0,
                }
            }
            RFunc::Timer => {
                let n = x.trunc();
                if !(0.0..=10.0).contains(&n) {
                    return Err(Box::new(RuntimeError::IllegalValue(format!(
                        "TIMER({x}) (0 to 10)"
                    ))));
                }
                let since = if n == 0.0 {
                    Some(0)
                } else {
                    self.timers[n as usize]
                };
                match since {
                    Some(s) => {
                        // 1 ms resolution, truncated.
                        let ms = (i128::from(self.now) - s).div_euclid(1_000_000);
                        (ms as f64 / 1000.0) as f32
                    }
                    None => 0.0,
                }
            }
        })
    }

    fn eval_s(&mut self, i: usize, e: &SExpr, sys: &mut dyn System) -> R<Bytes> {
        Ok(match e {
            SExpr::Const(b) => b.clone(),
            SExpr::Var(l) => self.read_s(i, l, sys)?,
            SExpr::Concat(a, b) => {
                let x = self.eval_s(i, a, sys)?;
                let y = self.eval_s(i, b, sys)?;
                if x.len() + y.len() > MAX_STRING {
                    return Err(Box::new(RuntimeError::StringTooLong(x.len() + y.len())));
                }
                let mut v = Vec::with_capacity(x.len() + y.len());
                v.extend_from_slice(&x);
                v.extend_from_slice(&y);
                v.into()
            }
            SExpr::Mid(s, start, n) => {
                let s = self.eval_s(i, s, sys)?;
                let start = self.eval_r(i, start, sys)?.trunc();
                let n = match n {
                    Some(n) => Some(self.eval_r(i, n, sys)?.trunc()),
                    None => None,
                };
                if start < 1.0 || n.is_some_and(|n| n < 0.0) {
                    return Err(Box::new(RuntimeError::IllegalValue(format!(
                        "$MID start {start} (from 1), count {}",
                        n.unwrap_or(0.0)
                    ))));
                }
                let a = (start as usize - 1).min(s.len());
                let b = match n {
                    Some(n) => a.saturating_add(n as usize).min(s.len()),
                    None => s.len(),
                };
                s.slice(a, b)
            }
            SExpr::Left(s, n) | SExpr::Right(s, n) => {
                let s = self.eval_s(i, s, sys)?;
                let n = self.eval_r(i, n, sys)?.trunc();
                if n < 0.0 {
                    return Err(Box::new(RuntimeError::IllegalValue(format!("count {n}"))));
                }
                let n = (n as usize).min(s.len());
                if matches!(e, SExpr::Left(..)) {
                    s.slice(0, n)
                } else {
                    s.slice(s.len() - n, s.len())
                }
            }
            SExpr::Chr(n) => {
                let n = self.eval_r(i, n, sys)?.trunc();
                if !(0.0..=255.0).contains(&n) {
                    return Err(Box::new(RuntimeError::IllegalValue(format!(
                        "$CHR({n}) (0 to 255)"
                    ))));
                }
                Bytes::from(&[n as u8][..])
            }
            SExpr::Encode(items) => {
                let (bytes, _) = self.encode(i, items, sys)?;
                if bytes.len() > MAX_STRING {
                    return Err(Box::new(RuntimeError::StringTooLong(bytes.len())));
                }
                bytes.into()
            }
            SExpr::Decode(var, delims, mode) => {
                let s = self.read_s(i, var, sys)?;
                // Constant delimiters (the usual case) are used in place.
                let evaluated;
                let d: &[u8] = match &**delims {
                    SExpr::Const(b) => b,
                    other => {
                        evaluated = self.eval_s(i, other, sys)?;
                        &evaluated
                    }
                };
                let mode = self.eval_r(i, mode, sys)?;
                let cut = decode_cut(&s, d, mode);
                let (head, rest) = s.split_off_head(cut);
                self.write_s(i, var, rest, sys)?;
                head
            }
            SExpr::ErrorMsg(code) => {
                let c = self.eval_r(i, code, sys)?.trunc() as i32;
                let text = match error_message(c) {
                    Some(m) => m.to_owned(),
                    None if c == 0 => String::new(),
                    None => format!("Error {}", ErrorCode(c)),
                };
                Bytes::from(text.as_bytes())
            }
        })
    }

    fn eval_loc(&mut self, i: usize, l: &Loc, sys: &mut dyn System) -> R<LocVal> {
        Ok(match l {
            Loc::J(j) => LocVal::J(self.eval_j(i, j, sys)?),
            Loc::T(t) => LocVal::T(self.eval_t(i, t, sys)?),
        })
    }

    fn eval_j(&mut self, i: usize, e: &JExpr, sys: &mut dyn System) -> R<[f32; 6]> {
        Ok(match e {
            JExpr::Var(l) => self.read_loc_var(i, l, Ty::Joint, sys)?,
            JExpr::PPoint(args) => {
                let mut v = [0f32; 6];
                for (k, a) in args.iter().enumerate().take(6) {
                    v[k] = self.eval_r(i, a, sys)?;
                }
                v
            }
            JExpr::Here => sys.joints().map(|x| x as f32),
        })
    }

    fn eval_t(&mut self, i: usize, e: &TExpr, sys: &mut dyn System) -> R<[f32; 6]> {
        Ok(match e {
            TExpr::Var(l) => self.read_loc_var(i, l, Ty::Trans, sys)?,
            TExpr::Trans(args) => {
                let mut v = [0f32; 6];
                for (k, a) in args.iter().enumerate().take(6) {
                    v[k] = self.eval_r(i, a, sys)?;
                }
                v
            }
            TExpr::Here => match sys.pose() {
                Some(p) => p.map(|x| x as f32),
                None => {
                    return Err(Box::new(RuntimeError::IllegalValue(
                        "HERE: this controller has no kinematics".into(),
                    )))
                }
            },
            TExpr::Compose(a, b) => {
                let x = self.eval_t(i, a, sys)?;
                let y = self.eval_t(i, b, sys)?;
                let px = Pose::from_xyzoat(xyzoat(&x));
                let py = Pose::from_xyzoat(xyzoat(&y));
                let r = (px * py).to_xyzoat();
                [r.x_mm, r.y_mm, r.z_mm, r.o_deg, r.a_deg, r.t_deg].map(|v| v as f32)
            }
        })
    }

    /// Formats PRINT/$ENCODE items: the bytes (line feeds for `/C`) and whether `/S` was given.
    fn encode(&mut self, i: usize, items: &[Item], sys: &mut dyn System) -> R<(Vec<u8>, bool)> {
        // Room for the usual items (a number takes up to a dozen characters): no regrowth.
        let mut out = String::with_capacity(16 * items.len());
        let mut bytes = Vec::new();
        let mut current = FormatCode::D;
        let mut no_newline = false;
        for item in items {
            match item {
                Item::Format(f) => match f {
                    FormatCode::X(n) => out.extend(std::iter::repeat_n(' ', usize::from(*n))),
                    FormatCode::C(n) => out.extend(std::iter::repeat_n('\n', usize::from(*n))),
                    FormatCode::S => no_newline = true,
                    other => current = *other,
                },
                Item::Real(e) => {
                    let v = f64::from(self.eval_r(i, e, sys)?);
                    match current {
                        FormatCode::D => {
                            out.push(' ');
                            fmt::push_default(&mut out, v);
                        }
                        FormatCode::L => fmt::push_default(&mut out, v),
                        FormatCode::F(w, d) => {
                            fmt::push_fixed(&mut out, v, usize::from(w), usize::from(d))
                        }
                        FormatCode::E(w, d) => {
                            fmt::push_exponent(&mut out, v, usize::from(w), usize::from(d))
                        }
                        FormatCode::G(w, d) => {
                            fmt::push_general(&mut out, v, usize::from(w), usize::from(d))
                        }
                        FormatCode::I(w) => fmt::push_integer(&mut out, v, usize::from(w), false),
                        FormatCode::K(w) => fmt::push_integer(&mut out, v, usize::from(w), true),
                        FormatCode::H(w) => fmt::push_hex(&mut out, v, usize::from(w), false),
                        FormatCode::J(w) => fmt::push_hex(&mut out, v, usize::from(w), true),
                        FormatCode::X(_) | FormatCode::C(_) | FormatCode::S => {}
                    }
                }
                Item::Str(e) => {
                    let s = self.eval_s(i, e, sys)?;
                    bytes.extend_from_slice(out.as_bytes());
                    out.clear();
                    bytes.extend_from_slice(&s);
                }
            }
            if out.len() + bytes.len() > 64 * 1024 {
                return Err(Box::new(RuntimeError::StringTooLong(
                    out.len() + bytes.len(),
                )));
            }
        }
        if bytes.is_empty() {
            // Numbers and formats only: the text is the result.
            return Ok((out.into_bytes(), no_newline));
        }
        bytes.extend_from_slice(out.as_bytes());
        Ok((bytes, no_newline))
    }

    // ------------------------------------------------------------------ statements

    /// Runs one step of task `i` at `self.now`: the op at `pc` of program `p`, the task's
    /// current frame (`None`: no frame or no such program).
    #[allow(clippy::too_many_arguments)]
    fn step(
        &mut self,
        i: usize,
        sys: &mut dyn System,
        code: &Code,
        sync: bool,
        checked: bool,
        p: Option<&CProgram>,
        pc: usize,
    ) -> R<Flow> {
        if i == 0 && sync {
            // (`checked`: the poll just did this at this time.)
            if !checked && !self.robot_allowed(sys) {
                return Ok(Flow::Next);
            }
            if self.mc_hold || !sys.panel().run {
                return Ok(Flow::Wait(Box::new(Wait::Held)));
            }
        }
        let Some(p) = p else {
            self.abort(TaskId::from_index(i));
            return Ok(Flow::Next);
        };
        let Some(op) = p.ops.get(pc) else {
            self.end_program(i, sys, true);
            return Ok(Flow::Next);
        };
        let now = self.now;
        if self.trace.is_some() && !matches!(op, Op::Jump(_)) {
            self.trace_step(i, code, p, pc, now);
        }
        // By default the next step is the following op.
        let t = &mut self.tasks[i];
        t.steps += 1;
        let depth = t.frames.len();
        if let Some(f) = t.frames.last_mut() {
            f.pc = pc + 1;
        }
        let r = self.exec(i, sys, code, op, pc, now, self.stmt_ns);
        if r.is_err() && self.tasks[i].frames.len() == depth {
            // Errors name the step that failed.
            self.set_pc(i, pc);
        }
        r
    }

    #[cold]
    fn trace_step(&mut self, i: usize, code: &Code, p: &CProgram, pc: usize, now: Ns) {
        let id = self.tasks[i].id;
        let Some(trace) = &mut self.trace else { return };
        let line = p.lines.get(pc).copied().unwrap_or(0);
        let prog = code
            .programs
            .iter()
            .position(|q| std::ptr::eq(q, p))
            .unwrap_or(usize::MAX);
        trace.push(TraceLine {
            at: Duration::from_nanos(now),
            task: id,
            program: p.name.clone(),
            line,
            text: code.line_text(prog, line).to_owned(),
        });
        if trace.len() > 1_000_000 {
            trace.drain(..trace.len() / 2);
        }
    }

    // The step's context (program, pc, time, cost) travels as arguments: the hot path.
    /// One step's op (the task's pc already points after it).
    #[allow(clippy::too_many_arguments)]
    #[inline]
    fn exec(
        &mut self,
        i: usize,
        sys: &mut dyn System,
        code: &Code,
        op: &Op,
        pc: usize,
        now: Ns,
        cost: Ns,
    ) -> R<Flow> {
        match self.exec_hot(i, sys, op, pc)? {
            NOT_PURE => self.exec_other(i, sys, code, op, pc, now, cost),
            next => {
                let t = &mut self.tasks[i];
                if let Some(f) = t.frames.last_mut() {
                    f.pc = next;
                }
                t.ready_at = now.saturating_add(cost);
                Ok(Flow::Next)
            }
        }
    }

    /// The ops of pure computation (assignments, jumps, FOR), which change nothing but
    /// variables: the pc of the next step, [`NOT_PURE`] (nothing done) for any other op. The
    /// caller sets the pc and the task's time.
    #[inline(always)]
    fn exec_hot(&mut self, i: usize, sys: &mut dyn System, op: &Op, pc: usize) -> R<usize> {
        Ok(match op {
            Op::AssignR(l, e) => {
                let v = self.eval_r_top(i, e, sys)?;
                self.write_r(i, l, v, sys)?;
                pc + 1
            }
            Op::AssignS(l, e) => {
                match e {
                    // `.$tok = $DECODE(.$data, " ", 0)`: the server's tokenizer, in place.
                    SExpr::Decode(var, delims, mode) if l.idx.is_empty() && var.idx.is_empty() => {
                        if let (SExpr::Const(d), RExpr::Const(m)) = (&**delims, &**mode) {
                            self.decode_scalar(i, l, var, d, *m)?;
                            return Ok(pc + 1);
                        }
                    }
                    _ => {}
                }
                let v = self.eval_s(i, e, sys)?;
                self.write_s(i, l, v, sys)?;
                pc + 1
            }
            Op::Jump(t) => *t,
            Op::JumpIfNot(c, t) => {
                if truthy(self.eval_r_top(i, c, sys)?) {
                    pc + 1
                } else {
                    *t
                }
            }
            Op::JumpIf(c, t) => {
                if truthy(self.eval_r_top(i, c, sys)?) {
                    *t
                } else {
                    pc + 1
                }
            }
            Op::ForInit {
                var,
                from,
                to,
                step,
                limit,
                step_slot,
                exit,
            } => {
                let from = self.eval_r(i, from, sys)?;
                let to = self.eval_r(i, to, sys)?;
                let step = match step {
                    Some(s) => self.eval_r(i, s, sys)?,
                    None => 1.0,
                };
                if step == 0.0 {
                    return Err(Box::new(RuntimeError::IllegalValue("FOR … STEP 0".into())));
                }
                self.write_r(i, var, from, sys)?;
                self.set_hidden_r(i, *limit, to);
                self.set_hidden_r(i, *step_slot, step);
                if (step > 0.0 && from > to) || (step < 0.0 && from < to) {
                    *exit
                } else {
                    pc + 1
                }
            }
            Op::ForNext {
                var,
                limit,
                step_slot,
                body,
            } if var.idx.is_empty() && !var.var.global => {
                // A local scalar counter: the counter, limit and step in one lookup of the
                // frame's reals.
                let reals = &mut self.store(i, false).reals;
                let scalar = |k: u32| reals.get(k as usize).and_then(|v| v.scalar);
                let step = scalar(*step_slot).unwrap_or(0.0);
                let to = scalar(*limit).unwrap_or(0.0);
                let Some(cur) = scalar(var.var.slot) else {
                    return Err(self.undefined(i, var, Ty::Real, &[]));
                };
                let v = check(cur + step, "FOR")?;
                if let Some(x) = reals.get_mut(var.var.slot as usize) {
                    x.scalar = Some(v);
                }
                if (step > 0.0 && v <= to) || (step < 0.0 && v >= to) {
                    *body
                } else {
                    pc + 1
                }
            }
            Op::ForNext {
                var,
                limit,
                step_slot,
                body,
            } => {
                let step = self.hidden_r(i, *step_slot);
                let to = self.hidden_r(i, *limit);
                let v = check(self.read_r(i, var, sys)? + step, "FOR")?;
                self.write_r(i, var, v, sys)?;
                if (step > 0.0 && v <= to) || (step < 0.0 && v >= to) {
                    *body
                } else {
                    pc + 1
                }
            }
            _ => NOT_PURE,
        })
    }

    /// The ops [`Self::exec`] leaves to this function.
    #[allow(clippy::too_many_arguments)]
    #[inline(never)]
    fn exec_other(
        &mut self,
        i: usize,
        sys: &mut dyn System,
        code: &Code,
        op: &Op,
        pc: usize,
        now: Ns,
        mut cost: Ns,
    ) -> R<Flow> {
        let robot = i == 0;
        let flow = match op {
            Op::Nop => Flow::Next,
            Op::NotEmulated(instr) => {
                return Err(Box::new(RuntimeError::NotEmulated(instr.to_string())))
            }
            Op::AssignR(..)
            | Op::AssignS(..)
            | Op::Jump(_)
            | Op::JumpIfNot(..)
            | Op::JumpIf(..)
            | Op::ForInit { .. }
            | Op::ForNext { .. } => return self.exec(i, sys, code, op, pc, now, cost),
            Op::AssignJ(l, e) => {
                let v = self.eval_j(i, e, sys)?;
                self.write_loc_var(i, l, Ty::Joint, v, sys)?;
                Flow::Next
            }
            Op::AssignT(l, e) => {
                let v = self.eval_t(i, e, sys)?;
                self.write_loc_var(i, l, Ty::Trans, v, sys)?;
                Flow::Next
            }
            Op::CaseSelR(e, slot) => {
                let v = self.eval_r(i, e, sys)?;
                self.set_hidden_r(i, *slot, v);
                Flow::Next
            }
            Op::CaseSelS(e, slot) => {
                let v = self.eval_s(i, e, sys)?;
                if let Some(x) = self.store(i, false).strs.get_mut(*slot as usize) {
                    x.set(&[], v);
                }
                Flow::Next
            }
            Op::CaseTestR(values, slot, next) => {
                let sel = self.hidden_r(i, *slot);
                let mut hit = false;
                for v in values.iter() {
                    if self.eval_r(i, v, sys)? == sel {
                        hit = true;
                        break;
                    }
                }
                if !hit {
                    self.set_pc(i, *next);
                }
                Flow::Next
            }
            Op::CaseTestS(values, slot, next) => {
                let sel = self
                    .store(i, false)
                    .strs
                    .get(*slot as usize)
                    .and_then(|v| v.get(&[]))
                    .cloned()
                    .unwrap_or_else(|| Bytes::from(&b""[..]));
                let mut hit = false;
                for v in values.iter() {
                    if self.eval_s(i, v, sys)? == sel {
                        hit = true;
                        break;
                    }
                }
                if !hit {
                    self.set_pc(i, *next);
                }
                Flow::Next
            }
            Op::Call(prog, args) => {
                let args = self.eval_args(i, args, sys)?;
                // The caller resumes after the CALL.
                self.push_frame(i, *prog, &args)?;
                Flow::Next
            }
            Op::Return | Op::End => {
                self.ret(i, sys)?;
                Flow::Next
            }
            Op::Print(items) => {
                let (bytes, no_newline) = self.encode(i, items, sys)?;
                cost = cost.saturating_add(ns(self.cfg.cost.print
                    + self.cfg.cost.print_per_byte * bytes.len().min(100_000) as u32));
                let text = String::from_utf8_lossy(&bytes).into_owned();
                let id = self.tasks[i].id;
                let mut parts: Vec<&str> = text.split('\n').collect();
                let last = parts.pop().unwrap_or("");
                for part in parts {
                    let mut line = std::mem::take(&mut self.tasks[i].line_buf);
                    line.push_str(part);
                    self.message(sys, id, line);
                }
                self.tasks[i].line_buf.push_str(last);
                // A line ends unless /S says otherwise (and never grows without bound).
                if !no_newline || self.tasks[i].line_buf.len() > 4096 {
                    let line = std::mem::take(&mut self.tasks[i].line_buf);
                    self.message(sys, id, line);
                }
                Flow::Next
            }
            Op::Twait(e) => {
                let d = secs(self.eval_r(i, e, sys)?, "TWAIT")?;
                Flow::Wait(Box::new(Wait::Until(now.saturating_add(ns(d)))))
            }
            Op::Wait(e) => {
                if truthy(self.eval_r(i, e, sys)?) {
                    Flow::Next
                } else {
                    self.set_pc(i, pc);
                    Flow::Wait(Box::new(Wait::Cond))
                }
            }
            Op::Halt | Op::Stop => {
                self.end_program(i, sys, false);
                Flow::Next
            }
            Op::Pause => Flow::Wait(Box::new(Wait::Paused)),
            Op::Signal(v) => {
                for e in v.iter() {
                    let s = signal_number(self.eval_r(i, e, sys)?);
                    if s == 0 || !Self::signal_number_ok(s, true) {
                        return Err(Box::new(RuntimeError::IllegalValue(format!(
                            "SIGNAL {s} (outputs 1–999, internal 2001–2960)"
                        ))));
                    }
                    self.write_signal(s.abs(), s > 0);
                }
                Flow::Shared
            }
            Op::On {
                immediate,
                signal,
                goto,
                call,
            } => {
                if *immediate && !robot {
                    return Err(Box::new(RuntimeError::WrongTask(
                        "ONI is allowed only in robot programs".into(),
                    )));
                }
                let s = signal_number(self.eval_r(i, signal, sys)?);
                if s == 0 || !Self::signal_number_ok(s, false) {
                    return Err(Box::new(RuntimeError::IllegalValue(format!(
                        "signal number {s}"
                    ))));
                }
                let depth = self.tasks[i].frames.len();
                let t = &mut self.tasks[i];
                t.interrupts.retain(|x| x.signal.abs() != s.abs());
                t.interrupts.push(Interrupt {
                    signal: s,
                    immediate: *immediate,
                    goto: *goto,
                    call: *call,
                    depth,
                    armed_at: now,
                });
                self.int_epoch += 1;
                Flow::Next
            }
            Op::Ignore(e) => {
                let s = signal_number(self.eval_r(i, e, sys)?);
                self.tasks[i]
                    .interrupts
                    .retain(|x| x.signal.abs() != s.abs());
                self.int_epoch += 1;
                Flow::Next
            }
            Op::Execute {
                program,
                args,
                cycles,
            } => {
                if robot {
                    return Err(Box::new(RuntimeError::WrongTask(
                        "EXECUTE/MC is allowed only in PC programs".into(),
                    )));
                }
                let args = self.eval_args(i, args, sys)?;
                let cycles = match cycles {
                    Some(c) => self.eval_r(i, c, sys)?.trunc() as i64,
                    None => 1,
                };
                if let Err(r) = self.execute_robot(*program, args, cycles, sys) {
                    let id = self.tasks[i].id;
                    self.message(
                        sys,
                        id,
                        format!("EXECUTE {}: {r}", code.programs[*program].name),
                    );
                }
                Flow::Shared
            }
            Op::PcExecute {
                task,
                program,
                args,
                cycles,
            } => {
                let n = match task {
                    Some(t) => self.eval_r(i, t, sys)?.trunc(),
                    None => 1.0,
                };
                let args = self.eval_args(i, args, sys)?;
                let cycles = match cycles {
                    Some(c) => self.eval_r(i, c, sys)?.trunc() as i64,
                    None => 1,
                };
                if let Err(r) =
                    self.pc_execute_at(n.clamp(0.0, 255.0) as u8, *program, args, cycles)
                {
                    let id = self.tasks[i].id;
                    self.message(
                        sys,
                        id,
                        format!("PCEXECUTE {}: {r}", code.programs[*program].name),
                    );
                }
                Flow::Shared
            }
            Op::PcAbort(task) => {
                let n = match task {
                    Some(t) => self.eval_r(i, t, sys)?.trunc(),
                    None => 1.0,
                };
                if (1.0..=5.0).contains(&n) {
                    self.abort(TaskId::Pc(n as u8));
                }
                Flow::Shared
            }
            Op::McAbort | Op::McHold | Op::McContinue | Op::McSpeed(_) | Op::McEreset if robot => {
                return Err(Box::new(RuntimeError::WrongTask(
                    "MC is allowed only in PC programs".into(),
                )));
            }
            Op::McAbort => {
                if self.tasks[0].run == Run::Running {
                    self.end_program(0, sys, false);
                }
                Flow::Shared
            }
            Op::McHold => {
                self.mc_hold = true;
                sys.set_program_hold(true);
                Flow::Shared
            }
            Op::McContinue => {
                self.mc_hold = false;
                sys.set_program_hold(false);
                if matches!(self.tasks[0].wait, Some(Wait::Paused)) {
                    self.tasks[0].wait = None;
                    self.tasks[0].ready_at = now;
                }
                Flow::Shared
            }
            Op::McSpeed(e) => {
                let v = self.eval_r(i, e, sys)?;
                if let Err(why) = sys.set_monitor_speed(f64::from(v)) {
                    let id = self.tasks[i].id;
                    self.message(sys, id, format!("MC SPEED {v}: {why}"));
                }
                Flow::Shared
            }
            Op::McEreset => {
                if let Err(why) = sys.reset_error() {
                    let id = self.tasks[i].id;
                    self.message(sys, id, format!("MC ERESET: {why}"));
                }
                Flow::Shared
            }
            Op::SetSwitch(k, on) => {
                if let Some(s) = self.switches.get_mut(*k) {
                    *s = *on;
                }
                Flow::Next
            }
            Op::Timer(n, v) => {
                let n = self.eval_r(i, n, sys)?.trunc();
                let v = self.eval_r(i, v, sys)?;
                if !(1.0..=10.0).contains(&n) {
                    return Err(Box::new(RuntimeError::IllegalValue(format!(
                        "TIMER {n} (1 to 10)"
                    ))));
                }
                let offset = (f64::from(v).clamp(-1.0e9, 1.0e9) * 1e9) as i128;
                self.timers[n as usize] = Some(i128::from(now) - offset);
                Flow::Next
            }
            Op::Decompose(target, l) => {
                let v = match self.eval_loc(i, l, sys)? {
                    LocVal::J(v) | LocVal::T(v) => v,
                };
                let n = target.idx.len().min(3);
                let idx = self.indices(i, target, sys)?;
                let dims = n.max(1);
                for (k, x) in v.iter().enumerate() {
                    let mut at = idx;
                    at[0] = idx[0] + k as i32;
                    if at[0] > MAX_INDEX {
                        return Err(Box::new(RuntimeError::IndexRange(format!(
                            "DECOMPOSE beyond index {MAX_INDEX}"
                        ))));
                    }
                    self.write_r_at(i, target.var, &at[..dims], *x)?;
                }
                Flow::Next
            }
            Op::HereJ(l) => {
                let v = sys.joints().map(|x| x as f32);
                self.write_loc_var(i, l, Ty::Joint, v, sys)?;
                Flow::Next
            }
            Op::HereT(l) => {
                let Some(p) = sys.pose() else {
                    return Err(Box::new(RuntimeError::IllegalValue(
                        "HERE: this controller has no kinematics".into(),
                    )));
                };
                self.write_loc_var(i, l, Ty::Trans, p.map(|x| x as f32), sys)?;
                Flow::Next
            }
            Op::Move(linear, l) => {
                self.require_robot(robot, "JMOVE/LMOVE")?;
                let target = match self.eval_loc(i, l, sys)? {
                    LocVal::J(v) => Target::Joints(v.map(f64::from)),
                    LocVal::T(v) => Target::Pose(v.map(f64::from)),
                };
                let kind = if *linear {
                    MotionKind::Linear
                } else {
                    MotionKind::Joint
                };
                self.motion(i, kind, target, 0.0, sys)?
            }
            Op::Home => {
                self.require_robot(robot, "HOME")?;
                let home = sys.home();
                self.motion(i, MotionKind::Joint, Target::Joints(home), 0.0, sys)?
            }
            Op::Delay(e) => {
                self.require_robot(robot, "DELAY")?;
                let d = self.eval_r(i, e, sys)?;
                if !(d.is_finite() && d >= 0.0) {
                    return Err(Box::new(RuntimeError::IllegalValue(format!("DELAY {d}"))));
                }
                let here = Target::Joints(sys.joints());
                self.motion(i, MotionKind::Delay, here, f64::from(d), sys)?
            }
            Op::Brake => {
                sys.brake();
                Flow::Shared
            }
            Op::Break => {
                self.require_robot(robot, "BREAK")?;
                if sys.motion_in_progress() {
                    Flow::Wait(Box::new(Wait::MotionDone))
                } else {
                    Flow::Next
                }
            }
            Op::Speed(e, unit, always) => {
                let v = self.eval_r(i, e, sys)?;
                let v = f64::from(v);
                let speed = match unit {
                    SpeedUnit::Percent => Speed::Percent(v.clamp(0.01, 100.0)),
                    other => {
                        if !(v.is_finite() && v > 0.0) {
                            return Err(Box::new(RuntimeError::IllegalValue(format!("SPEED {v}"))));
                        }
                        match other {
                            SpeedUnit::MmPerS => Speed::MmPerS(v),
                            SpeedUnit::MmPerMin => Speed::MmPerS(v / 60.0),
                            _ => Speed::Seconds(v),
                        }
                    }
                };
                let m = &mut self.tasks[i].motion;
                if *always {
                    m.speed = speed;
                    m.speed_once = None;
                } else {
                    m.speed_once = Some(speed);
                }
                Flow::Next
            }
            Op::Accuracy(e, fine, always) => {
                let v = f64::from(self.eval_r(i, e, sys)?);
                if !(v.is_finite() && v >= 0.0) {
                    return Err(Box::new(RuntimeError::IllegalValue(format!(
                        "ACCURACY {v}"
                    ))));
                }
                let m = &mut self.tasks[i].motion;
                if *always {
                    m.accuracy = (v, *fine);
                    m.accuracy_once = None;
                } else {
                    m.accuracy_once = Some((v, *fine));
                }
                Flow::Next
            }
            Op::AccelDecel(decel, e, always) => {
                let v = f64::from(self.eval_r(i, e, sys)?).clamp(0.01, 100.0);
                let m = &mut self.tasks[i].motion;
                match (decel, always) {
                    (false, true) => {
                        m.accel = v;
                        m.accel_once = None;
                    }
                    (false, false) => m.accel_once = Some(v),
                    (true, true) => {
                        m.decel = v;
                        m.decel_once = None;
                    }
                    (true, false) => m.decel_once = Some(v),
                }
                Flow::Next
            }
            Op::Cp(on) => {
                if let Some(k) = SYSTEM_SWITCHES.iter().position(|(n, _)| *n == "cp") {
                    self.switches[k] = *on;
                }
                Flow::Next
            }
            Op::TcpListen(ret, port) => {
                let port = self.port(i, port, sys)?;
                let r = sys.tcp_listen(port);
                self.write_r(i, ret, r as f32, sys)?;
                Flow::Shared
            }
            Op::TcpEndListen(ret, port) => {
                let port = self.port(i, port, sys)?;
                let r = sys.tcp_end_listen(port);
                self.write_r(i, ret, r as f32, sys)?;
                Flow::Shared
            }
            Op::TcpAccept { port, timeout, .. } => {
                let port = self.port(i, port, sys)?;
                let deadline = now.saturating_add(ns(self.timeout(i, timeout.as_ref(), sys)?));
                self.set_pc(i, pc);
                match sys.tcp_accept(port) {
                    SockPoll::Ready(r) => {
                        self.finish_accept(i, r, sys)?;
                        Flow::Shared
                    }
                    SockPoll::Pending => Flow::Wait(Box::new(Wait::Accept { port, deadline })),
                }
            }
            Op::TcpConnect {
                port, ip, timeout, ..
            } => {
                let port = self.port(i, port, sys)?;
                let deadline = now.saturating_add(ns(self.timeout(i, timeout.as_ref(), sys)?));
                let mut addr = [0u8; 4];
                let n = ip.idx.len().min(3);
                let base = self.indices(i, ip, sys)?;
                for (k, b) in addr.iter_mut().enumerate() {
                    let mut at = base;
                    at[0] += k as i32;
                    let v = match self
                        .store(i, ip.var.global)
                        .reals
                        .get(ip.var.slot as usize)
                        .and_then(|x| x.get(&at[..n.max(1)]))
                    {
                        Some(v) => *v,
                        None => return Err(self.undefined(i, ip, Ty::Real, &at[..n.max(1)])),
                    };
                    if !(0.0..=255.0).contains(&v) {
                        return Err(Box::new(RuntimeError::IllegalValue(format!(
                            "IP address byte {v}"
                        ))));
                    }
                    *b = v as u8;
                }
                self.set_pc(i, pc);
                match sys.tcp_connect(addr, port) {
                    SockPoll::Ready(r) => {
                        self.finish_ret(i, r.unwrap_or_else(|e| e) as f32, sys)?;
                        Flow::Shared
                    }
                    SockPoll::Pending => Flow::Wait(Box::new(Wait::Connect {
                        ip: addr,
                        port,
                        deadline,
                    })),
                }
            }
            Op::TcpRecv {
                sock, timeout, max, ..
            } => {
                let sock = self.eval_r(i, sock, sys)?.trunc() as i32;
                let deadline = now.saturating_add(ns(self.timeout(i, timeout.as_ref(), sys)?));
                let max = match max {
                    Some(m) => {
                        let m = self.eval_r(i, m, sys)?.trunc();
                        if !(1.0..=255.0).contains(&m) {
                            return Err(Box::new(RuntimeError::IllegalValue(format!(
                                "TCP_RECV element size {m} (1 to 255)"
                            ))));
                        }
                        m as usize
                    }
                    None => 255,
                };
                self.set_pc(i, pc);
                match sys.tcp_recv(sock, MAX_TRANSFER) {
                    SockPoll::Ready(r) => {
                        self.finish_recv(i, r, max, sys)?;
                        Flow::Shared
                    }
                    SockPoll::Pending => Flow::Wait(Box::new(Wait::Recv {
                        sock,
                        max,
                        deadline,
                    })),
                }
            }
            Op::TcpSend {
                ret,
                sock,
                buf,
                n,
                timeout,
            } => {
                let sock = self.eval_r(i, sock, sys)?.trunc() as i32;
                let deadline = now.saturating_add(ns(self.timeout(i, timeout.as_ref(), sys)?));
                let count = self.eval_r(i, n, sys)?.trunc();
                if !(0.0..=MAX_INDEX as f32).contains(&count) {
                    return Err(Box::new(RuntimeError::IllegalValue(format!(
                        "TCP_SEND element count {count}"
                    ))));
                }
                let dims = buf.idx.len().clamp(1, 3);
                let base = self.indices(i, buf, sys)?;
                let mut data = Vec::new();
                for k in 0..count as i32 {
                    let mut at = base;
                    at[0] += k;
                    let v = match self
                        .store(i, buf.var.global)
                        .strs
                        .get(buf.var.slot as usize)
                        .and_then(|x| x.get(&at[..dims]))
                    {
                        Some(v) => v.clone(),
                        None => return Err(self.undefined(i, buf, Ty::Str, &at[..dims])),
                    };
                    data.extend_from_slice(&v);
                    if data.len() > MAX_TRANSFER {
                        break;
                    }
                }
                if data.len() > MAX_TRANSFER {
                    self.write_r(i, ret, -34022.0, sys)?;
                    return Ok(Flow::Shared);
                }
                self.set_pc(i, pc);
                match sys.tcp_send(sock, &data) {
                    SockPoll::Ready(r) => {
                        self.finish_ret(i, r.map_or_else(|e| e as f32, |()| 0.0), sys)?;
                        Flow::Shared
                    }
                    SockPoll::Pending => Flow::Wait(Box::new(Wait::Send {
                        sock,
                        data,
                        deadline,
                    })),
                }
            }
            Op::TcpClose(ret, sock) => {
                let sock = self.eval_r(i, sock, sys)?.trunc() as i32;
                let r = sys.tcp_close(sock);
                self.write_r(i, ret, r as f32, sys)?;
                Flow::Shared
            }
        };
        let t = &mut self.tasks[i];
        t.ready_at = now.saturating_add(cost);
        Ok(flow)
    }

    fn require_robot(&self, robot: bool, what: &str) -> R<()> {
        if robot {
            Ok(())
        } else {
            Err(Box::new(RuntimeError::WrongTask(format!(
                "{what} is allowed only in robot programs"
            ))))
        }
    }

    fn set_pc(&mut self, i: usize, pc: usize) {
        if let Some(f) = self.tasks[i].frames.last_mut() {
            f.pc = pc;
        }
    }

    fn port(&mut self, i: usize, e: &RExpr, sys: &mut dyn System) -> R<u16> {
        let p = self.eval_r(i, e, sys)?.trunc();
        if !(8192.0..=65535.0).contains(&p) {
            return Err(Box::new(RuntimeError::IllegalValue(format!(
                "port {p} (8192 to 65535)"
            ))));
        }
        Ok(p as u16)
    }

    fn timeout(&mut self, i: usize, e: Option<&RExpr>, sys: &mut dyn System) -> R<Duration> {
        let v = match e {
            Some(e) => self.eval_r(i, e, sys)?,
            None => 1.0,
        };
        if !(0.0..=60.0).contains(&v) {
            return Err(Box::new(RuntimeError::IllegalValue(format!(
                "timeout {v} s (0 to 60)"
            ))));
        }
        Ok(Duration::from_secs_f64(f64::from(v)))
    }

    /// Writes a socket instruction's result to its `ret` variable and goes on.
    fn finish_ret(&mut self, i: usize, v: f32, sys: &mut dyn System) -> R<()> {
        let code = Arc::clone(&self.code);
        let op = self.tasks[i]
            .frames
            .last()
            .and_then(|f| code.programs.get(f.prog)?.ops.get(f.pc));
        let ret = match op {
            Some(
                Op::TcpConnect { ret, .. }
                | Op::TcpSend { ret, .. }
                | Op::TcpAccept { ret, .. }
                | Op::TcpRecv { ret, .. },
            ) => ret,
            _ => return Ok(()),
        };
        self.write_r(i, ret, v, sys)?;
        self.advance_pc(i);
        Ok(())
    }

    fn finish_accept(
        &mut self,
        i: usize,
        r: Result<(i32, [u8; 4]), i32>,
        sys: &mut dyn System,
    ) -> R<()> {
        let ip = match self.current_op(i) {
            Some(Op::TcpAccept { ip, .. }) => ip.clone(),
            _ => None,
        };
        if let (Ok((_, addr)), Some(ip)) = (&r, ip) {
            let n = ip.idx.len().clamp(1, 3);
            let base = self.indices(i, &ip, sys)?;
            for (k, b) in addr.iter().enumerate() {
                let mut at = base;
                at[0] += k as i32;
                self.write_r_at(i, ip.var, &at[..n], f32::from(*b))?;
            }
        }
        let v = match r {
            Ok((id, _)) => id as f32,
            Err(e) => e as f32,
        };
        self.finish_ret(i, v, sys)
    }

    fn finish_recv(
        &mut self,
        i: usize,
        r: Result<Vec<u8>, i32>,
        max: usize,
        sys: &mut dyn System,
    ) -> R<()> {
        // A handle on the code (not a copy of the op's variables) while the variables change.
        let code = Arc::clone(&self.code);
        let op = self.tasks[i]
            .frames
            .last()
            .and_then(|f| code.programs.get(f.prog)?.ops.get(f.pc));
        let (buf, count) = match op {
            Some(Op::TcpRecv { buf, count, .. }) => (buf, count),
            _ => return Ok(()),
        };
        match r {
            Ok(bytes) => {
                let dims = buf.idx.len().clamp(1, 3);
                let base = self.indices(i, buf, sys)?;
                let mut n = 0;
                for (k, chunk) in bytes.chunks(max.max(1)).take(MAX_TRANSFER).enumerate() {
                    let mut at = base;
                    at[0] += k as i32;
                    if at[0] > MAX_INDEX {
                        break;
                    }
                    self.write_s_at(i, buf.var, &at[..dims], Bytes::from(chunk))?;
                    n += 1;
                }
                self.write_r(i, count, n as f32, sys)?;
                self.finish_ret(i, 0.0, sys)
            }
            Err(e) => {
                self.write_r(i, count, 0.0, sys)?;
                self.finish_ret(i, e as f32, sys)
            }
        }
    }

    fn eval_args(
        &mut self,
        i: usize,
        args: &[CArg],
        sys: &mut dyn System,
    ) -> R<Vec<(ArgVal, Option<ByRefTarget>)>> {
        let mut out = Vec::with_capacity(args.len());
        for a in args {
            let v = match &a.value {
                CExpr::R(e) => ArgVal::R(self.eval_r(i, e, sys)?),
                CExpr::S(e) => ArgVal::S(self.eval_s(i, e, sys)?),
                CExpr::J(e) => ArgVal::J(self.eval_j(i, e, sys)?),
                CExpr::T(e) => ArgVal::T(self.eval_t(i, e, sys)?),
            };
            let target = match &a.var {
                Some((_, l)) => {
                    let n = l.idx.len().min(3);
                    let idx = self.indices(i, l, sys)?;
                    let frame = self.tasks[i].frames.len().saturating_sub(1);
                    Some(ByRefTarget {
                        var: l.var,
                        idx: idx[..n].to_vec(),
                        frame,
                    })
                }
                None => None,
            };
            out.push((v, target));
        }
        Ok(out)
    }

    /// RETURN (or `.END`): back to the caller, writing by-reference parameters back.
    fn ret(&mut self, i: usize, sys: &mut dyn System) -> R<()> {
        if self.tasks[i].frames.len() <= 1 {
            self.end_program(i, sys, true);
            return Ok(());
        }
        let Some(frame) = self.tasks[i].frames.pop() else {
            return Ok(());
        };
        let mut result = Ok(());
        for b in &frame.byref {
            let s = b.param as usize;
            let callee = &frame.locals;
            let val = match b.ty {
                Ty::Real => callee.reals[s].get(&[]).copied().map(ArgVal::R),
                Ty::Str => callee.strs[s].get(&[]).cloned().map(ArgVal::S),
                Ty::Joint => callee.joints[s].get(&[]).copied().map(ArgVal::J),
                Ty::Trans => callee.trans[s].get(&[]).copied().map(ArgVal::T),
            };
            let Some(val) = val else { continue };
            let store = if b.var.global {
                &mut self.globals
            } else {
                match self.tasks[i].frames.get_mut(b.frame) {
                    Some(f) => &mut f.locals,
                    None => continue,
                }
            };
            let slot = b.var.slot as usize;
            let created = match val {
                ArgVal::R(v) => store.reals.get_mut(slot).is_some_and(|x| x.set(&b.idx, v)),
                ArgVal::S(v) => store.strs.get_mut(slot).is_some_and(|x| x.set(&b.idx, v)),
                ArgVal::J(v) => store.joints.get_mut(slot).is_some_and(|x| x.set(&b.idx, v)),
                ArgVal::T(v) => store.trans.get_mut(slot).is_some_and(|x| x.set(&b.idx, v)),
            };
            if let Err(e) = self.count_element(created) {
                result = Err(e);
            }
        }
        // A CALL's caller resumes after its CALL (its pc moved when it executed it); an
        // `ON … CALL` returns to where the interrupt found the task.
        self.release(i, frame);
        result
    }

    /// Issues a motion with the task's motion parameters (the one-shot ones are used up).
    fn motion(
        &mut self,
        i: usize,
        kind: MotionKind,
        target: Target,
        delay_s: f64,
        sys: &mut dyn System,
    ) -> R<Flow> {
        let cp = self.switch_on("cp");
        let abs_speed = self.switch_on("abs.speed");
        let m = &mut self.tasks[i].motion;
        let speed = m.speed_once.take().unwrap_or(m.speed);
        let (accuracy_mm, fine) = m.accuracy_once.take().unwrap_or(m.accuracy);
        let accel_percent = m.accel_once.take().unwrap_or(m.accel);
        let decel_percent = m.decel_once.take().unwrap_or(m.decel);
        let req = MotionRequest {
            kind,
            target,
            speed,
            delay_s,
            accuracy_mm,
            fine,
            accel_percent,
            decel_percent,
            cp,
            abs_speed,
        };
        match sys.issue_motion(&req) {
            Ok(Issued::Started) => Ok(Flow::Next),
            Ok(Issued::Planned) => Ok(Flow::Wait(Box::new(Wait::MotionPlanned))),
            Err(code) => Err(Box::new(RuntimeError::System(code))),
        }
    }
}

/// An evaluated argument.
#[derive(Debug, Clone)]
enum ArgVal {
    R(f32),
    S(Bytes),
    J([f32; 6]),
    T([f32; 6]),
}

/// Where a by-reference argument goes back.
#[derive(Debug, Clone)]
struct ByRefTarget {
    var: VarRef,
    idx: Vec<i32>,
    frame: usize,
}

fn xyzoat(v: &[f32; 6]) -> Xyzoat {
    Xyzoat {
        x_mm: f64::from(v[0]),
        y_mm: f64::from(v[1]),
        z_mm: f64::from(v[2]),
        o_deg: f64::from(v[3]),
        a_deg: f64::from(v[4]),
        t_deg: f64::from(v[5]),
    }
}

/// AS `VAL`: decimal through fs020n-proto's `as_val` (the protocol server's own reading),
/// `^H`/`^B` prefixes, and radix codes 1 (binary) and 2 (hexadecimal).
fn val(s: &[u8], radix: f32) -> R<f32> {
    // Leading blanks are cut on the bytes (ASCII: the same as on the text).
    let start = s
        .iter()
        .position(|&c| c != b' ' && c != b'\t')
        .unwrap_or(s.len());
    let s = &s[start..];
    // Valid UTF-8 (the usual case) is read in place; `from_utf8_lossy` gives the same text
    // but walks it chunk by chunk.
    let text = match std::str::from_utf8(s) {
        Ok(t) => std::borrow::Cow::Borrowed(t),
        Err(_) => String::from_utf8_lossy(s),
    };
    // A decimal number (no `^H`/`^B` prefix, radix code 0: `trunc(radix)` is 0, NaN
    // included): straight to the protocol's reading.
    if s.first() != Some(&b'^') && !(radix <= -1.0 || radix >= 1.0) {
        return Ok(as_val(&text) as f32);
    }
    let t = &*text;
    let (radix, digits) = if let Some(rest) = t.strip_prefix("^H").or_else(|| t.strip_prefix("^h"))
    {
        (16, rest)
    } else if let Some(rest) = t.strip_prefix("^B").or_else(|| t.strip_prefix("^b")) {
        (2, rest)
    } else {
        match radix.trunc() as i32 {
            0 => return Ok(as_val(t) as f32),
            1 => (2, t),
            2 => (16, t),
            other => {
                return Err(Box::new(RuntimeError::IllegalValue(format!(
                    "VAL radix code {other} (0, 1 or 2)"
                ))))
            }
        }
    };
    let end = digits
        .find(|c: char| !c.is_digit(radix))
        .unwrap_or(digits.len());
    Ok(u64::from_str_radix(&digits[..end.min(16)], radix).map_or(0.0, |v| v as f32))
}

/// `$DECODE`: where the token ends (mode ≤ 0: at the first delimiter; else at the first byte
/// that is not one). Delimiters match regardless of ASCII case.
#[inline]
fn decode_cut(s: &[u8], d: &[u8], mode: f32) -> usize {
    if let [x] = d {
        if !x.is_ascii_alphabetic() {
            // No case to ignore (the server's blank).
            return if mode <= 0.0 {
                s.iter().position(|c| c == x).unwrap_or(s.len())
            } else {
                s.iter().position(|c| c != x).unwrap_or(s.len())
            };
        }
    }
    let one = match d {
        [x] => Some(x.to_ascii_lowercase()),
        _ => None,
    };
    let is_delim = |c: u8| match one {
        Some(x) => c.to_ascii_lowercase() == x,
        None => d.iter().any(|x| x.eq_ignore_ascii_case(&c)),
    };
    if mode <= 0.0 {
        s.iter().position(|&c| is_delim(c)).unwrap_or(s.len())
    } else {
        s.iter().position(|&c| !is_delim(c)).unwrap_or(s.len())
    }
}

/// `INSTR`: 1-based position of `sub` in `s` at or after `start`, 0 when absent.
fn instr(s: &[u8], sub: &[u8], start: usize) -> usize {
    let from = start.saturating_sub(1);
    if from > s.len() {
        return 0;
    }
    if sub.is_empty() {
        return 0;
    }
    s[from..]
        .windows(sub.len())
        .position(|w| w == sub)
        .map_or(0, |p| p + from + 1)
}
