//! The interpreter: tasks, scheduler, statements and expressions on a clock it is given.
//!
//! See the crate documentation for the model (tasks, cost model, look-ahead) and docs/AS.md
//! for every choice made where the AS manuals are silent.
//!
//! # Map
//!
//! One concern per file, each file one `impl Interpreter` block (or plain types):
//!
//! | file | concern |
//! |---|---|
//! | `mod.rs` | [`Interpreter`] (its state) and loading |
//! | `config.rs`, `report.rs` | public settings ([`Config`], [`CostModel`]) and reports ([`TaskInfo`], [`TraceLine`], …) |
//! | `task.rs` | a task's state: frames, waits, interrupts, motion parameters; [`task::TaskSlot`] |
//! | `observers.rs` | reading and setting state from outside (tasks, variables, signals, switches) |
//! | `scheduler.rs` | `run_until`: which task runs next, waits and polls, interrupts, errors |
//! | `start.rs` | starting and ending programs (`start`, `EXECUTE`, `PCEXECUTE`, frames) |
//! | `reload.rs` | taking new programs while tasks run (`adopt`): frames, handlers and globals mapped by name |
//! | `vars.rs` | reading and writing variables with their indices |
//! | `signals.rs` | signal numbers and outputs, `PULSE`, `DLYSIG`, `BITS` |
//! | `frames.rs` | `TOOL`, `BASE`, kinematic conversions, `APPRO`, `DEPART`, `DRAW`, `ALIGN` |
//! | `circular.rs` | `C1MOVE`/`C2MOVE`: the via point kept, the circular motion issued |
//! | `xmove.rs` | `XMOVE … TILL`: a straight line the signal cuts short |
//! | `posture.rs` | `LEFTY`, `RIGHTY`, `ABOVE`, `BELOW`, `UWRIST`, `DWRIST`: the IK branch |
//! | `hands.rs` | `OPEN`/`CLOSE`/`RELAX` and their `I` forms on the hands' signals |
//! | `interface_panel.rs` | `IFPWPRINT`, `IFPWOVERWRITE`, `IFPLABEL`, `IFPTITLE`: what the interface panel shows |
//! | `immediate.rs` | a statement typed at the terminal (`DO`, `TYPE`, `POINT`, …): compiled against the loaded programs and run at once |
//! | `locations.rs`, `exist.rs` | `DISTANCE`, `DX`/`DY`/`DZ`, `FRAME`; `EXISTREAL` … `EXISTPROGRAM` |
//! | `named.rs` | `STRTOPOS`, `STRTOVAL`, `WHICHTASK`: what a string names |
//! | `listing.rs` | `LIST/R`, `/INT`, `/L`, `/S`: the globals as data-section lines |
//! | `expr.rs` | expressions (reals, strings, locations, functions, `PRINT` encoding) |
//! | `tcp.rs`, `udp.rs` | the `TCP_…` and `UDP_…` statements on the system's socket table |
//! | `payload.rs` | `WEIGHT`: the payload kept |
//! | `on_error.rs` | `ONE`: a task's error program, and how the task goes on after it |
//! | `stmt.rs` | one step: the hot path of pure computation, then every other op |
//! | `arith.rs`, `strings.rs` | free helpers: numbers and overflow, string functions |
//!
//! Arrows run one way: the `impl` files import the types (`task`, `report`, `config`) and the
//! helpers (`arith`, `strings`); they call one another only through `Interpreter`'s methods.

mod arith;
mod block;
mod circular;
mod clock;
mod config;
mod exist;
mod expr;
mod flow;
mod frames;
mod hands;
mod immediate;
mod interface_panel;
mod listing;
mod locations;
mod monitor;
mod motion;
mod named;
mod observers;
mod on_error;
mod payload;
mod posture;
mod print;
mod reload;
mod report;
mod scheduler;
mod signals;
mod start;
mod stmt;
mod strings;
mod task;
mod tcp;
mod udp;
mod vars;
mod xmove;

use std::collections::{HashMap, VecDeque};
use std::sync::Arc;
use std::time::Duration;

use crate::ast::{DataValue, Module};
use crate::compile::{compile, Code, Ty};
use crate::error::{LoadError, ParseError};
use crate::keywords::SYSTEM_SWITCHES;
use crate::system::TaskId;
use crate::value::{Bytes, Store};

use arith::{ns, Ns};
use task::{SignalState, Task, TaskSlot};

pub use config::{BlockSettings, Config, CostModel, HandSignals};
pub use interface_panel::{InterfacePanel, PanelWindow};
pub use listing::ListKind;
pub use payload::Payload;
pub use report::{
    ImmediateError, Refusal, ReloadError, TaskInfo, TaskState, TerminalLine, TraceLine,
};

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
    kept: HashMap<(TaskSlot, usize), Store>,
    elements: usize,
    tasks: Vec<Task>,
    signals: HashMap<i32, SignalState>,
    /// Signal changes due later (`PULSE`, `DLYSIG`): (time, signal, ON), in no order.
    timed_signals: Vec<(Ns, i32, bool)>,
    /// Hand actions of `OPEN`/`CLOSE`/`RELAX` waiting for the next motion: (hand, action).
    hand_pending: Vec<(usize, crate::ast::HandAction)>,
    /// The target of the latest motion instruction (`DEST`), as the system received it.
    dest: Option<crate::system::Target>,
    /// `RUNMASK`: outputs turned OFF when the robot program stops.
    run_mask: Vec<i32>,
    /// The flange pose of a `C1MOVE` waiting for its `C2MOVE` (robot base frame).
    circle_via: Option<crate::system::Trans>,
    /// The posture asked for the next joint motion to a transformation: front shoulder
    /// (RIGHTY), elbow up (ABOVE), JT5 positive (UWRIST); `None`: any (the nearest solution).
    posture: [Option<bool>; 3],
    /// `TOOL` (flange to tool) and `BASE` (world to robot), `None` for NULL.
    tool: Option<[f32; 6]>,
    base: Option<[f32; 6]>,
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
    /// While a typed statement runs ([`Interpreter::immediate`]): its slot and the task put
    /// aside there, which `TASK(n)` still reports.
    aside: Option<(TaskSlot, Box<Task>)>,
    /// What the interface panel shows (`IFPWPRINT` …).
    panel: Box<InterfacePanel>,
    /// The payload `WEIGHT` set.
    payload: Payload,
}

/// Largest string, bytes.
pub const MAX_STRING: usize = 255;

/// Most bytes one `TCP_RECV` or `TCP_SEND` moves.
pub const MAX_TRANSFER: usize = 4096;

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
        if cfg.clock_at_start.is_none() {
            cfg.clock_at_start = Some(clock::host_now());
        }
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
            timed_signals: Vec::new(),
            hand_pending: Vec::new(),
            run_mask: Vec::new(),
            dest: None,
            posture: [None; 3],
            circle_via: None,
            tool: None,
            base: None,
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
            aside: None,
            panel: Box::default(),
            payload: Payload::default(),
        })
    }

    /// Parses and loads one file.
    pub fn from_source(file: &str, text: &str, config: Config) -> Result<Interpreter, LoadError> {
        let m = crate::parser::parse(file, text)?;
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
        self.code
            .programs
            .iter()
            .filter(|p| p.defined)
            .map(|p| p.name.as_str())
            .collect()
    }

    /// Interpreter time (since it was created).
    pub fn now(&self) -> Duration {
        Duration::from_nanos(self.now)
    }
}
