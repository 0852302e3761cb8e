//! The interpreter's settings: [`Config`] and the [`CostModel`].

use std::time::Duration;

use serde::Serialize;

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
    /// Deepest `CALL` nesting before E0118.
    pub max_call_depth: usize,
    /// Terminal lines kept for [`Interpreter::terminal`](crate::Interpreter::terminal).
    pub terminal_lines: usize,
    /// `false` (default): a program's dot-locals are created for each execution and each
    /// `CALL` and start undefined. `true`: they belong to the program in its task and keep
    /// their values across calls and new executions (the controller's behaviour is not
    /// documented; see docs/AS.md).
    pub persistent_locals: bool,
    /// The output signals of hands 1, 2, … that `OPEN`/`CLOSE`/`RELAX` drive (default: hand 1
    /// on outputs 1 and 2, hand 2 on 3 and 4; see docs/AS.md).
    pub hands: Vec<HandSignals>,
    /// The controller clock (`$TIME`, `$DATE`) when the interpreter's time is zero: a Unix time
    /// in seconds and the offset of local time from UTC in seconds. `None` (default): the
    /// host's local time when the interpreter is created. Tests set it for repeatable output.
    pub clock_at_start: Option<(i64, i32)>,
    /// The controller's tables that block-teaching steps name by number (`SPEEDn`, `ACCUn`,
    /// `TIMERn`, `TOOLn`).
    pub block: BlockSettings,
}

/// The settings tables of block-teaching steps (the controller's auxiliary data: speed, accuracy,
/// timer and tool numbers). The defaults are the values of the tables in controller saves
/// (their `.AUXDATA` section); a cell's own values come from its controller (docs/AS.md,
/// "Block-teaching steps").
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct BlockSettings {
    /// `SPEED0` … `SPEED9`: percent of the maximum speed (default 10, 20, … 100). The motion
    /// speed is this times the monitor speed, at most 100 %.
    pub speed_percent: [f64; 10],
    /// `ACCU0` … `ACCU4`: the accuracy, mm (default 1, 1, 10, 50, 100).
    pub accuracy_mm: [f64; 5],
    /// `TIMER0` … `TIMER9`: the wait after the step reached its pose, seconds (default 0,
    /// 0.1, … 0.9).
    pub timer_s: [f64; 10],
    /// `TOOL1` … `TOOL15` (index 0 is `TOOL0`): the tool transformation (x, y, z mm, o, a, t
    /// degrees) a step sets; `None` (default): the null tool.
    pub tools: [Option<[f64; 6]>; 16],
}

impl Default for BlockSettings {
    fn default() -> Self {
        BlockSettings {
            speed_percent: [10.0, 20.0, 30.0, 40.0, 50.0, 60.0, 70.0, 80.0, 90.0, 100.0],
            accuracy_mm: [1.0, 1.0, 10.0, 50.0, 100.0],
            timer_s: [0.0, 0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7, 0.8, 0.9],
            tools: [None; 16],
        }
    }
}

/// The output signals of one hand (a double-solenoid valve: one signal opens, one closes).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
pub struct HandSignals {
    /// The signal `OPEN` turns ON (and `CLOSE` OFF); 0 for a single-solenoid hand, where
    /// `OPEN` only turns [`HandSignals::close`] OFF.
    pub open: i32,
    /// The signal `CLOSE` turns ON (and `OPEN` OFF).
    pub close: i32,
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
            hands: vec![
                HandSignals { open: 1, close: 2 },
                HandSignals { open: 3, close: 4 },
            ],
            clock_at_start: None,
            block: BlockSettings::default(),
        }
    }
}
