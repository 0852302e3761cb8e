//! The syntax tree of AS program files, with a [`Span`] on every statement, expression and
//! name (see [`crate::parse`]).

use std::sync::Arc;

use crate::error::ParseError;
use crate::lexer::Name;
use crate::span::Span;

/// One parsed file: its programs and data sections.
#[derive(Debug, Clone, PartialEq)]
pub struct Module {
    /// The file name used in messages.
    pub file: Arc<str>,
    /// The source lines (without line endings), for traces and the pendant.
    pub lines: Vec<String>,
    /// `.PROGRAM` … `.END` blocks, in file order.
    pub programs: Vec<Program>,
    /// Values of the data sections (`.REALS`, `.STRINGS`, `.JOINTS`, `.TRANS`), in file order.
    pub data: Vec<DataItem>,
    /// Things loaded but worth knowing: instructions loaded but not emulated, sections kept
    /// opaque, a section without its `.END`.
    pub warnings: Vec<ParseError>,
    /// Every section of the file, in file order (programs and data sections too), with its
    /// line range: what was read and what was kept opaque.
    pub sections: Vec<Section>,
    /// The system switches a `.SYSDATA` section sets (`SWITCH AUTOSTART.PC ON`), in file order.
    pub switches: Vec<SwitchSetting>,
}

impl Module {
    /// The state a `.SYSDATA` section of this file gives the system switch `name` (any case,
    /// e.g. `"AUTOSTART.PC"`; the last setting wins); `None` when the file does not set it.
    pub fn switch(&self, name: &str) -> Option<bool> {
        let name = name.to_ascii_lowercase();
        self.switches
            .iter()
            .rev()
            .find(|s| s.name == name)
            .map(|s| s.on)
    }

    /// The AUTOSTART switches this file sets: `(n, on)` for `AUTOSTART.PC` (n = 1) to
    /// `AUTOSTART5.PC` (n = 5), in that order. At power-on the controller starts PC program
    /// `autostartN.pc` in PC task n when its switch is ON.
    pub fn autostart(&self) -> Vec<(u8, bool)> {
        (1..=5u8)
            .filter_map(|n| {
                let name = if n == 1 {
                    "autostart.pc".to_owned()
                } else {
                    format!("autostart{n}.pc")
                };
                self.switch(&name).map(|on| (n, on))
            })
            .collect()
    }
}

/// One section of a file: `.PROGRAM`, `.REALS`, `.SYSDATA`, `.NETCONF`, …
#[derive(Debug, Clone, PartialEq, Eq, serde::Serialize)]
pub struct Section {
    /// The name as written after the dot, in upper case (`SYSDATA`, `PROGRAM`).
    pub name: String,
    /// The first line (the `.NAME` line).
    pub first_line: u32,
    /// The last line (its `.END`, or the line before the next section when it has none, or
    /// the first line of a one-line section).
    pub last_line: u32,
    /// What the loader did with it.
    pub reads: crate::sections::SectionUse,
    /// Whether the name is in [`crate::sections::SECTIONS`].
    pub known: bool,
}

/// A `SWITCH name ON|OFF` line of `.SYSDATA`.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct SwitchSetting {
    /// The switch, lower case (`autostart.pc`).
    pub name: String,
    /// ON.
    pub on: bool,
    /// Where it stands.
    pub span: Span,
}

/// `.PROGRAM name(params)` … `.END`.
#[derive(Debug, Clone, PartialEq)]
pub struct Program {
    /// Program name in lower case (`autostart.pc`, `ros_move`).
    pub name: String,
    /// Parameters (program-local variables assigned by `CALL`).
    pub params: Vec<Param>,
    /// The statements.
    pub body: Vec<Stmt>,
    /// Where `.PROGRAM` stands.
    pub span: Span,
    /// The line of `.END`.
    pub end_line: u32,
}

/// A program parameter: `.a`, `.$s`, `.#p`, or by reference `.&a` / `&.a`.
#[derive(Debug, Clone, PartialEq)]
pub struct Param {
    /// The local variable it fills.
    pub name: Name,
    /// Passed by reference: the caller's variable receives the final value on `RETURN`.
    pub by_ref: bool,
    /// Declared as a whole array (`.$data[]`).
    pub array: bool,
    /// Where it stands.
    pub span: Span,
}

/// An argument of `CALL` (and `EXECUTE`, `PCEXECUTE`): a value, or a whole array
/// (`CALL tcp.send(.$data[], 1)`, `name[]`, `name[,]`), which the subroutine's parameter
/// receives element by element and gives back on `RETURN`.
#[derive(Debug, Clone, PartialEq)]
pub struct CallArg {
    /// The value; for a whole array, the array variable without indices.
    pub value: Expr,
    /// `name[]`: the whole array.
    pub whole_array: bool,
}

/// A label (`exit:` or `10`) with where it stands.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Label {
    /// The label in lower case (a number as its digits).
    pub name: String,
    /// Where it stands.
    pub span: Span,
}

/// A statement (one source line, or a block of lines for IF, WHILE, DO, FOR, CASE).
#[derive(Debug, Clone, PartialEq)]
pub struct Stmt {
    /// A label at the start of the line.
    pub label: Option<Label>,
    /// What it does.
    pub kind: StmtKind,
    /// Where it starts.
    pub span: Span,
}

/// A variable or array element that can be assigned: `a`, `.$buf[1]`, `ros_cmd[.i, 2]`.
#[derive(Debug, Clone, PartialEq)]
pub struct LValue {
    /// The variable.
    pub name: Name,
    /// Array indices (0 to 3).
    pub indices: Vec<Expr>,
    /// Where it stands.
    pub span: Span,
}

/// What a statement does.
#[derive(Debug, Clone, PartialEq)]
pub enum StmtKind {
    /// A line with only a label (or a label on an empty statement).
    Empty,
    /// `target = value`.
    Assign {
        /// The variable.
        target: LValue,
        /// The value.
        value: Expr,
    },
    /// `IF cond THEN` … [`ELSE` …] `END`.
    If {
        /// Condition (non-zero is true).
        cond: Expr,
        /// Statements when true.
        then: Vec<Stmt>,
        /// Statements when false.
        otherwise: Vec<Stmt>,
    },
    /// `IF cond GOTO label`.
    IfGoto {
        /// Condition.
        cond: Expr,
        /// Where to go when true.
        label: Label,
    },
    /// `WHILE cond DO` … `END`.
    While {
        /// Tested before each pass.
        cond: Expr,
        /// The loop body.
        body: Vec<Stmt>,
    },
    /// `DO` … `UNTIL cond`.
    DoUntil {
        /// The loop body (runs at least once).
        body: Vec<Stmt>,
        /// Tested after each pass; the loop ends when true.
        cond: Expr,
    },
    /// `FOR var = from TO to [STEP step]` … `END`.
    For {
        /// The loop variable (a real).
        var: LValue,
        /// First value.
        from: Expr,
        /// Last value.
        to: Expr,
        /// Increment (default 1).
        step: Option<Expr>,
        /// The loop body.
        body: Vec<Stmt>,
    },
    /// `CASE expr OF` `VALUE a, b:` … `ANY:` … `END`.
    Case {
        /// The value compared.
        selector: Expr,
        /// The arms in order.
        arms: Vec<CaseArm>,
    },
    /// `GOTO label`.
    Goto(Label),
    /// `CALL program[(args)]`.
    Call {
        /// The program.
        program: String,
        /// The arguments.
        args: Vec<CallArg>,
    },
    /// `RETURN`.
    Return,
    /// `RETURNE`: from an error program (`ONE`), back to the step after the one that failed.
    ReturnAfterError,
    /// `PRINT` / `TYPE` items.
    Print {
        /// The items (values, strings, format codes).
        items: Vec<PrintItem>,
    },
    /// `TWAIT seconds`.
    Twait(Expr),
    /// `WAIT condition`.
    Wait(Expr),
    /// `HALT`.
    Halt,
    /// `STOP`.
    Stop,
    /// `PAUSE`.
    Pause,
    /// `SIGNAL n, -m, …`.
    Signal(Vec<Expr>),
    /// `SWAIT n, -m, …`: waits until every signal is in the state asked (negative: OFF).
    Swait(Vec<Expr>),
    /// `PULSE n[, seconds]`: output `n` ON now, OFF after the time (0.2 s when omitted).
    Pulse {
        /// The output signal.
        signal: Expr,
        /// How long it stays ON, seconds.
        time: Option<Expr>,
    },
    /// `DLYSIG n, seconds`: signal `n` (negative: OFF) set after the time; the program goes on.
    Dlysig {
        /// The signal (negative: turned OFF).
        signal: Expr,
        /// The delay, seconds.
        time: Expr,
    },
    /// `WEIGHT [mass, cog x, y, z[, inertia x, y, z]]` (AS-E p.6-120): the payload; without
    /// values the rated payload.
    Weight {
        /// Up to seven values (kg, mm in the tool frame, kg·m²); those left out are 0.
        values: Vec<Expr>,
    },
    /// `SOUT n = signal expression` (AS-E p.6-88): output `n` (negative: inverted) set to a
    /// logic of signals — each operand of `AND`, `OR`, `XOR`, `NOT` a signal number
    /// (negative: that signal OFF).
    Sout {
        /// The output (negative: set to the expression's inverse).
        signal: Expr,
        /// The signal expression.
        logic: Expr,
    },
    /// `IFPWPRINT`/`IFPWOVERWRITE window, [row, column, background, label colour] = "text", …`
    /// (AS-E p.6-98, p.6-100): strings written to an interface-panel window.
    IfpWrite {
        /// `IFPWOVERWRITE`: the other rows are kept (`IFPWPRINT` clears the window).
        overwrite: bool,
        /// The window, 1–8.
        window: Expr,
        /// Row, column, background colour, label colour; omitted: the window's last.
        place: [Option<Expr>; 4],
        /// The strings, one per row from the row given.
        texts: Vec<Expr>,
    },
    /// `IFPLABEL position, ["label 1"], …, ["label 4"]` (AS-E p.6-96): the labels of an
    /// interface-panel icon; an omitted label is not changed.
    IfpLabel {
        /// The icon's position, 1–112.
        position: Expr,
        /// Up to four labels.
        labels: Vec<Option<Expr>>,
    },
    /// `IFPTITLE page, "title"` (AS-E p.6-97): the title of an interface-panel page.
    IfpTitle {
        /// The page.
        page: Expr,
        /// The title.
        title: Expr,
    },
    /// `BITS start, count = value`: `count` signals from `start` set to the binary of `value`.
    Bits {
        /// `BITS32`: up to 32 signals (`BITS`: 16).
        wide: bool,
        /// The first (least significant) signal.
        start: Expr,
        /// How many signals (1–16; `BITS32` 1–32).
        count: Expr,
        /// The value.
        value: Expr,
    },
    /// `RUNMASK n[, count]`: outputs turned OFF when the robot program stops (negative `n`:
    /// no longer).
    RunMask {
        /// The first signal (negative: remove).
        signal: Expr,
        /// How many signals (1 when omitted).
        count: Option<Expr>,
    },
    /// `OPEN`/`CLOSE`/`RELAX [hand]` and their `I` forms: the hand's signals.
    Hand {
        /// What the hand does.
        action: HandAction,
        /// The `I` form: at once (after the current motion), not with the next motion.
        immediate: bool,
        /// The hand number (1 when omitted).
        hand: Option<Expr>,
    },
    /// `ON sig GOTO|CALL …` (`immediate`: `ONI`).
    On {
        /// `ONI` (cuts the motion) rather than `ON`.
        immediate: bool,
        /// The signal (negative: falling edge).
        signal: Expr,
        /// What happens when it fires.
        action: OnAction,
    },
    /// `IGNORE sig`.
    Ignore(Expr),
    /// `MC monitor command`, or a program-level `EXECUTE`/`PCEXECUTE`/`PCABORT`.
    Monitor(MonitorCommand),
    /// `ABS.SPEED ON`, `ENABLE name`, `DISABLE name`.
    SetSwitch {
        /// The system switch (lower case).
        name: String,
        /// ON or OFF.
        on: bool,
    },
    /// `TIMER n = value`.
    Timer {
        /// Timer number.
        timer: Expr,
        /// Seconds it shows now.
        value: Expr,
    },
    /// `UTIMER @timer = value` (AS-E p.6-118): a user timer, named by an integer variable,
    /// shows `value` seconds now and counts on.
    UTimer {
        /// The timer's variable (`@t`, `.@t`).
        timer: LValue,
        /// Seconds it shows now.
        value: Expr,
    },
    /// `DECOMPOSE array[i] = location`.
    Decompose {
        /// First element to fill.
        target: LValue,
        /// A joint point or a transformation.
        source: Expr,
    },
    /// `HERE location_variable`, or `HERE a+b`: the rightmost variable is defined so that
    /// the compound value is the current pose (AS-E p.6-108), the others must exist.
    Here {
        /// The variable (`#p` for joints, `p` for the transformation).
        target: LValue,
        /// `a` of `HERE a+b` (transformation variables, in order; empty for a plain HERE).
        relative_to: Vec<LValue>,
    },
    /// `POINT location_variable = location`.
    Point {
        /// The variable.
        target: LValue,
        /// The value.
        value: Expr,
    },
    /// `JMOVE` (`linear` false) or `LMOVE` (`linear` true).
    Move {
        /// Straight-line interpolation.
        linear: bool,
        /// A joint point or a transformation.
        target: Expr,
    },
    /// `TOOL t` / `TOOL NULL` (`base` false), `BASE t` / `BASE NULL`: the flange-to-tool or
    /// world-to-robot frame (`None`: NULL, the identity).
    Frame {
        /// `BASE` rather than `TOOL`.
        base: bool,
        /// The transformation (`None`: NULL).
        value: Option<Expr>,
    },
    /// `APPRO`/`JAPPRO` (joint) or `LAPPRO` (linear) `location, distance`: to `distance` mm
    /// short of the location along its tool Z axis.
    Appro {
        /// Straight-line interpolation.
        linear: bool,
        /// The location approached.
        target: Expr,
        /// Millimetres back along the tool Z axis.
        distance: Expr,
    },
    /// `DEPART`/`JDEPART` (joint) or `LDEPART` (linear) `distance`: back along the tool Z axis.
    Depart {
        /// Straight-line interpolation.
        linear: bool,
        /// Millimetres back along the tool Z axis.
        distance: Expr,
    },
    /// `DRAW dx, dy, dz, o, a, t` (along and about the base axes) or `TDRAW` (the tool's): a
    /// straight line by an offset and a rotation; an omitted value is 0.
    Draw {
        /// `TDRAW`: the tool's axes.
        tool: bool,
        /// X, Y, Z offsets, millimetres.
        offset: [Option<Expr>; 3],
        /// O, A, T of the rotation (Z-Y-Z Euler angles, as a transformation's), degrees.
        rotation: [Option<Expr>; 3],
        /// The seventh value: this motion's speed, percent.
        speed: Option<Box<Expr>>,
    },
    /// `DRIVE joint, degrees[, speed]`: one joint turned by an amount (the others stay), a
    /// joint motion at `speed` percent for this motion (the program's speed when omitted).
    Drive {
        /// The joint, 1 to 6.
        joint: Expr,
        /// The change, degrees.
        degrees: Expr,
        /// Percent of the maximum speed for this motion.
        speed: Option<Expr>,
    },
    /// `C1MOVE location`: the intermediate point of a circular motion (the `C2MOVE` that
    /// follows gives its end).
    CircleVia(Expr),
    /// `C2MOVE location`: the end of the circular motion through the `C1MOVE` point.
    CircleEnd(Expr),
    /// `XMOVE location TILL signal`: a straight line that stops when the signal condition
    /// becomes true (a negative number: OFF).
    Xmove {
        /// The destination.
        target: Expr,
        /// The signal number.
        till: Expr,
    },
    /// `HMOVE location`: the wrist centre on a straight line, the wrist joints interpolated.
    Hmove(Expr),
    /// `ALIGN`: turns the tool so that its Z axis is parallel to the nearest axis of the base
    /// (world) frame, joint-interpolated.
    Align,
    /// `LEFTY`, `RIGHTY`, `ABOVE`, `BELOW`, `UWRIST`, `DWRIST`: the arm configuration of the
    /// next joint motion to a transformation.
    Posture(Posture),
    /// `HOME [n]`.
    Home(Option<Expr>),
    /// `DELAY seconds` (a motion that stands still).
    Delay(Expr),
    /// `BRAKE`.
    Brake,
    /// `BREAK`.
    Break,
    /// `SPEED v [unit] [ALWAYS]`.
    Speed {
        /// The value.
        value: Expr,
        /// Its unit.
        unit: SpeedUnit,
        /// Persistent (otherwise the next motion only).
        always: bool,
    },
    /// `ACCURACY d [FINE] [ALWAYS]`.
    Accuracy {
        /// Millimetres.
        value: Expr,
        /// Exact coincidence.
        fine: bool,
        /// Persistent.
        always: bool,
    },
    /// `ACCEL p [ALWAYS]` (`decel` false) or `DECEL p [ALWAYS]`.
    AccelDecel {
        /// DECEL rather than ACCEL.
        decel: bool,
        /// Percent.
        value: Expr,
        /// Persistent.
        always: bool,
    },
    /// `CP ON|OFF`.
    Cp(bool),
    /// A `TCP_…` instruction.
    Tcp(TcpStmt),
    /// `UDP_SENDTO` or `UDP_RECVFROM`.
    Udp(UdpStmt),
    /// `ONE program` (`None`: `ONE` alone, or `ONE OFF`): the program this task runs when one
    /// of its statements fails (docs/AS.md, "ONE").
    OnError(Option<String>),
    /// An instruction that loads but is not emulated (`TOOL`, `JAPPRO`, a block-teaching
    /// step, …): a task that reaches it stops with E0199 naming it — unless it is stubbed,
    /// when it does nothing. Modelling one is local: the parser gives it its own statement.
    NotEmulated {
        /// The instruction as the warnings and the error name it (`JAPPRO`, `JOINT`).
        instruction: String,
        /// Declared a no-op by the user ([`crate::LoadOptions::stub`]).
        stubbed: bool,
    },
    /// A block-teaching step (`JOINT SPEED9 ACCU1 TIMER0 TOOL1 WORK0 … OX= WX= #[…]`): one
    /// motion with its settings and signals (docs/AS.md, "Block-teaching steps").
    BlockStep(Box<BlockStep>),
}

/// A block-teaching step as the emulator runs it: every field is a constant of the line.
#[derive(Debug, Clone, PartialEq)]
pub struct BlockStep {
    /// `LINEAR` (straight line) rather than `JOINT` (joint interpolation).
    pub linear: bool,
    /// The step's speed.
    pub speed: BlockSpeed,
    /// `ACCUn`: the accuracy number (0–4).
    pub accuracy: u8,
    /// `TIMERn`: the timer number (0–9), a delay after the robot reached the step.
    pub timer: u8,
    /// `TOOLn`: the tool number (0–15; 0 for the null tool).
    pub tool: u8,
    /// `OX=`: outputs set at the step (positive ON, negative OFF), in order.
    pub outputs: Vec<i32>,
    /// `WX=`: inputs the step waits for after reaching its pose (positive ON, negative OFF),
    /// as signal numbers (`WX=5` is input 1005).
    pub inputs: Vec<i32>,
    /// The pose the step moves to: the six joint angles (degrees) of `#[…]` or the
    /// transformation (mm, degrees) of `[x, y, z, o, a, t]`.
    pub target: BlockTarget,
    /// `END`: the program's last step (the program returns after it).
    pub end: bool,
}

/// The speed of a block-teaching step.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum BlockSpeed {
    /// `SPEEDn`: the speed number (0–9), a percentage of the controller's table.
    Number(u8),
    /// A number in place of `SPEEDn` after `LINEAR` (`LINEAR 50.0 …`): mm/s.
    MmPerS(f64),
}

/// The pose a block-teaching step moves to.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum BlockTarget {
    /// `#[j1, …, j6]`: joint angles, degrees (values for axes beyond the sixth are dropped).
    Joints([f64; 6]),
    /// `[x, y, z, o, a, t]`: the tool in the world, mm and degrees.
    Pose([f64; 6]),
}

/// A posture command: which inverse-kinematics branch the next joint motion takes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Posture {
    /// `LEFTY`: the shoulder in its back configuration (the wrist centre behind the JT1 axis).
    Lefty,
    /// `RIGHTY`: the shoulder in its front configuration.
    Righty,
    /// `ABOVE`: elbow up.
    Above,
    /// `BELOW`: elbow down.
    Below,
    /// `UWRIST`: JT5 positive.
    Uwrist,
    /// `DWRIST`: JT5 negative.
    Dwrist,
}

/// What `OPEN`, `CLOSE` and `RELAX` do to a hand.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum HandAction {
    /// `OPEN`: the open signal ON, the close signal OFF.
    Open,
    /// `CLOSE`: the close signal ON, the open signal OFF.
    Close,
    /// `RELAX`: both OFF.
    Relax,
}

/// One `VALUE …:` or `ANY:` arm of a CASE.
#[derive(Debug, Clone, PartialEq)]
pub struct CaseArm {
    /// The values (`None`: `ANY`).
    pub values: Option<Vec<Expr>>,
    /// Its statements.
    pub body: Vec<Stmt>,
    /// Where `VALUE`/`ANY` stands.
    pub span: Span,
}

/// What an `ON`/`ONI` does.
#[derive(Debug, Clone, PartialEq)]
pub enum OnAction {
    /// Jump to a label of the program that executed the ON.
    Goto(Label),
    /// Call a program, then go on where the task was.
    Call(String),
}

/// A monitor command (`MC …`, or the program instructions of the same effect).
#[derive(Debug, Clone, PartialEq)]
pub enum MonitorCommand {
    /// `EXECUTE program[(args)][, cycles]`: start it in robot task 1.
    Execute {
        /// The program.
        program: String,
        /// Its arguments.
        args: Vec<CallArg>,
        /// How many times it runs (default 1; negative: forever).
        cycles: Option<Expr>,
    },
    /// `PCEXECUTE [n:] program[(args)][, cycles]`: start it in PC task n (default 1).
    PcExecute {
        /// Task number 1–5.
        task: Option<Expr>,
        /// The program.
        program: String,
        /// Its arguments.
        args: Vec<CallArg>,
        /// How many times it runs.
        cycles: Option<Expr>,
    },
    /// `PCABORT [n:]`.
    PcAbort {
        /// Task number 1–5 (default 1).
        task: Option<Expr>,
    },
    /// `PCEND [n[: mode]]` (AS-E p.10-5): PC task `n` ends at the end of its current cycle
    /// (its next `STOP`/`RETURN`/`.END` of the main program) whatever cycles remain; mode −1
    /// cancels a PCEND given before.
    PcEnd {
        /// Task number 1–5 (default 1).
        task: Option<Expr>,
        /// 1 (default) or −1 (cancel).
        mode: Option<Expr>,
    },
    /// `ABORT`: robot task 1 stops after the current step.
    Abort,
    /// `HOLD`: robot task 1 and its motion pause.
    Hold,
    /// `CONTINUE`: resume after HOLD or PAUSE.
    Continue,
    /// `SPEED p`: monitor speed, percent.
    Speed(Expr),
    /// `ERESET`: reset the error.
    Ereset,
    /// `ZPOWER ON|OFF`: motor power (later controllers' monitor command, which real PC
    /// programs run through `MC ZPOWER ON`).
    Zpower(bool),
}

/// A print format code.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FormatCode {
    /// `/D`: default.
    D,
    /// `/L`: default without blanks.
    L,
    /// `/Fm.n`.
    F(u8, u8),
    /// `/Em.n`.
    E(u8, u8),
    /// `/Gm.n`.
    G(u8, u8),
    /// `/Im`.
    I(u8),
    /// `/Km`: `/I` padded with zeros.
    K(u8),
    /// `/Hm`: hexadecimal.
    H(u8),
    /// `/Jm`: `/H` padded with zeros.
    J(u8),
    /// `/Xn`: n blanks.
    X(u8),
    /// `/Cn`: n line feeds.
    C(u8),
    /// `/S`: no line feed at the end of the PRINT.
    S,
}

/// An item of PRINT/TYPE or `$ENCODE`.
#[derive(Debug, Clone, PartialEq)]
pub enum PrintItem {
    /// A value (real or string).
    Expr(Expr),
    /// A format code.
    Format(FormatCode, Span),
}

/// Unit of a SPEED.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SpeedUnit {
    /// Percent of the maximum (default).
    Percent,
    /// `MM/S`: tool speed.
    MmPerS,
    /// `MM/MIN`: tool speed.
    MmPerMin,
    /// `S`: the motion takes this many seconds.
    Seconds,
}

/// The `TCP_…` instructions (each stores its result, 0/socket id or a negative code, in `ret`).
#[derive(Debug, Clone, PartialEq)]
pub enum TcpStmt {
    /// `TCP_LISTEN ret, port`.
    Listen {
        /// Result.
        ret: LValue,
        /// Port.
        port: Expr,
    },
    /// `TCP_ACCEPT ret, port, timeout[, ip_array]`.
    Accept {
        /// Socket id or error.
        ret: LValue,
        /// Port.
        port: Expr,
        /// Seconds (default 1).
        timeout: Option<Expr>,
        /// Receives the client's address in 4 elements.
        ip: Option<LValue>,
    },
    /// `TCP_END_LISTEN ret, port`.
    EndListen {
        /// Result.
        ret: LValue,
        /// Port.
        port: Expr,
    },
    /// `TCP_RECV ret, sock, $array[start], count, timeout[, max_bytes]`.
    Recv {
        /// Result.
        ret: LValue,
        /// Socket id.
        sock: Expr,
        /// First string element to fill.
        buf: LValue,
        /// Receives the number of elements filled.
        count: LValue,
        /// Seconds (default 1).
        timeout: Option<Expr>,
        /// Bytes per element, 1–255 (default 255).
        max: Option<Expr>,
    },
    /// `TCP_SEND ret, sock, $array[start], n, timeout`.
    Send {
        /// Result.
        ret: LValue,
        /// Socket id.
        sock: Expr,
        /// First string element to send.
        buf: LValue,
        /// Number of elements.
        n: Expr,
        /// Seconds (default 1).
        timeout: Option<Expr>,
    },
    /// `TCP_STATUS ret, port[i], sock[i], err[i], sub[i], $ip[i]`: the open sockets.
    Status {
        /// Result: how many sockets.
        ret: LValue,
        /// First elements of the arrays filled per socket: port, id, error, sub-error, the
        /// peer's address as text.
        arrays: [LValue; 5],
    },
    /// `TCP_CLOSE ret, sock`.
    Close {
        /// Result.
        ret: LValue,
        /// Socket id.
        sock: Expr,
    },
    /// `TCP_CONNECT ret, port, ip_array[start], timeout`.
    Connect {
        /// Socket id or error.
        ret: LValue,
        /// Port.
        port: Expr,
        /// 4 elements holding the IPv4 address.
        ip: LValue,
        /// Seconds (default 1).
        timeout: Option<Expr>,
    },
}

/// An expression.
#[derive(Debug, Clone, PartialEq)]
pub struct Expr {
    /// What it is.
    pub kind: ExprKind,
    /// Where it starts.
    pub span: Span,
}

/// The kinds of expression.
#[derive(Debug, Clone, PartialEq)]
pub enum ExprKind {
    /// A number.
    Num(f64),
    /// A string literal.
    Str(Vec<u8>),
    /// A variable, an array element, or a name-only function (`TRUE`, `ERROR`, `HERE`, …).
    Var(LValue),
    /// `-a`, `NOT a`, `COM a`.
    Unary(UnOp, Box<Expr>),
    /// `a op b`.
    Binary(BinOp, Box<Expr>, Box<Expr>),
    /// `name(args)`: a function.
    Call {
        /// The function name (with its sigil: `$mid`, `#ppoint`).
        name: Name,
        /// The arguments.
        args: Vec<Arg>,
    },
}

/// A function argument.
#[derive(Debug, Clone, PartialEq)]
pub enum Arg {
    /// An expression.
    Expr(Expr),
    /// A format code (`$ENCODE(/F10.3, …)`).
    Format(FormatCode, Span),
    /// An omitted value (`TRANS(, -100)`): the function's default, 0 for the components of
    /// `TRANS`, `SHIFT` and `#PPOINT`.
    Omitted(Span),
    /// A keyword as an argument (`SYSDATA(STEP)`), lower case.
    Keyword(String, Span),
}

/// Unary operators.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum UnOp {
    /// `-`
    Neg,
    /// `NOT` (logical).
    Not,
    /// `COM` (bitwise complement).
    Com,
}

/// Binary operators.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum BinOp {
    /// `+` (also string concatenation and transformation composition).
    Add,
    /// `-`
    Sub,
    /// `*`
    Mul,
    /// `/`
    Div,
    /// `MOD`
    Mod,
    /// `^`
    Pow,
    /// `==`
    Eq,
    /// `<>`
    Ne,
    /// `<`
    Lt,
    /// `>`
    Gt,
    /// `<=`
    Le,
    /// `>=`
    Ge,
    /// `AND` (logical).
    And,
    /// `OR` (logical).
    Or,
    /// `XOR` (logical).
    Xor,
    /// `BAND` (bitwise).
    Band,
    /// `BOR` (bitwise).
    Bor,
    /// `BXOR` (bitwise).
    Bxor,
}

/// A value from a data section.
#[derive(Debug, Clone, PartialEq)]
pub struct DataItem {
    /// The variable (global; indices are constants).
    pub name: Name,
    /// Array indices.
    pub indices: Vec<i32>,
    /// The value.
    pub value: DataValue,
    /// Where it stands.
    pub span: Span,
}

/// The value of a data item.
#[derive(Debug, Clone, PartialEq)]
pub enum DataValue {
    /// `.REALS`: `name = value`.
    Real(f64),
    /// `.STRINGS`: `$name = "text"`.
    Str(Vec<u8>),
    /// `.JOINTS`: `#name j1 … j6` (degrees).
    Joints([f64; 6]),
    /// `.TRANS`: `name x y z o a t` (mm, degrees).
    Trans([f64; 6]),
}

/// The UDP instructions: each opens its own socket and closes it when it ends, and stores its
/// result (0 or a negative code) in `ret`.
#[derive(Debug, Clone, PartialEq)]
pub enum UdpStmt {
    /// `UDP_SENDTO ret, ip_array[start], port, $array[start], n[, timeout]`.
    SendTo {
        /// Result.
        ret: LValue,
        /// 4 elements holding the destination's IPv4 address.
        ip: LValue,
        /// Destination port.
        port: Expr,
        /// First string element to send.
        buf: LValue,
        /// Number of elements.
        n: Expr,
        /// Seconds (default 1).
        timeout: Option<Expr>,
    },
    /// `UDP_RECVFROM ret, port, $array[start], count[, timeout[, ip_array[start][, max_bytes]]]`.
    RecvFrom {
        /// Result.
        ret: LValue,
        /// The port it receives on.
        port: Expr,
        /// First string element to fill.
        buf: LValue,
        /// Receives the number of elements filled.
        count: LValue,
        /// Seconds (default 1).
        timeout: Option<Expr>,
        /// Receives the sender's address in 4 elements.
        ip: Option<LValue>,
        /// Bytes per element, 1–255 (default 255).
        max: Option<Expr>,
    },
}
