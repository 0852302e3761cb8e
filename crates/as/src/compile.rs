//! The compiler: parsed modules into flat, typed code with resolved variables, labels and
//! programs. Structured statements become jumps (so `GOTO` may leave any block); every
//! expression is typed (real, string, joint point, transformation) so that a type error is a
//! load error with file:line:column, never a surprise at run time.

use std::collections::HashMap;
use std::sync::Arc;

use crate::ast::*;
use crate::error::{LoadError, ParseError, MAX_REPORTED};
use crate::keywords;
use crate::lexer::{Name, Sigil};
use crate::span::Span;
use crate::value::Bytes;

/// The four value types of AS.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub(crate) enum Ty {
    Real = 0,
    Str = 1,
    Joint = 2,
    Trans = 3,
}

impl Ty {
    fn name(self) -> &'static str {
        match self {
            Ty::Real => "a real",
            Ty::Str => "a string",
            Ty::Joint => "a joint point",
            Ty::Trans => "a transformation",
        }
    }
}

/// A variable: its scope and slot (the type is known from where it is used).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct VarRef {
    pub(crate) global: bool,
    pub(crate) slot: u32,
}

/// A variable or array element to read or write.
#[derive(Debug, Clone)]
pub(crate) struct LRef {
    pub(crate) var: VarRef,
    pub(crate) idx: Box<[RExpr]>,
}

/// Real-valued expressions.
// An explicit one-byte tag (no niche in a field): a `match` is one load and a jump.
#[derive(Debug, Clone)]
#[repr(u8)]
pub(crate) enum RExpr {
    Const(f32),
    Var(LRef),
    Neg(Box<RExpr>),
    Not(Box<RExpr>),
    Com(Box<RExpr>),
    Bin(BinOp, Box<RExpr>, Box<RExpr>),
    StrCmp(BinOp, Box<SExpr>, Box<SExpr>),
    Func(RFunc, Box<[RExpr]>),
    Val(Box<SExpr>, Option<Box<RExpr>>),
    Len(Box<SExpr>),
    Asc(Box<SExpr>, Option<Box<RExpr>>),
    Instr(Option<Box<RExpr>>, Box<SExpr>, Box<SExpr>),
    Dext(Box<Loc>, Box<RExpr>),
    Switch(SwitchRef),
    Error,
    /// `DISTANCE(t1, t2)`, `DX(t)`, `DY(t)`, `DZ(t)`.
    Loc(LocFn, Box<[TExpr]>),
    /// `EXISTREAL("name")` …: whether the named thing exists.
    Exist(Exist, Box<SExpr>),
    /// `WHICHTASK($name)`: the task running the named program.
    WhichTask(Box<SExpr>),
    /// `STRTOVAL($name)`: the real variable the string names.
    NamedReal(Box<SExpr>),
    /// `MAXINDEX($name[, dim])` (`true`) / `MININDEX`: the largest / smallest index used.
    ArrayIndex(bool, Box<SExpr>, Option<Box<RExpr>>),
    /// `SYSDATA(keyword[, robot])`: a value of the controller's state; the robot number when
    /// it is not the constant 1 (an expression such as `.rno`, evaluated when read: robot 1
    /// is this robot, another has no value, −1).
    SysData(SysData, Option<Box<RExpr>>),
}

/// The `SYSDATA` keywords the emulator answers (AS-E p.9-24…9-26).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum SysData {
    /// `M.SPEED`: the monitor speed, percent.
    MonitorSpeed,
    /// `STEP`, `MSTEP`: the step (line) the task runs.
    Step,
    /// `NUMROBOT`: how many robots (1).
    Robots,
    /// `ZROB.NOWAXIS`: the robot's axes (6).
    Axes,
    /// `LANGUAGE`: the display language (2, English).
    Language,
    /// `MEM.FREE`: free memory, percent (the emulator's is never short: 100).
    FreeMemory,
    /// `P.SPEED`: the program speed of the robot task's next motion, percent (−1 when it is
    /// given in mm/s or seconds).
    ProgramSpeed,
}

/// Real functions of transformations.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum LocFn {
    Distance,
    Dx,
    Dy,
    Dz,
}

/// What an `EXIST…` function looks for.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Exist {
    Real,
    /// An integer variable (`@name`; integers are reals here).
    Integer,
    Char,
    Joint,
    Trans,
    Program,
}

/// Real functions of real arguments.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum RFunc {
    Abs,
    Sqrt,
    Sin,
    Cos,
    Tan,
    Atan2,
    Int,
    MaxVal,
    MinVal,
    Sig,
    Bits,
    Bits32,
    Task,
    Timer,
    /// `UTIMER(@t)`: the seconds since the user timer read 0 (its variable holds that time).
    UTimer,
    Round,
}

/// A switch read by `SWITCH(name)`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum SwitchRef {
    Power,
    Run,
    Repeat,
    TeachLock,
    CycleStart,
    InError,
    /// An emergency stop (`EMERGENCY`, `TP_EMG`, `OP_EMG`, `EX_EMG`): none is pressed in the
    /// emulator, so it reads OFF.
    EmergencyStop,
    System(usize),
}

/// String-valued expressions.
// An explicit one-byte tag (no niche in a field): a `match` is one load and a jump.
#[derive(Debug, Clone)]
#[repr(u8)]
pub(crate) enum SExpr {
    Const(Bytes),
    Var(LRef),
    Concat(Box<SExpr>, Box<SExpr>),
    Mid(Box<SExpr>, Box<RExpr>, Option<Box<RExpr>>),
    Left(Box<SExpr>, Box<RExpr>),
    Right(Box<SExpr>, Box<RExpr>),
    Chr(Box<RExpr>),
    Encode(Box<[Item]>),
    Decode(LRef, Box<SExpr>, Box<RExpr>),
    ErrorMsg(Box<RExpr>),
    /// `$TIME`: the controller clock, `hh:mm:ss`.
    Time,
    /// `$DATE(form)`: 1 `mm/dd/yyyy`, 2 `dd/MMM/yyyy`, 3 `yyyy/mm/dd`.
    Date(Box<RExpr>),
    /// `$SYSDATA(ZROB.NAME)`: the robot's model name.
    RobotName,
    /// `$SPACE(n)`: n blanks.
    Space(Box<RExpr>),
}

/// Joint-point expressions.
#[derive(Debug, Clone)]
pub(crate) enum JExpr {
    Var(LRef),
    PPoint(Box<[RExpr]>),
    Here,
    /// A transformation's joint values (inverse kinematics near the current joints).
    Inverse(Box<TExpr>),
    /// `#DEST`: the target of the latest motion instruction.
    Dest,
}

/// Transformation expressions.
#[derive(Debug, Clone)]
pub(crate) enum TExpr {
    Var(LRef),
    Trans(Box<[RExpr]>),
    Here,
    Compose(Box<TExpr>, Box<TExpr>),
    /// A joint point's transformation (forward kinematics, with TOOL and BASE).
    Forward(Box<JExpr>),
    /// `DEST`: the target of the latest motion instruction.
    Dest,
    /// `SHIFT(t BY dx, dy, dz)`: `t` moved along the base axes.
    Shift(Box<TExpr>, Box<[RExpr]>),
    /// `FRAME(t1, t2, t3, t4)`: origin t4, X from t1 toward t2, t3 on the XY plane's +Y side.
    Frame(Box<[TExpr; 4]>),
    /// `-t`: the inverse transformation (`a - b` is `a + (-b)`).
    Inverse(Box<TExpr>),
    /// `RX(angle)`, `RY(angle)`, `RZ(angle)`: a pure rotation about the X (0), Y (1) or Z (2)
    /// axis, in degrees.
    Rot(u8, Box<RExpr>),
}

/// A location: joint point or transformation.
#[derive(Debug, Clone)]
pub(crate) enum Loc {
    J(JExpr),
    T(TExpr),
    /// `STRTOPOS($s)`: the pose variable the string names (`"#pos"` a joint point, `"pos"` a
    /// transformation), its kind known when it is read.
    Named(SExpr),
}

/// An item of PRINT/TYPE/$ENCODE.
#[derive(Debug, Clone)]
pub(crate) enum Item {
    Real(RExpr),
    Str(SExpr),
    Format(FormatCode),
}

/// A typed expression.
#[derive(Debug, Clone)]
pub(crate) enum CExpr {
    R(RExpr),
    S(SExpr),
    J(JExpr),
    T(TExpr),
}

impl CExpr {
    fn ty(&self) -> Ty {
        match self {
            CExpr::R(_) => Ty::Real,
            CExpr::S(_) => Ty::Str,
            CExpr::J(_) => Ty::Joint,
            CExpr::T(_) => Ty::Trans,
        }
    }
}

/// An argument of CALL/EXECUTE: a value, and for a variable the variable (it receives the
/// parameter's final value).
#[derive(Debug, Clone)]
pub(crate) struct CArg {
    /// `None`: a whole array (`.$data[]`), the variable `var` names.
    pub(crate) value: Option<CExpr>,
    pub(crate) var: Option<(Ty, LRef)>,
}

/// One instruction of the flat code.
// An explicit one-byte tag (no niche in a field): a `match` is one load and a jump.
#[derive(Debug, Clone)]
#[repr(u8)]
pub(crate) enum Op {
    Nop,
    /// A jump to a label the program does not have (E0101 when reached).
    Fail(Box<str>),
    AssignR(LRef, RExpr),
    AssignS(LRef, SExpr),
    AssignJ(LRef, JExpr),
    AssignT(LRef, TExpr),
    Jump(usize),
    JumpIfNot(RExpr, usize),
    JumpIf(RExpr, usize),
    /// FOR: set the variable, keep the limit and step in hidden locals, skip the loop when
    /// already past the limit.
    ForInit {
        var: LRef,
        from: RExpr,
        to: RExpr,
        step: Option<RExpr>,
        limit: u32,
        step_slot: u32,
        exit: usize,
    },
    ForNext {
        var: LRef,
        limit: u32,
        step_slot: u32,
        body: usize,
    },
    /// CASE: remember the selector (a real or a string) in a hidden local.
    CaseSelR(RExpr, u32),
    CaseSelS(SExpr, u32),
    /// One VALUE arm: when no value equals the selector, jump to `next`.
    CaseTestR(Box<[RExpr]>, u32, usize),
    CaseTestS(Box<[SExpr]>, u32, usize),
    Call(usize, Box<[CArg]>),
    Return,
    /// `RETURNE`: a RETURN that resumes an error program's task after the failed step.
    ReturnAfterError,
    Print(Box<[Item]>),
    Twait(RExpr),
    Wait(RExpr),
    Halt,
    Stop,
    Pause,
    Signal(Box<[RExpr]>),
    /// `PULSE n[, t]`.
    Pulse(RExpr, Option<RExpr>),
    /// `RUNMASK n[, count]`.
    RunMask(RExpr, Option<RExpr>),
    /// `DLYSIG n, t`.
    Dlysig(RExpr, RExpr),
    /// `BITS start, count = value` (`BITS32`: true).
    Bits(bool, RExpr, RExpr, RExpr),
    /// `OPEN`/`CLOSE`/`RELAX[I] [hand]`: the action, the `I` form, the hand.
    Hand(HandAction, bool, Option<RExpr>),
    On {
        immediate: bool,
        signal: RExpr,
        goto: Option<usize>,
        call: Option<usize>,
    },
    Ignore(RExpr),
    Execute {
        program: usize,
        args: Box<[CArg]>,
        cycles: Option<RExpr>,
    },
    PcExecute {
        task: Option<RExpr>,
        program: usize,
        args: Box<[CArg]>,
        cycles: Option<RExpr>,
    },
    PcAbort(Option<RExpr>),
    /// `PCEND [n[: mode]]`: the task and the mode (−1 cancels).
    PcEnd(Option<RExpr>, Option<RExpr>),
    McAbort,
    McHold,
    McContinue,
    McSpeed(RExpr),
    McEreset,
    McZpower(bool),
    SetSwitch(usize, bool),
    Timer(RExpr, RExpr),
    /// `UTIMER @t = value`: the variable holds the clock's seconds when the timer read 0.
    UTimer(LRef, RExpr),
    Decompose(LRef, Loc),
    HereJ(LRef),
    HereT(LRef),
    Move(bool, Loc),
    Home,
    /// `LEFTY`, `RIGHTY`, `ABOVE`, `BELOW`, `UWRIST`, `DWRIST`.
    Posture(Posture),
    /// `TOOL`/`BASE` (true) with a transformation or NULL.
    Frame(bool, Option<TExpr>),
    /// `APPRO`/`LAPPRO` (linear) location, distance.
    Appro(bool, TExpr, RExpr),
    /// `DEPART`/`LDEPART` (linear) distance.
    Depart(bool, RExpr),
    /// `DRAW`/`TDRAW` (tool axes): X, Y, Z offsets, O, A, T of the rotation, and the speed
    /// (percent, this motion only).
    Draw(bool, Box<[Option<RExpr>; 7]>),
    /// `WEIGHT values…` (none: the rated payload).
    Weight(Box<[RExpr]>),
    /// `SOUT n = logic`: the output and the logic, its operands read as `SIG(n)`.
    Sout(RExpr, RExpr),
    /// `IFPWPRINT`/`IFPWOVERWRITE` (`true`: overwrite): window, row, column, colours, strings.
    IfpWrite(bool, Box<IfpWriteOp>),
    /// `IFPLABEL position, labels…` (`None`: a label not changed).
    IfpLabel(Box<(RExpr, Vec<Option<SExpr>>)>),
    /// `IFPTITLE page, title`.
    IfpTitle(Box<(RExpr, SExpr)>),
    /// `DRIVE joint, degrees[, speed]`.
    Drive(Box<(RExpr, RExpr, Option<RExpr>)>),
    /// `C1MOVE` (false: the via point) / `C2MOVE` (true: the end) location.
    Circle(bool, TExpr),
    /// `XMOVE location TILL signal`.
    Xmove(Loc, RExpr),
    /// `ALIGN`.
    Align,
    /// `HMOVE location`.
    Hmove(Loc),
    Delay(RExpr),
    Brake,
    Break,
    Speed(RExpr, SpeedUnit, bool),
    Accuracy(RExpr, bool, bool),
    AccelDecel(bool, RExpr, bool),
    Cp(bool),
    TcpListen(LRef, RExpr),
    TcpEndListen(LRef, RExpr),
    TcpAccept {
        ret: LRef,
        port: RExpr,
        timeout: Option<RExpr>,
        ip: Option<LRef>,
    },
    TcpRecv {
        ret: LRef,
        sock: RExpr,
        buf: LRef,
        count: LRef,
        timeout: Option<RExpr>,
        max: Option<RExpr>,
    },
    TcpSend {
        ret: LRef,
        sock: RExpr,
        buf: LRef,
        n: RExpr,
        timeout: Option<RExpr>,
    },
    TcpClose(LRef, RExpr),
    /// `TCP_STATUS ret, port[i], sock[i], err[i], sub[i], $ip[i]`.
    TcpStatus(LRef, Box<[LRef; 5]>),
    TcpConnect {
        ret: LRef,
        port: RExpr,
        ip: LRef,
        timeout: Option<RExpr>,
    },
    /// `UDP_SENDTO` (boxed: the op stays small).
    UdpSendTo(Box<UdpSendTo>),
    /// `UDP_RECVFROM` (boxed).
    UdpRecvFrom(Box<UdpRecvFrom>),
    /// `ONE program`: the task's error program (`None`: none).
    OnError(Option<usize>),
    /// An instruction that loads but is not emulated: the task stops with E0199 naming it.
    NotEmulated(Box<str>),
    /// One part of a block-teaching step (its line compiles to the parts in order).
    Block(BlockPart, Arc<BlockStep>),
    /// The end of the program (`.END`).
    End,
}

/// The parts of a block-teaching step, each an op (a part that waits runs again when its wait
/// ends, so each part has one wait).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum BlockPart {
    /// The tool, the speed, the accuracy, the motion, and `OX` when `OX.PREOUT` is ON.
    Move,
    /// At the pose: `OX` when `OX.PREOUT` is OFF, the timer (unless `AFTER.WAIT.TMR` puts it
    /// after the `WX` wait).
    Arrive,
    /// The `WX` wait, then the timer when `AFTER.WAIT.TMR` is ON.
    Inputs,
}

/// `UDP_SENDTO ret, ip[i], port, $buf[i], n[, timeout]`, compiled.
#[derive(Debug, Clone)]
pub(crate) struct UdpSendTo {
    pub(crate) ret: LRef,
    pub(crate) ip: LRef,
    pub(crate) port: RExpr,
    pub(crate) buf: LRef,
    pub(crate) n: RExpr,
    pub(crate) timeout: Option<RExpr>,
}

/// `UDP_RECVFROM ret, port, $buf[i], count[, timeout[, ip[i][, max]]]`, compiled.
#[derive(Debug, Clone)]
pub(crate) struct UdpRecvFrom {
    pub(crate) ret: LRef,
    pub(crate) port: RExpr,
    pub(crate) buf: LRef,
    pub(crate) count: LRef,
    pub(crate) timeout: Option<RExpr>,
    pub(crate) ip: Option<LRef>,
    pub(crate) max: Option<RExpr>,
}

/// A parameter of a compiled program.
#[derive(Debug, Clone)]
pub(crate) struct CParam {
    pub(crate) ty: Ty,
    pub(crate) slot: u32,
    pub(crate) by_ref: bool,
}

/// The operands of `IFPWPRINT`/`IFPWOVERWRITE`.
#[derive(Debug, Clone)]
pub(crate) struct IfpWriteOp {
    pub(crate) window: RExpr,
    /// Row, column, background colour, label colour (`None`: the window's last).
    pub(crate) place: [Option<RExpr>; 4],
    pub(crate) texts: Vec<SExpr>,
}

/// A compiled program.
#[derive(Debug, Clone)]
pub(crate) struct CProgram {
    pub(crate) name: String,
    pub(crate) module: usize,
    pub(crate) params: Vec<CParam>,
    pub(crate) ops: Vec<Op>,
    /// Source line of each op.
    pub(crate) lines: Vec<u32>,
    /// Whether each op reads or changes the system (motion, panel, error, sockets, the end
    /// of a program): the interpreter brings the system to the op's time first. Pure
    /// computation runs without it.
    pub(crate) touches: Vec<bool>,
    /// Number of local slots per type.
    pub(crate) locals: [usize; 4],
    /// Local names per type (for messages).
    pub(crate) local_names: [Vec<String>; 4],
    /// `false` for a program that is named (by CALL, EXECUTE, PCEXECUTE, ON … CALL) but that
    /// no loaded file defines: as on the controller, the name resolves when a task reaches
    /// it, and a task that does stops with E0119 (a later LOAD may define it).
    pub(crate) defined: bool,
    /// The line of its `.PROGRAM` header (step n is n lines below it; 0 for a placeholder).
    pub(crate) header_line: u32,
}

/// Everything loaded: programs, global names, data to load.
#[derive(Debug, Clone)]
pub(crate) struct Code {
    pub(crate) programs: Vec<CProgram>,
    pub(crate) by_name: HashMap<String, usize>,
    pub(crate) globals: [Vec<String>; 4],
    pub(crate) global_index: [HashMap<String, u32>; 4],
    pub(crate) data: Vec<(Ty, u32, Vec<i32>, DataValue)>,
    pub(crate) lines: Vec<Arc<[String]>>,
    pub(crate) warnings: Vec<ParseError>,
}

impl Code {
    /// The index of the program called `name`, when a loaded file defines it (not a
    /// placeholder for a program only named).
    pub(crate) fn defined(&self, name: &str) -> Option<usize> {
        self.by_name
            .get(name)
            .copied()
            .filter(|&p| self.programs.get(p).is_some_and(|p| p.defined))
    }

    /// The source text of a line of a program.
    pub(crate) fn line_text(&self, program: usize, line: u32) -> &str {
        self.programs
            .get(program)
            .and_then(|p| self.lines.get(p.module))
            .and_then(|l| l.get((line as usize).wrapping_sub(1)))
            .map_or("", |s| s.as_str())
    }

    pub(crate) fn global_name(&self, ty: Ty, slot: u32) -> &str {
        self.globals[ty as usize]
            .get(slot as usize)
            .map_or("?", |s| s.as_str())
    }
}

/// The name of a variable as written, from its type, scope and name.
pub(crate) fn var_display(ty: Ty, global: bool, name: &str) -> String {
    let sigil = match ty {
        Ty::Str => "$",
        Ty::Joint => "#",
        _ => "",
    };
    format!("{}{sigil}{name}", if global { "" } else { "." })
}

/// Compiles modules (all their programs share the globals).
pub(crate) fn compile(modules: &[crate::ast::Module]) -> Result<Code, LoadError> {
    let mut c = Compiler::new();
    // Program names first (CALL may name a program defined later or in another file).
    let mut order = Vec::new();
    for (mi, m) in modules.iter().enumerate() {
        for p in &m.programs {
            if let Some(&prev) = c.by_name.get(&p.name) {
                let (pm, _): &(usize, &Program) = &order[prev];
                c.errors.push(ParseError::new(
                    &m.file,
                    p.span,
                    format!(
                        "program {} is also defined in {}",
                        p.name, modules[*pm].file
                    ),
                ));
                continue;
            }
            c.by_name.insert(p.name.clone(), order.len());
            order.push((mi, p));
        }
    }
    let mut programs = Vec::new();
    c.defined = order.len();
    for &(_, p) in &order {
        let trans = p
            .params
            .iter()
            .map(|prm| prm.by_ref && prm.name.sigil == Sigil::None)
            .collect();
        c.trans_params.insert(p.name.clone(), trans);
    }
    for &(mi, p) in &order {
        c.file = modules[mi].file.to_string();
        programs.push(c.program(mi, p));
    }
    // Programs named but defined by no file: resolved when a task reaches them.
    for name in std::mem::take(&mut c.undefined) {
        programs.push(CProgram {
            name,
            module: 0,
            params: Vec::new(),
            ops: vec![Op::End],
            lines: vec![0],
            touches: vec![true],
            locals: [0; 4],
            local_names: Default::default(),
            defined: false,
            header_line: 0,
        });
    }
    // Data sections.
    let mut data = Vec::new();
    for m in modules {
        c.file = m.file.to_string();
        for d in &m.data {
            let ty = match d.value {
                DataValue::Real(_) => Ty::Real,
                DataValue::Str(_) => Ty::Str,
                DataValue::Joints(_) => Ty::Joint,
                DataValue::Trans(_) => Ty::Trans,
            };
            let slot = c.global(ty, &d.name.text);
            data.push((ty, slot, d.indices.clone(), d.value.clone()));
        }
    }
    if !c.errors.is_empty() {
        c.errors.truncate(MAX_REPORTED);
        return Err(LoadError { errors: c.errors });
    }
    Ok(Code {
        programs,
        by_name: c.by_name,
        globals: c.globals,
        global_index: c.global_index,
        data,
        lines: modules.iter().map(|m| Arc::from(m.lines.clone())).collect(),
        // Per file, in line order: the parser's and the compiler's together.
        warnings: modules
            .iter()
            .flat_map(|m| {
                let mut w = m.warnings.clone();
                w.extend(c.warnings.iter().filter(|x| x.file == m.file).cloned());
                w.sort_by_key(|x| x.span);
                w
            })
            .collect(),
    })
}

/// The name a statement typed at the terminal runs under: no AS name can be written so, so no
/// `CALL` reaches it.
pub(crate) const IMMEDIATE_PROGRAM: &str = "(terminal)";

/// Compiles one statement typed at the terminal, given as the body of `m`'s only program,
/// against the loaded `code`: its names are the loaded globals and programs, a variable it
/// names first becomes a new global. Appends it to `code` as the last program
/// ([`IMMEDIATE_PROGRAM`]) and gives its index; the caller removes it when it has run.
/// A statement that names a program no file defines is refused (nothing to run).
pub(crate) fn compile_immediate(
    code: &mut Code,
    m: &crate::ast::Module,
) -> Result<usize, LoadError> {
    let [p] = m.programs.as_slice() else {
        return Err(LoadError {
            errors: vec![ParseError::new(
                &m.file,
                Span::default(),
                "one statement is typed at a time",
            )],
        });
    };
    let mut c = Compiler::new();
    c.file = m.file.to_string();
    c.globals = code.globals.clone();
    c.global_index = code.global_index.clone();
    c.by_name = code.by_name.clone();
    c.defined = code.programs.len();
    for q in &code.programs {
        let trans = q.params.iter().map(|prm| prm.ty == Ty::Trans).collect();
        c.trans_params.insert(q.name.clone(), trans);
    }
    let mut program = c.program(code.lines.len(), p);
    if let Some(name) = c.undefined.first() {
        c.errors.push(c.err(
            p.span,
            format!("program {name} is not loaded (load the file that holds it)"),
        ));
    }
    if !c.errors.is_empty() {
        c.errors.truncate(MAX_REPORTED);
        return Err(LoadError { errors: c.errors });
    }
    program.name = IMMEDIATE_PROGRAM.to_owned();
    code.globals = c.globals;
    code.global_index = c.global_index;
    code.lines.push(Arc::from(m.lines.clone()));
    code.programs.push(program);
    Ok(code.programs.len() - 1)
}

struct Compiler {
    errors: Vec<ParseError>,
    file: String,
    globals: [Vec<String>; 4],
    global_index: [HashMap<String, u32>; 4],
    by_name: HashMap<String, usize>,
    /// How many programs the files define (the first indices).
    defined: usize,
    /// For each program, which parameters are transformations (`.&p`).
    trans_params: HashMap<String, Vec<bool>>,
    /// Programs named but not defined, in order of first use (indices after the defined ones).
    undefined: Vec<String>,
    // Per program being compiled:
    locals: [Vec<String>; 4],
    local_index: [HashMap<String, u32>; 4],
    ops: Vec<Op>,
    lines: Vec<u32>,
    labels: HashMap<String, (usize, Span)>,
    /// (op index, label) of jumps to resolve.
    fixups: Vec<(usize, Label)>,
    hidden: u32,
    /// Set when an expression calls a function the emulator does not compute: the statement
    /// then loads as not emulated.
    not_emulated_fn: Option<String>,
    /// Statements loaded as not emulated because of such a function.
    warnings: Vec<ParseError>,
}

type CResult<T> = Result<T, ParseError>;

impl Compiler {
    fn new() -> Compiler {
        Compiler {
            errors: Vec::new(),
            file: String::new(),
            globals: Default::default(),
            global_index: Default::default(),
            by_name: HashMap::new(),
            locals: Default::default(),
            local_index: Default::default(),
            ops: Vec::new(),
            lines: Vec::new(),
            labels: HashMap::new(),
            fixups: Vec::new(),
            hidden: 0,
            not_emulated_fn: None,
            warnings: Vec::new(),
            defined: 0,
            undefined: Vec::new(),
            trans_params: HashMap::new(),
        }
    }

    fn err(&self, span: Span, msg: impl Into<String>) -> ParseError {
        ParseError::new(&self.file, span, msg)
    }

    fn global(&mut self, ty: Ty, name: &str) -> u32 {
        let t = ty as usize;
        if let Some(&s) = self.global_index[t].get(name) {
            return s;
        }
        let s = self.globals[t].len() as u32;
        self.globals[t].push(name.to_owned());
        self.global_index[t].insert(name.to_owned(), s);
        s
    }

    fn local(&mut self, ty: Ty, name: &str) -> u32 {
        let t = ty as usize;
        if let Some(&s) = self.local_index[t].get(name) {
            return s;
        }
        let s = self.locals[t].len() as u32;
        self.locals[t].push(name.to_owned());
        self.local_index[t].insert(name.to_owned(), s);
        s
    }

    fn hidden_local(&mut self, ty: Ty) -> u32 {
        self.hidden += 1;
        let name = format!("~{}", self.hidden);
        self.local(ty, &name)
    }

    fn program(&mut self, module: usize, p: &Program) -> CProgram {
        self.locals = Default::default();
        self.local_index = Default::default();
        self.ops.clear();
        self.lines.clear();
        self.labels.clear();
        self.fixups.clear();
        self.hidden = 0;
        let mut params = Vec::new();
        for prm in &p.params {
            let ty = match prm.name.sigil {
                // `.&p`: a transformation parameter (AS-E p.4-12, `add(.&aa,.&bb,.&cc)`).
                Sigil::None if prm.by_ref => Ty::Trans,
                Sigil::None => Ty::Real,
                Sigil::Dollar => Ty::Str,
                Sigil::Hash => Ty::Joint,
            };
            if self.local_index[ty as usize].contains_key(&prm.name.text) {
                self.errors
                    .push(self.err(prm.span, format!("parameter {} appears twice", prm.name)));
            }
            let slot = self.local(ty, &prm.name.text);
            params.push(CParam {
                ty,
                slot,
                by_ref: prm.by_ref,
            });
        }
        self.block(&p.body);
        self.emit(Op::End, p.end_line);
        let fixups = std::mem::take(&mut self.fixups);
        for (at, label) in fixups {
            match self.labels.get(&label.name) {
                Some(&(target, _)) => match &mut self.ops[at] {
                    Op::Jump(t) | Op::JumpIf(_, t) => *t = target,
                    Op::On { goto, .. } => *goto = Some(target),
                    _ => {}
                },
                None => {
                    // As on the controller, a missing label is found when the jump runs
                    // (E0101); the lint reports it.
                    let target = self.ops.len();
                    self.ops.push(Op::Fail(
                        format!("label {} in program {}", label.name, p.name).into(),
                    ));
                    self.lines.push(label.span.line);
                    match &mut self.ops[at] {
                        Op::Jump(t) | Op::JumpIf(_, t) => *t = target,
                        Op::On { goto, .. } => *goto = Some(target),
                        _ => {}
                    }
                    self.warnings.push(ParseError::new(
                        &self.file,
                        label.span,
                        format!(
                            "label {} is not defined in program {}: a task that jumps there stops with E0101",
                            label.name, p.name
                        ),
                    ));
                }
            }
        }
        let touches = self.ops.iter().map(op_touches).collect();
        CProgram {
            name: p.name.clone(),
            module,
            params,
            touches,
            ops: std::mem::take(&mut self.ops),
            lines: std::mem::take(&mut self.lines),
            locals: [
                self.locals[0].len(),
                self.locals[1].len(),
                self.locals[2].len(),
                self.locals[3].len(),
            ],
            local_names: std::mem::take(&mut self.locals),
            defined: true,
            header_line: p.span.line,
        }
    }

    fn emit(&mut self, op: Op, line: u32) -> usize {
        self.ops.push(op);
        self.lines.push(line);
        self.ops.len() - 1
    }

    fn block(&mut self, stmts: &[Stmt]) {
        for s in stmts {
            self.not_emulated_fn = None;
            if let Err(e) = self.stmt(s) {
                if let Some(f) = self.not_emulated_fn.take() {
                    let instruction = if f.starts_with("POINT") {
                        f
                    } else {
                        format!("the function {f}")
                    };
                    self.emit(Op::NotEmulated(instruction.as_str().into()), s.span.line);
                    self.warnings.push(ParseError::new(&self.file, e.span, format!("{instruction} loads but is not emulated: a task that reaches this line stops with {}", crate::error::NOT_EMULATED)));
                    continue;
                }
                if self.errors.len() < MAX_REPORTED {
                    self.errors.push(e);
                }
            }
        }
    }

    fn set_target(&mut self, at: usize, target: usize) {
        match &mut self.ops[at] {
            Op::Jump(t) | Op::JumpIfNot(_, t) | Op::JumpIf(_, t) => *t = target,
            Op::ForInit { exit, .. } => *exit = target,
            Op::CaseTestR(_, _, t) | Op::CaseTestS(_, _, t) => *t = target,
            _ => {}
        }
    }

    fn stmt(&mut self, s: &Stmt) -> CResult<()> {
        let line = s.span.line;
        if let Some(l) = &s.label {
            let here = self.ops.len();
            if let Some((_, prev)) = self.labels.insert(l.name.clone(), (here, l.span)) {
                return Err(self.err(
                    l.span,
                    format!(
                        "label {} is defined twice (first at line {})",
                        l.name, prev.line
                    ),
                ));
            }
        }
        match &s.kind {
            StmtKind::NotEmulated {
                instruction,
                stubbed,
            } => {
                let op = if *stubbed {
                    Op::Nop
                } else {
                    Op::NotEmulated(instruction.as_str().into())
                };
                self.emit(op, line);
            }
            StmtKind::BlockStep(step) => {
                let step: Arc<BlockStep> = Arc::new((**step).clone());
                self.emit(Op::Block(BlockPart::Move, step.clone()), line);
                self.emit(Op::Block(BlockPart::Arrive, step.clone()), line);
                if !step.inputs.is_empty() {
                    self.emit(Op::Block(BlockPart::Inputs, step.clone()), line);
                }
                if step.end {
                    self.emit(Op::Return, line);
                }
            }
            StmtKind::Empty => {
                if s.label.is_some() {
                    self.emit(Op::Nop, line);
                }
            }
            StmtKind::Assign { target, value } => {
                let op = self.assign(target, value)?;
                self.emit(op, line);
            }
            StmtKind::If {
                cond,
                then,
                otherwise,
            } => {
                let c = self.real(cond)?;
                let jf = self.emit(Op::JumpIfNot(c, 0), line);
                self.block(then);
                if otherwise.is_empty() {
                    let end = self.ops.len();
                    self.set_target(jf, end);
                } else {
                    let jend = self.emit(Op::Jump(0), line);
                    let else_at = self.ops.len();
                    self.set_target(jf, else_at);
                    self.block(otherwise);
                    let end = self.ops.len();
                    self.set_target(jend, end);
                }
            }
            StmtKind::IfGoto { cond, label } => {
                let c = self.real(cond)?;
                let at = self.emit(Op::JumpIf(c, 0), line);
                self.fixups.push((at, label.clone()));
            }
            StmtKind::While { cond, body } => {
                let c = self.real(cond)?;
                let top = self.emit(Op::JumpIfNot(c, 0), line);
                self.block(body);
                let back = self.ops.len();
                self.emit(Op::Jump(top), line);
                let _ = back;
                let end = self.ops.len();
                self.set_target(top, end);
            }
            StmtKind::DoUntil { body, cond } => {
                let top = self.ops.len();
                self.emit(Op::Nop, line);
                self.block(body);
                let c = self.real(cond)?;
                let until_line = cond.span.line;
                self.emit(Op::JumpIfNot(c, top), until_line);
            }
            StmtKind::For {
                var,
                from,
                to,
                step,
                body,
            } => {
                let v = self.lref(var, Ty::Real)?;
                let from = self.real(from)?;
                let to = self.real(to)?;
                let step = step.as_ref().map(|e| self.real(e)).transpose()?;
                let limit = self.hidden_local(Ty::Real);
                let step_slot = self.hidden_local(Ty::Real);
                let init = self.emit(
                    Op::ForInit {
                        var: v.clone(),
                        from,
                        to,
                        step,
                        limit,
                        step_slot,
                        exit: 0,
                    },
                    line,
                );
                let body_at = self.ops.len();
                self.block(body);
                self.emit(
                    Op::ForNext {
                        var: v,
                        limit,
                        step_slot,
                        body: body_at,
                    },
                    line,
                );
                let end = self.ops.len();
                self.set_target(init, end);
            }
            StmtKind::Case { selector, arms } => {
                let sel = self.expr(selector)?;
                let (is_str, slot) = match sel {
                    CExpr::R(r) => {
                        let slot = self.hidden_local(Ty::Real);
                        self.emit(Op::CaseSelR(r, slot), line);
                        (false, slot)
                    }
                    CExpr::S(sx) => {
                        let slot = self.hidden_local(Ty::Str);
                        self.emit(Op::CaseSelS(sx, slot), line);
                        (true, slot)
                    }
                    other => {
                        return Err(self.err(
                            selector.span,
                            format!("CASE needs a real or a string, found {}", other.ty().name()),
                        ));
                    }
                };
                let mut ends = Vec::new();
                for arm in arms {
                    let test = match &arm.values {
                        Some(values) => {
                            let at = if is_str {
                                let v = values
                                    .iter()
                                    .map(|e| self.string(e))
                                    .collect::<CResult<Vec<_>>>()?;
                                self.emit(Op::CaseTestS(v.into(), slot, 0), arm.span.line)
                            } else {
                                let v = values
                                    .iter()
                                    .map(|e| self.real(e))
                                    .collect::<CResult<Vec<_>>>()?;
                                self.emit(Op::CaseTestR(v.into(), slot, 0), arm.span.line)
                            };
                            Some(at)
                        }
                        None => None,
                    };
                    self.block(&arm.body);
                    ends.push(self.emit(Op::Jump(0), arm.span.line));
                    if let Some(at) = test {
                        let next = self.ops.len();
                        self.set_target(at, next);
                    }
                }
                let end = self.ops.len();
                for j in ends {
                    self.set_target(j, end);
                }
            }
            StmtKind::Goto(label) => {
                let at = self.emit(Op::Jump(0), line);
                self.fixups.push((at, label.clone()));
            }
            StmtKind::Call { program, args } => {
                let p = self.program_ref(program, s.span)?;
                let args = self.args(program, args)?;
                self.emit(Op::Call(p, args), line);
            }
            StmtKind::Return => {
                self.emit(Op::Return, line);
            }
            StmtKind::ReturnAfterError => {
                self.emit(Op::ReturnAfterError, line);
            }
            StmtKind::Print { items } => {
                let items = self.items(items)?;
                self.emit(Op::Print(items), line);
            }
            StmtKind::Twait(e) => {
                let e = self.real(e)?;
                self.emit(Op::Twait(e), line);
            }
            StmtKind::Wait(e) => {
                let e = self.real(e)?;
                self.emit(Op::Wait(e), line);
            }
            StmtKind::Halt => {
                self.emit(Op::Halt, line);
            }
            StmtKind::Stop => {
                self.emit(Op::Stop, line);
            }
            StmtKind::Pause => {
                self.emit(Op::Pause, line);
            }
            StmtKind::Signal(v) => {
                let v = v
                    .iter()
                    .map(|e| self.real(e))
                    .collect::<CResult<Vec<_>>>()?;
                self.emit(Op::Signal(v.into()), line);
            }
            StmtKind::Swait(v) => {
                // `SWAIT a, b` is `WAIT SIG(a, b)`: the same poll, the same checks.
                let v = v
                    .iter()
                    .map(|e| self.real(e))
                    .collect::<CResult<Vec<_>>>()?;
                self.emit(Op::Wait(RExpr::Func(RFunc::Sig, v.into())), line);
            }
            StmtKind::Pulse { signal, time } => {
                let signal = self.real(signal)?;
                let time = time.as_ref().map(|t| self.real(t)).transpose()?;
                self.emit(Op::Pulse(signal, time), line);
            }
            StmtKind::RunMask { signal, count } => {
                let signal = self.real(signal)?;
                let count = count.as_ref().map(|c| self.real(c)).transpose()?;
                self.emit(Op::RunMask(signal, count), line);
            }
            StmtKind::Dlysig { signal, time } => {
                let signal = self.real(signal)?;
                let time = self.real(time)?;
                self.emit(Op::Dlysig(signal, time), line);
            }
            StmtKind::Bits {
                wide,
                start,
                count,
                value,
            } => {
                let start = self.real(start)?;
                let count = self.real(count)?;
                let value = self.real(value)?;
                self.emit(Op::Bits(*wide, start, count, value), line);
            }
            StmtKind::Hand {
                action,
                immediate,
                hand,
            } => {
                let hand = hand.as_ref().map(|h| self.real(h)).transpose()?;
                self.emit(Op::Hand(*action, *immediate, hand), line);
            }
            StmtKind::On {
                immediate,
                signal,
                action,
            } => {
                let signal = self.real(signal)?;
                match action {
                    OnAction::Goto(label) => {
                        let at = self.emit(
                            Op::On {
                                immediate: *immediate,
                                signal,
                                goto: None,
                                call: None,
                            },
                            line,
                        );
                        self.fixups.push((at, label.clone()));
                    }
                    OnAction::Call(p) => {
                        let p = self.program_ref(p, s.span)?;
                        self.emit(
                            Op::On {
                                immediate: *immediate,
                                signal,
                                goto: None,
                                call: Some(p),
                            },
                            line,
                        );
                    }
                }
            }
            StmtKind::Ignore(e) => {
                let e = self.real(e)?;
                self.emit(Op::Ignore(e), line);
            }
            StmtKind::Monitor(m) => {
                let op = match m {
                    MonitorCommand::Execute {
                        program,
                        args,
                        cycles,
                    } => Op::Execute {
                        program: self.program_ref(program, s.span)?,
                        args: self.args(program, args)?,
                        cycles: cycles.as_ref().map(|e| self.real(e)).transpose()?,
                    },
                    MonitorCommand::PcExecute {
                        task,
                        program,
                        args,
                        cycles,
                    } => Op::PcExecute {
                        task: task.as_ref().map(|e| self.real(e)).transpose()?,
                        program: self.program_ref(program, s.span)?,
                        args: self.args(program, args)?,
                        cycles: cycles.as_ref().map(|e| self.real(e)).transpose()?,
                    },
                    MonitorCommand::PcAbort { task } => {
                        Op::PcAbort(task.as_ref().map(|e| self.real(e)).transpose()?)
                    }
                    MonitorCommand::PcEnd { task, mode } => Op::PcEnd(
                        task.as_ref().map(|e| self.real(e)).transpose()?,
                        mode.as_ref().map(|e| self.real(e)).transpose()?,
                    ),
                    MonitorCommand::Abort => Op::McAbort,
                    MonitorCommand::Hold => Op::McHold,
                    MonitorCommand::Continue => Op::McContinue,
                    MonitorCommand::Speed(e) => Op::McSpeed(self.real(e)?),
                    MonitorCommand::Ereset => Op::McEreset,
                    MonitorCommand::Zpower(on) => Op::McZpower(*on),
                };
                self.emit(op, line);
            }
            StmtKind::SetSwitch { name, on } => {
                let idx = keywords::SYSTEM_SWITCHES
                    .iter()
                    .position(|(n, _)| n == name)
                    .ok_or_else(|| {
                        self.err(
                            s.span,
                            format!("{} is not a system switch", name.to_uppercase()),
                        )
                    })?;
                self.emit(Op::SetSwitch(idx, *on), line);
            }
            StmtKind::Timer { timer, value } => {
                let t = self.real(timer)?;
                let v = self.real(value)?;
                self.emit(Op::Timer(t, v), line);
            }
            StmtKind::UTimer { timer, value } => {
                let t = self.lref(timer, Ty::Real)?;
                let v = self.real(value)?;
                self.emit(Op::UTimer(t, v), line);
            }
            StmtKind::Decompose { target, source } => {
                let t = self.lref(target, Ty::Real)?;
                let src = self.loc(source)?;
                self.emit(Op::Decompose(t, src), line);
            }
            StmtKind::Here {
                target,
                relative_to,
            } if !relative_to.is_empty() => {
                // `HERE a+b`: b = -a + HERE (a must be defined: E0103 otherwise).
                let mut base: Option<TExpr> = None;
                for lv in relative_to.iter().chain(std::iter::once(target)) {
                    if lv.name.sigil != Sigil::None {
                        return Err(self.err(
                            lv.span,
                            "a compound HERE (a+b) is made of transformation variables",
                        ));
                    }
                }
                for lv in relative_to {
                    let v = TExpr::Var(self.lref(lv, Ty::Trans)?);
                    base = Some(match base {
                        None => v,
                        Some(b) => TExpr::Compose(Box::new(b), Box::new(v)),
                    });
                }
                let t = self.lref(target, Ty::Trans)?;
                let value = match base {
                    Some(b) => {
                        TExpr::Compose(Box::new(TExpr::Inverse(Box::new(b))), Box::new(TExpr::Here))
                    }
                    None => TExpr::Here,
                };
                self.emit(Op::AssignT(t, value), line);
            }
            StmtKind::Here { target, .. } => {
                let op = match target.name.sigil {
                    Sigil::Hash => Op::HereJ(self.lref(target, Ty::Joint)?),
                    Sigil::None => Op::HereT(self.lref(target, Ty::Trans)?),
                    Sigil::Dollar => {
                        return Err(self.err(
                            target.span,
                            "HERE needs a location variable (#name or name)",
                        ))
                    }
                };
                self.emit(op, line);
            }
            StmtKind::Point { target, value } => {
                let op = match target.name.sigil {
                    Sigil::Hash => {
                        let t = self.lref(target, Ty::Joint)?;
                        match self.loc(value)? {
                            Loc::J(j) => Op::AssignJ(t, j),
                            Loc::T(x) => Op::AssignJ(t, JExpr::Inverse(Box::new(x))),
                            Loc::Named(_) => return Err(self.named_not_emulated(value.span)),
                        }
                    }
                    Sigil::None => {
                        let t = self.lref(target, Ty::Trans)?;
                        match self.loc(value)? {
                            Loc::T(x) => Op::AssignT(t, x),
                            Loc::J(j) => Op::AssignT(t, TExpr::Forward(Box::new(j))),
                            Loc::Named(_) => return Err(self.named_not_emulated(value.span)),
                        }
                    }
                    Sigil::Dollar => {
                        return Err(self.err(
                            target.span,
                            "POINT needs a location variable (#name or name)",
                        ))
                    }
                };
                self.emit(op, line);
            }
            StmtKind::Move { linear, target } => {
                let l = self.loc(target)?;
                self.emit(Op::Move(*linear, l), line);
            }
            StmtKind::Posture(p) => {
                self.emit(Op::Posture(*p), line);
            }
            StmtKind::Frame { base, value } => {
                let t = match value {
                    Some(v) => Some(self.trans_loc(v)?),
                    None => None,
                };
                self.emit(Op::Frame(*base, t), line);
            }
            StmtKind::Appro {
                linear,
                target,
                distance,
            } => {
                let t = self.trans_loc(target)?;
                let d = self.real(distance)?;
                self.emit(Op::Appro(*linear, t, d), line);
            }
            StmtKind::Depart { linear, distance } => {
                let d = self.real(distance)?;
                self.emit(Op::Depart(*linear, d), line);
            }
            StmtKind::Draw {
                tool,
                offset,
                rotation,
                speed,
            } => {
                let mut v: [Option<RExpr>; 7] = Default::default();
                let speed = speed.as_deref().cloned();
                for (k, e) in offset.iter().chain(rotation).chain([&speed]).enumerate() {
                    if let Some(e) = e {
                        v[k] = Some(self.real(e)?);
                    }
                }
                self.emit(Op::Draw(*tool, Box::new(v)), line);
            }
            StmtKind::Weight { values } => {
                let values = values
                    .iter()
                    .map(|e| self.real(e))
                    .collect::<CResult<Vec<_>>>()?;
                self.emit(Op::Weight(values.into()), line);
            }
            StmtKind::Sout { signal, logic } => {
                let op = Op::Sout(self.real(signal)?, self.signal_logic(logic)?);
                self.emit(op, line);
            }
            StmtKind::IfpWrite {
                overwrite,
                window,
                place,
                texts,
            } => {
                let mut compiled: [Option<RExpr>; 4] = Default::default();
                for (slot, e) in compiled.iter_mut().zip(place) {
                    if let Some(e) = e {
                        *slot = Some(self.real(e)?);
                    }
                }
                let op = IfpWriteOp {
                    window: self.real(window)?,
                    place: compiled,
                    texts: texts
                        .iter()
                        .map(|t| self.string(t))
                        .collect::<CResult<_>>()?,
                };
                self.emit(Op::IfpWrite(*overwrite, Box::new(op)), line);
            }
            StmtKind::IfpLabel { position, labels } => {
                let labels = labels
                    .iter()
                    .map(|l| l.as_ref().map(|e| self.string(e)).transpose())
                    .collect::<CResult<_>>()?;
                let position = self.real(position)?;
                self.emit(Op::IfpLabel(Box::new((position, labels))), line);
            }
            StmtKind::IfpTitle { page, title } => {
                let op = Op::IfpTitle(Box::new((self.real(page)?, self.string(title)?)));
                self.emit(op, line);
            }
            StmtKind::Drive {
                joint,
                degrees,
                speed,
            } => {
                let speed = speed.as_ref().map(|e| self.real(e)).transpose()?;
                let op = Op::Drive(Box::new((self.real(joint)?, self.real(degrees)?, speed)));
                self.emit(op, line);
            }
            StmtKind::CircleVia(target) | StmtKind::CircleEnd(target) => {
                let end = matches!(&s.kind, StmtKind::CircleEnd(_));
                let t = self.trans_loc(target)?;
                self.emit(Op::Circle(end, t), line);
            }
            StmtKind::Xmove { target, till } => {
                let l = self.loc(target)?;
                let till = self.real(till)?;
                self.emit(Op::Xmove(l, till), line);
            }
            StmtKind::Align => {
                self.emit(Op::Align, line);
            }
            StmtKind::Hmove(target) => {
                let l = self.loc(target)?;
                self.emit(Op::Hmove(l), line);
            }
            StmtKind::Home(_) => {
                self.emit(Op::Home, line);
            }
            StmtKind::Delay(e) => {
                let e = self.real(e)?;
                self.emit(Op::Delay(e), line);
            }
            StmtKind::Brake => {
                self.emit(Op::Brake, line);
            }
            StmtKind::Break => {
                self.emit(Op::Break, line);
            }
            StmtKind::Speed {
                value,
                unit,
                always,
            } => {
                let v = self.real(value)?;
                self.emit(Op::Speed(v, *unit, *always), line);
            }
            StmtKind::Accuracy {
                value,
                fine,
                always,
            } => {
                let v = self.real(value)?;
                self.emit(Op::Accuracy(v, *fine, *always), line);
            }
            StmtKind::AccelDecel {
                decel,
                value,
                always,
            } => {
                let v = self.real(value)?;
                self.emit(Op::AccelDecel(*decel, v, *always), line);
            }
            StmtKind::Cp(on) => {
                self.emit(Op::Cp(*on), line);
            }
            StmtKind::Tcp(t) => {
                let op = self.tcp(t)?;
                self.emit(op, line);
            }
            StmtKind::Udp(u) => {
                let op = self.udp(u)?;
                self.emit(op, line);
            }
            StmtKind::OnError(program) => {
                // An error program that is not loaded is a warning, not a load error (it may
                // be in another file): a task that fails then stops as without ONE.
                let p = match program.as_deref() {
                    Some(name) => {
                        let p = self.by_name.get(name).copied();
                        if p.is_none() {
                            self.warnings.push(ParseError::new(
                                &self.file,
                                s.span,
                                format!("ONE {name}: program {name} is not defined (load the file that holds it); a task that fails stops as without ONE"),
                            ));
                        }
                        p
                    }
                    None => None,
                };
                self.emit(Op::OnError(p), line);
            }
        }
        Ok(())
    }

    fn tcp(&mut self, t: &TcpStmt) -> CResult<Op> {
        Ok(match t {
            TcpStmt::Listen { ret, port } => {
                Op::TcpListen(self.lref(ret, Ty::Real)?, self.real(port)?)
            }
            TcpStmt::EndListen { ret, port } => {
                Op::TcpEndListen(self.lref(ret, Ty::Real)?, self.real(port)?)
            }
            TcpStmt::Accept {
                ret,
                port,
                timeout,
                ip,
            } => Op::TcpAccept {
                ret: self.lref(ret, Ty::Real)?,
                port: self.real(port)?,
                timeout: timeout.as_ref().map(|e| self.real(e)).transpose()?,
                ip: ip.as_ref().map(|l| self.lref(l, Ty::Real)).transpose()?,
            },
            TcpStmt::Recv {
                ret,
                sock,
                buf,
                count,
                timeout,
                max,
            } => Op::TcpRecv {
                ret: self.lref(ret, Ty::Real)?,
                sock: self.real(sock)?,
                buf: self.lref(buf, Ty::Str)?,
                count: self.lref(count, Ty::Real)?,
                timeout: timeout.as_ref().map(|e| self.real(e)).transpose()?,
                max: max.as_ref().map(|e| self.real(e)).transpose()?,
            },
            TcpStmt::Send {
                ret,
                sock,
                buf,
                n,
                timeout,
            } => Op::TcpSend {
                ret: self.lref(ret, Ty::Real)?,
                sock: self.real(sock)?,
                buf: self.lref(buf, Ty::Str)?,
                n: self.real(n)?,
                timeout: timeout.as_ref().map(|e| self.real(e)).transpose()?,
            },
            TcpStmt::Status { ret, arrays } => {
                let [port, sock, err, sub, ip] = arrays;
                Op::TcpStatus(
                    self.lref(ret, Ty::Real)?,
                    Box::new([
                        self.lref(port, Ty::Real)?,
                        self.lref(sock, Ty::Real)?,
                        self.lref(err, Ty::Real)?,
                        self.lref(sub, Ty::Real)?,
                        self.lref(ip, Ty::Str)?,
                    ]),
                )
            }
            TcpStmt::Close { ret, sock } => {
                Op::TcpClose(self.lref(ret, Ty::Real)?, self.real(sock)?)
            }
            TcpStmt::Connect {
                ret,
                port,
                ip,
                timeout,
            } => Op::TcpConnect {
                ret: self.lref(ret, Ty::Real)?,
                port: self.real(port)?,
                ip: self.lref(ip, Ty::Real)?,
                timeout: timeout.as_ref().map(|e| self.real(e)).transpose()?,
            },
        })
    }

    fn udp(&mut self, u: &UdpStmt) -> CResult<Op> {
        Ok(match u {
            UdpStmt::SendTo {
                ret,
                ip,
                port,
                buf,
                n,
                timeout,
            } => Op::UdpSendTo(Box::new(UdpSendTo {
                ret: self.lref(ret, Ty::Real)?,
                ip: self.lref(ip, Ty::Real)?,
                port: self.real(port)?,
                buf: self.lref(buf, Ty::Str)?,
                n: self.real(n)?,
                timeout: timeout.as_ref().map(|e| self.real(e)).transpose()?,
            })),
            UdpStmt::RecvFrom {
                ret,
                port,
                buf,
                count,
                timeout,
                ip,
                max,
            } => Op::UdpRecvFrom(Box::new(UdpRecvFrom {
                ret: self.lref(ret, Ty::Real)?,
                port: self.real(port)?,
                buf: self.lref(buf, Ty::Str)?,
                count: self.lref(count, Ty::Real)?,
                timeout: timeout.as_ref().map(|e| self.real(e)).transpose()?,
                ip: ip.as_ref().map(|l| self.lref(l, Ty::Real)).transpose()?,
                max: max.as_ref().map(|e| self.real(e)).transpose()?,
            })),
        })
    }

    /// The index of a named program; a program no file defines gets a placeholder, resolved
    /// when a task reaches it (E0119 then).
    fn program_ref(&mut self, name: &str, _span: Span) -> CResult<usize> {
        if let Some(&p) = self.by_name.get(name) {
            return Ok(p);
        }
        let p = self.defined + self.undefined.len();
        self.undefined.push(name.to_owned());
        self.by_name.insert(name.to_owned(), p);
        Ok(p)
    }

    /// The arguments of a CALL, EXECUTE or PCEXECUTE of `program`. A plain name given for a
    /// transformation parameter (`.&p`) is the transformation of that name (`CALL add(&a)`,
    /// the `&` being optional).
    fn args(&mut self, program: &str, args: &[CallArg]) -> CResult<Box<[CArg]>> {
        let mut out = Vec::new();
        let trans_params = self.trans_params.get(program).cloned().unwrap_or_default();
        for (
            k,
            CallArg {
                value: a,
                whole_array,
            },
        ) in args.iter().enumerate()
        {
            let trans_param = trans_params.get(k) == Some(&true);
            if *whole_array {
                let ExprKind::Var(lv) = &a.kind else {
                    return Err(self.err(a.span, "a whole array argument is a variable (name[])"));
                };
                let ty = match lv.name.sigil {
                    Sigil::None if trans_param => Ty::Trans,
                    Sigil::None => Ty::Real,
                    Sigil::Dollar => Ty::Str,
                    Sigil::Hash => Ty::Joint,
                };
                let l = self.lref(lv, ty)?;
                out.push(CArg {
                    value: None,
                    var: Some((ty, l)),
                });
                continue;
            }
            let value = match &a.kind {
                ExprKind::Var(lv)
                    if trans_param
                        && lv.name.sigil == Sigil::None
                        && !is_name_function(&lv.name) =>
                {
                    CExpr::T(TExpr::Var(self.lref(lv, Ty::Trans)?))
                }
                _ => self.expr(a)?,
            };
            let var = match &a.kind {
                ExprKind::Var(lv) if !is_name_function(&lv.name) => {
                    let ty = value.ty();
                    Some((ty, self.lref(lv, ty)?))
                }
                _ => None,
            };
            out.push(CArg {
                value: Some(value),
                var,
            });
        }
        Ok(out.into())
    }

    fn items(&mut self, items: &[PrintItem]) -> CResult<Box<[Item]>> {
        items
            .iter()
            .map(|it| match it {
                PrintItem::Format(f, _) => Ok(Item::Format(*f)),
                PrintItem::Expr(e) => match self.expr(e)? {
                    CExpr::R(r) => Ok(Item::Real(r)),
                    CExpr::S(s) => Ok(Item::Str(s)),
                    other => Err(self.err(e.span, format!("PRINT and $ENCODE take reals and strings, found {} (DECOMPOSE it into reals first)", other.ty().name()))),
                },
            })
            .collect::<CResult<Vec<_>>>()
            .map(Into::into)
    }

    fn assign(&mut self, target: &LValue, value: &Expr) -> CResult<Op> {
        let ty = match target.name.sigil {
            Sigil::None => Ty::Real,
            Sigil::Dollar => Ty::Str,
            Sigil::Hash => Ty::Joint,
        };
        if !target.name.local && is_name_function(&target.name) {
            return Err(self.err(
                target.span,
                format!(
                    "{} is a reserved word and cannot be assigned",
                    target.name.text.to_uppercase()
                ),
            ));
        }
        let l = self.lref(target, ty)?;
        Ok(match ty {
            Ty::Real => Op::AssignR(l, self.real(value)?),
            Ty::Str => Op::AssignS(l, self.string(value)?),
            _ => match self.loc(value)? {
                Loc::J(j) => Op::AssignJ(l, j),
                Loc::Named(_) => return Err(self.named_not_emulated(value.span)),
                Loc::T(_) => {
                    return Err(self.err(
                        value.span,
                        "a joint point needs a joint value (#PPOINT(…), #HERE or #name)",
                    ))
                }
            },
        })
    }

    fn lref(&mut self, lv: &LValue, ty: Ty) -> CResult<LRef> {
        let want = match ty {
            Ty::Real | Ty::Trans => Sigil::None,
            Ty::Str => Sigil::Dollar,
            Ty::Joint => Sigil::Hash,
        };
        if lv.name.sigil != want {
            return Err(self.err(
                lv.span,
                format!("expected {} variable, found {}", ty.name(), lv.name),
            ));
        }
        let idx = lv
            .indices
            .iter()
            .map(|e| self.real(e))
            .collect::<CResult<Vec<_>>>()?;
        let var = if lv.name.local {
            VarRef {
                global: false,
                slot: self.local(ty, &lv.name.text),
            }
        } else {
            VarRef {
                global: true,
                slot: self.global(ty, &lv.name.text),
            }
        };
        Ok(LRef {
            var,
            idx: idx.into(),
        })
    }

    fn real(&mut self, e: &Expr) -> CResult<RExpr> {
        match self.expr(e)? {
            CExpr::R(r) => Ok(r),
            other => Err(self.err(
                e.span,
                format!("expected a real value, found {}", other.ty().name()),
            )),
        }
    }

    /// A signal expression (`SOUT`, AS-E p.6-88): `AND`, `OR`, `XOR` and `NOT` of operands
    /// that are signal numbers, each read as `SIG(n)` (`-1001`: input 1001 OFF).
    fn signal_logic(&mut self, e: &Expr) -> CResult<RExpr> {
        Ok(match &e.kind {
            ExprKind::Binary(op @ (BinOp::And | BinOp::Or | BinOp::Xor), a, b) => RExpr::Bin(
                *op,
                Box::new(self.signal_logic(a)?),
                Box::new(self.signal_logic(b)?),
            ),
            ExprKind::Unary(UnOp::Not, a) => RExpr::Not(Box::new(self.signal_logic(a)?)),
            _ => RExpr::Func(RFunc::Sig, Box::new([self.real(e)?])),
        })
    }

    fn string(&mut self, e: &Expr) -> CResult<SExpr> {
        match self.expr(e)? {
            CExpr::S(s) => Ok(s),
            other => Err(self.err(
                e.span,
                format!("expected a string, found {}", other.ty().name()),
            )),
        }
    }

    /// A location: a joint point or a transformation (a plain name is a transformation here).
    fn loc(&mut self, e: &Expr) -> CResult<Loc> {
        match &e.kind {
            ExprKind::Var(lv) if lv.name.sigil == Sigil::None && !lv.name.local && lv.name.text == "here" && lv.indices.is_empty() => Ok(Loc::T(TExpr::Here)),
            ExprKind::Var(lv) if lv.name.sigil == Sigil::None && !lv.name.local && lv.name.text == "dest" && lv.indices.is_empty() => Ok(Loc::T(TExpr::Dest)),
            ExprKind::Var(lv) if lv.name.sigil == Sigil::None => Ok(Loc::T(TExpr::Var(self.lref(lv, Ty::Trans)?))),
            ExprKind::Call { name, args } if name.sigil == Sigil::None && name.text == "trans" => {
                Ok(Loc::T(TExpr::Trans(self.reals_up_to(args, 6, "TRANS", e.span)?)))
            }
            ExprKind::Call { name, args } if name.sigil == Sigil::None && name.text == "strtopos" => {
                self.arity(name, args, 1, 1, e.span)?;
                Ok(Loc::Named(self.arg_str(&args[0])?))
            }
            ExprKind::Binary(op @ (BinOp::Add | BinOp::Sub), a, b) => {
                match (self.loc(a)?, self.loc(b)?) {
                    (Loc::T(x), Loc::T(y)) => {
                        let y = if *op == BinOp::Sub {
                            TExpr::Inverse(Box::new(y))
                        } else {
                            y
                        };
                        Ok(Loc::T(TExpr::Compose(Box::new(x), Box::new(y))))
                    }
                    _ => Err(self.err(
                        e.span,
                        "only transformations can be composed with + and -",
                    )),
                }
            }
            ExprKind::Unary(UnOp::Neg, a) => match self.loc(a)? {
                Loc::T(t) => Ok(Loc::T(TExpr::Inverse(Box::new(t)))),
                Loc::J(_) => Err(self.err(e.span, "a joint point has no inverse")),
                Loc::Named(_) => Err(self.named_not_emulated(e.span)),
            },
            _ => match self.expr(e)? {
                CExpr::J(j) => Ok(Loc::J(j)),
                CExpr::T(t) => Ok(Loc::T(t)),
                other => Err(self.err(e.span, format!("expected a location (#point, #PPOINT(…), a transformation, HERE), found {}", other.ty().name()))),
            },
        }
    }

    /// A location as a transformation (a joint point through forward kinematics).
    fn trans_loc(&mut self, e: &Expr) -> CResult<TExpr> {
        Ok(match self.loc(e)? {
            Loc::T(t) => t,
            Loc::J(j) => TExpr::Forward(Box::new(j)),
            Loc::Named(_) => return Err(self.named_not_emulated(e.span)),
        })
    }

    /// `STRTOPOS` where the kind of location must be known when the program loads (`POINT`,
    /// an assignment, a compound): not emulated (a motion target and `DECOMPOSE` take it).
    fn named_not_emulated(&mut self, span: Span) -> ParseError {
        let what = "the function STRTOPOS here (it runs as a motion target or in DECOMPOSE)";
        self.not_emulated_fn = Some(what.to_owned());
        self.err(span, format!("{what} is not emulated"))
    }

    fn reals_up_to(
        &mut self,
        args: &[Arg],
        n: usize,
        what: &str,
        span: Span,
    ) -> CResult<Box<[RExpr]>> {
        // More values than the FS020N's six axes (external axes 7…18): not emulated.
        if args.len() > n {
            self.not_emulated_fn = Some(format!("{what} with more than {n} values"));
            return Err(self.err(span, format!("{what} takes at most {n} values here")));
        }
        let mut v = Vec::new();
        for a in args {
            match a {
                Arg::Expr(e) => v.push(self.real(e)?),
                // An omitted component is 0 (`TRANS(, -100)`).
                Arg::Omitted(_) => v.push(RExpr::Const(0.0)),
                Arg::Format(_, s) => {
                    return Err(self.err(*s, "a format code is allowed only in $ENCODE"))
                }
                Arg::Keyword(k, s) => {
                    return Err(self.err(
                        *s,
                        format!("expected a value, found the word {}", k.to_uppercase()),
                    ))
                }
            }
        }
        Ok(v.into())
    }

    fn expr(&mut self, e: &Expr) -> CResult<CExpr> {
        match &e.kind {
            ExprKind::Num(v) => {
                let f = *v as f32;
                if !f.is_finite() {
                    return Err(self.err(e.span, "number too large for an AS real (32-bit)"));
                }
                Ok(CExpr::R(RExpr::Const(f)))
            }
            ExprKind::Str(s) => Ok(CExpr::S(SExpr::Const(Bytes::from(s.as_slice())))),
            ExprKind::Var(lv) => self.var_expr(lv),
            ExprKind::Unary(UnOp::Neg, a) if !matches!(a.kind, ExprKind::Num(_)) => {
                match self.expr(a)? {
                    CExpr::T(t) => Ok(CExpr::T(TExpr::Inverse(Box::new(t)))),
                    CExpr::R(r) => Ok(CExpr::R(RExpr::Neg(Box::new(r)))),
                    other => Err(self.err(
                        e.span,
                        format!("expected a real, found {}", other.ty().name()),
                    )),
                }
            }
            ExprKind::Unary(op, a) => {
                let a = Box::new(self.real(a)?);
                Ok(CExpr::R(match op {
                    UnOp::Neg => match *a {
                        RExpr::Const(v) => RExpr::Const(-v),
                        a => RExpr::Neg(Box::new(a)),
                    },
                    UnOp::Not => RExpr::Not(a),
                    UnOp::Com => RExpr::Com(a),
                }))
            }
            ExprKind::Binary(op, a, b) => {
                let x = self.expr(a)?;
                let y = self.expr(b)?;
                match (x, y) {
                    (CExpr::R(x), CExpr::R(y)) => {
                        Ok(CExpr::R(RExpr::Bin(*op, Box::new(x), Box::new(y))))
                    }
                    (CExpr::S(x), CExpr::S(y)) => match op {
                        BinOp::Add => Ok(CExpr::S(SExpr::Concat(Box::new(x), Box::new(y)))),
                        BinOp::Eq | BinOp::Ne | BinOp::Lt | BinOp::Gt | BinOp::Le | BinOp::Ge => {
                            Ok(CExpr::R(RExpr::StrCmp(*op, Box::new(x), Box::new(y))))
                        }
                        _ => Err(self.err(e.span, "strings take only + (join) and comparisons")),
                    },
                    (CExpr::T(x), CExpr::T(y)) if *op == BinOp::Add => {
                        Ok(CExpr::T(TExpr::Compose(Box::new(x), Box::new(y))))
                    }
                    (CExpr::T(x), CExpr::T(y)) if *op == BinOp::Sub => Ok(CExpr::T(
                        TExpr::Compose(Box::new(x), Box::new(TExpr::Inverse(Box::new(y)))),
                    )),
                    (x, y) => Err(self.err(
                        e.span,
                        format!(
                            "cannot combine {} and {} with this operator",
                            x.ty().name(),
                            y.ty().name()
                        ),
                    )),
                }
            }
            ExprKind::Call { name, args } => self.call(name, args, e.span),
        }
    }

    fn var_expr(&mut self, lv: &LValue) -> CResult<CExpr> {
        let n = &lv.name;
        if !n.local && lv.indices.is_empty() {
            match (n.sigil, n.text.as_str()) {
                (Sigil::None, "true" | "on") => return Ok(CExpr::R(RExpr::Const(-1.0))),
                (Sigil::None, "false" | "off") => return Ok(CExpr::R(RExpr::Const(0.0))),
                (Sigil::None, "pi") => return Ok(CExpr::R(RExpr::Const(std::f32::consts::PI))),
                (Sigil::None, "error") => return Ok(CExpr::R(RExpr::Error)),
                (Sigil::None, "here") => return Ok(CExpr::T(TExpr::Here)),
                (Sigil::Hash, "here") => return Ok(CExpr::J(JExpr::Here)),
                (Sigil::None, "dest") => return Ok(CExpr::T(TExpr::Dest)),
                (Sigil::Hash, "dest") => return Ok(CExpr::J(JExpr::Dest)),
                // `$TIME`, `$DATE`: the controller's clock as text.
                (Sigil::Dollar, "time") => return Ok(CExpr::S(SExpr::Time)),
                (Sigil::Dollar, "date") => {
                    return Ok(CExpr::S(SExpr::Date(Box::new(RExpr::Const(1.0)))))
                }
                _ => {}
            }
        }
        Ok(match n.sigil {
            Sigil::None => CExpr::R(RExpr::Var(self.lref(lv, Ty::Real)?)),
            Sigil::Dollar => CExpr::S(SExpr::Var(self.lref(lv, Ty::Str)?)),
            Sigil::Hash => CExpr::J(JExpr::Var(self.lref(lv, Ty::Joint)?)),
        })
    }

    fn arity(&self, name: &Name, args: &[Arg], min: usize, max: usize, span: Span) -> CResult<()> {
        if args.len() < min || args.len() > max {
            let want = if min == max {
                format!("{min}")
            } else {
                format!("{min} to {max}")
            };
            return Err(self.err(
                span,
                format!(
                    "{} takes {want} argument(s), found {}",
                    display_fn(name),
                    args.len()
                ),
            ));
        }
        for a in args {
            if let Arg::Format(_, s) = a {
                return Err(self.err(*s, "a format code is allowed only in $ENCODE"));
            }
        }
        Ok(())
    }

    fn arg_expr<'e>(&mut self, a: &'e Arg) -> CResult<&'e Expr> {
        match a {
            Arg::Expr(e) => Ok(e),
            Arg::Format(_, s) => Err(self.err(*s, "a format code is allowed only in $ENCODE")),
            // An omitted value where the emulator does not know the function's default: the
            // statement loads as not emulated.
            Arg::Omitted(s) => {
                self.not_emulated_fn = Some("an omitted function argument".into());
                Err(self.err(*s, "an omitted value here is not emulated"))
            }
            Arg::Keyword(k, s) => Err(self.err(
                *s,
                format!("expected a value, found the word {}", k.to_uppercase()),
            )),
        }
    }

    fn arg_real(&mut self, a: &Arg) -> CResult<RExpr> {
        let e = self.arg_expr(a)?.clone();
        self.real(&e)
    }

    fn arg_str(&mut self, a: &Arg) -> CResult<SExpr> {
        let e = self.arg_expr(a)?.clone();
        self.string(&e)
    }

    fn call(&mut self, name: &Name, args: &[Arg], span: Span) -> CResult<CExpr> {
        match (name.sigil, name.text.as_str()) {
            (
                Sigil::None,
                f @ ("abs" | "sqrt" | "sin" | "cos" | "tan" | "int" | "task" | "timer" | "utimer"),
            ) => {
                self.arity(name, args, 1, 1, span)?;
                let a = self.arg_real(&args[0])?;
                let func = match f {
                    "abs" => RFunc::Abs,
                    "sqrt" => RFunc::Sqrt,
                    "sin" => RFunc::Sin,
                    "cos" => RFunc::Cos,
                    "tan" => RFunc::Tan,
                    "int" => RFunc::Int,
                    "task" => RFunc::Task,
                    "utimer" => RFunc::UTimer,
                    _ => RFunc::Timer,
                };
                Ok(CExpr::R(RExpr::Func(func, vec![a].into())))
            }
            (Sigil::Dollar, "date") => {
                self.arity(name, args, 0, 1, span)?;
                let form = match args.first() {
                    Some(a) => self.arg_real(a)?,
                    None => RExpr::Const(1.0),
                };
                Ok(CExpr::S(SExpr::Date(Box::new(form))))
            }
            (Sigil::None | Sigil::Dollar, "sysdata") => {
                let key = match args.first() {
                    Some(Arg::Keyword(k, _)) => k.clone(),
                    _ => String::new(),
                };
                // A robot number after the keyword: the constant 1, or an expression read
                // when the function is (`SYSDATA(ZROB.NOWAXIS, .rno)`). Another constant
                // robot, or an axis after it, is not emulated.
                let robot = match args.get(1) {
                    None => Some(None),
                    Some(Arg::Expr(Expr {
                        kind: ExprKind::Num(n),
                        ..
                    })) if *n == 1.0 => Some(None),
                    Some(Arg::Expr(Expr {
                        kind: ExprKind::Num(_),
                        ..
                    })) => None,
                    Some(Arg::Expr(e)) => Some(Some(Box::new(self.real(e)?))),
                    Some(_) => None,
                };
                let known = match (name.sigil, key.as_str(), robot, args.len() <= 2) {
                    (Sigil::Dollar, "zrob.name", Some(None), true) => {
                        Some(CExpr::S(SExpr::RobotName))
                    }
                    (Sigil::None, k, Some(robot), true) => match k {
                        "m.speed" => Some(SysData::MonitorSpeed),
                        "p.speed" => Some(SysData::ProgramSpeed),
                        "step" | "mstep" => Some(SysData::Step),
                        "numrobot" => Some(SysData::Robots),
                        "zrob.nowaxis" => Some(SysData::Axes),
                        "language" => Some(SysData::Language),
                        "mem.free" => Some(SysData::FreeMemory),
                        _ => None,
                    }
                    .map(|d| CExpr::R(RExpr::SysData(d, robot))),
                    _ => None,
                };
                match known {
                    Some(e) => Ok(e),
                    None => {
                        let what = format!("{}({})", display_fn(name), key.to_uppercase());
                        self.not_emulated_fn = Some(what.clone());
                        Err(self.err(span, format!("{what} is not emulated")))
                    }
                }
            }
            (Sigil::None, f @ ("rx" | "ry" | "rz")) => {
                self.arity(name, args, 1, 1, span)?;
                let a = self.arg_real(&args[0])?;
                let axis = match f {
                    "rx" => 0,
                    "ry" => 1,
                    _ => 2,
                };
                Ok(CExpr::T(TExpr::Rot(axis, Box::new(a))))
            }
            (Sigil::None, "round") => {
                self.arity(name, args, 1, 1, span)?;
                let a = self.arg_real(&args[0])?;
                Ok(CExpr::R(RExpr::Func(RFunc::Round, vec![a].into())))
            }
            (Sigil::None, f @ ("distance" | "dx" | "dy" | "dz")) => {
                let (n, func) = match f {
                    "distance" => (2, LocFn::Distance),
                    "dx" => (1, LocFn::Dx),
                    "dy" => (1, LocFn::Dy),
                    _ => (1, LocFn::Dz),
                };
                self.arity(name, args, n, n, span)?;
                let t = args
                    .iter()
                    .map(|a| {
                        let e = self.arg_expr(a)?.clone();
                        self.trans_loc(&e)
                    })
                    .collect::<CResult<Vec<_>>>()?;
                Ok(CExpr::R(RExpr::Loc(func, t.into())))
            }
            (Sigil::None, "frame") => {
                self.arity(name, args, 4, 4, span)?;
                let mut t = Vec::new();
                for a in args {
                    let e = self.arg_expr(a)?.clone();
                    t.push(self.trans_loc(&e)?);
                }
                let [a, b, c, d]: [TExpr; 4] = t
                    .try_into()
                    .map_err(|_| self.err(span, "FRAME takes 4 locations"))?;
                Ok(CExpr::T(TExpr::Frame(Box::new([a, b, c, d]))))
            }
            (
                Sigil::None,
                f @ ("existreal" | "existinteger" | "existchar" | "existjoint" | "existtrans"
                | "existprogram"),
            ) => {
                self.arity(name, args, 1, 1, span)?;
                let kind = match f {
                    "existreal" => Exist::Real,
                    "existinteger" => Exist::Integer,
                    "existchar" => Exist::Char,
                    "existjoint" => Exist::Joint,
                    "existtrans" => Exist::Trans,
                    _ => Exist::Program,
                };
                let s = self.arg_str(&args[0])?;
                Ok(CExpr::R(RExpr::Exist(kind, Box::new(s))))
            }
            (Sigil::None, "strtoval") => {
                self.arity(name, args, 1, 1, span)?;
                let s = self.arg_str(&args[0])?;
                Ok(CExpr::R(RExpr::NamedReal(Box::new(s))))
            }
            (Sigil::None, f @ ("maxindex" | "minindex")) => {
                self.arity(name, args, 1, 2, span)?;
                let s = self.arg_str(&args[0])?;
                let dim = args.get(1).map(|a| self.arg_real(a)).transpose()?;
                Ok(CExpr::R(RExpr::ArrayIndex(
                    f == "maxindex",
                    Box::new(s),
                    dim.map(Box::new),
                )))
            }
            (Sigil::Dollar, "space") => {
                self.arity(name, args, 1, 1, span)?;
                Ok(CExpr::S(SExpr::Space(Box::new(self.arg_real(&args[0])?))))
            }
            (Sigil::None, "whichtask") => {
                self.arity(name, args, 1, 1, span)?;
                let s = self.arg_str(&args[0])?;
                Ok(CExpr::R(RExpr::WhichTask(Box::new(s))))
            }
            (Sigil::None, "existdata") => {
                // `EXISTDATA(name, T)` (later controllers; not in the E manual): whether the
                // variable of that kind exists, the kind by its data section's initial — R
                // real, T transformation, J joint, S string. Another letter is not emulated.
                self.arity(name, args, 2, 2, span)?;
                let kind = match &args[1] {
                    Arg::Expr(Expr {
                        kind: ExprKind::Var(lv),
                        ..
                    }) if lv.indices.is_empty()
                        && !lv.name.local
                        && lv.name.sigil == Sigil::None =>
                    {
                        match lv.name.text.as_str() {
                            "r" => Some(Exist::Real),
                            "t" => Some(Exist::Trans),
                            "j" => Some(Exist::Joint),
                            "s" => Some(Exist::Char),
                            _ => None,
                        }
                    }
                    _ => None,
                };
                let Some(kind) = kind else {
                    let what = "EXISTDATA of a kind other than R, T, J or S".to_owned();
                    self.not_emulated_fn = Some(what.clone());
                    return Err(self.err(span, format!("{what} is not emulated")));
                };
                let s = self.arg_str(&args[0])?;
                Ok(CExpr::R(RExpr::Exist(kind, Box::new(s))))
            }
            (Sigil::None, "atan2") => {
                self.arity(name, args, 2, 2, span)?;
                let v = vec![self.arg_real(&args[0])?, self.arg_real(&args[1])?];
                Ok(CExpr::R(RExpr::Func(RFunc::Atan2, v.into())))
            }
            (Sigil::None, f @ ("maxval" | "minval" | "sig")) => {
                self.arity(name, args, 1, 32, span)?;
                let v = args
                    .iter()
                    .map(|a| self.arg_real(a))
                    .collect::<CResult<Vec<_>>>()?;
                let func = match f {
                    "maxval" => RFunc::MaxVal,
                    "minval" => RFunc::MinVal,
                    _ => RFunc::Sig,
                };
                Ok(CExpr::R(RExpr::Func(func, v.into())))
            }
            (Sigil::None, f @ ("bits" | "bits32")) => {
                self.arity(name, args, 2, 2, span)?;
                let v = vec![self.arg_real(&args[0])?, self.arg_real(&args[1])?];
                let func = if f == "bits" {
                    RFunc::Bits
                } else {
                    RFunc::Bits32
                };
                Ok(CExpr::R(RExpr::Func(func, v.into())))
            }
            (Sigil::None, "val") => {
                self.arity(name, args, 1, 2, span)?;
                let s = self.arg_str(&args[0])?;
                let radix = args.get(1).map(|a| self.arg_real(a)).transpose()?;
                Ok(CExpr::R(RExpr::Val(Box::new(s), radix.map(Box::new))))
            }
            (Sigil::None, "len") => {
                self.arity(name, args, 1, 1, span)?;
                Ok(CExpr::R(RExpr::Len(Box::new(self.arg_str(&args[0])?))))
            }
            (Sigil::None, "asc") => {
                self.arity(name, args, 1, 2, span)?;
                let s = self.arg_str(&args[0])?;
                let n = args.get(1).map(|a| self.arg_real(a)).transpose()?;
                Ok(CExpr::R(RExpr::Asc(Box::new(s), n.map(Box::new))))
            }
            (Sigil::None, "instr") => {
                self.arity(name, args, 2, 3, span)?;
                if args.len() == 3 {
                    let start = self.arg_real(&args[0])?;
                    let s = self.arg_str(&args[1])?;
                    let sub = self.arg_str(&args[2])?;
                    Ok(CExpr::R(RExpr::Instr(
                        Some(Box::new(start)),
                        Box::new(s),
                        Box::new(sub),
                    )))
                } else {
                    let s = self.arg_str(&args[0])?;
                    let sub = self.arg_str(&args[1])?;
                    Ok(CExpr::R(RExpr::Instr(None, Box::new(s), Box::new(sub))))
                }
            }
            (Sigil::None, "dext") => {
                self.arity(name, args, 2, 2, span)?;
                let e = self.arg_expr(&args[0])?.clone();
                let l = self.loc(&e)?;
                let n = self.arg_real(&args[1])?;
                Ok(CExpr::R(RExpr::Dext(Box::new(l), Box::new(n))))
            }
            (Sigil::None, "switch") => {
                self.arity(name, args, 1, 2, span)?;
                // `SWITCH(CS, 2)`: the switch of robot 2. The emulator has robot 1.
                if let Some(robot) = args.get(1) {
                    let one = matches!(robot, Arg::Expr(Expr { kind: ExprKind::Num(n), .. }) if *n == 1.0);
                    if !one {
                        self.not_emulated_fn = Some("SWITCH of another robot".into());
                        return Err(self.err(span, "SWITCH of another robot is not emulated"));
                    }
                }
                let e = self.arg_expr(&args[0])?;
                let sw = match &e.kind {
                    ExprKind::Var(lv)
                        if !lv.name.local
                            && lv.name.sigil == Sigil::None
                            && lv.indices.is_empty() =>
                    {
                        switch_ref(&lv.name.text)
                    }
                    _ => None,
                };
                if let (None, Some(Arg::Expr(a))) = (&sw, args.first()) {
                    if let ExprKind::Var(lv) = &a.kind {
                        // A switch the controller has but the emulator does not keep
                        // (`SWITCH(EMERGENCY)`): the statement loads as not emulated.
                        if !lv.name.local && lv.name.sigil == Sigil::None {
                            self.not_emulated_fn =
                                Some(format!("SWITCH({})", lv.name.text.to_ascii_uppercase()));
                        }
                    }
                }
                match sw {
                    Some(s) => Ok(CExpr::R(RExpr::Switch(s))),
                    None => Err(self.err(
                        e.span,
                        "SWITCH takes a switch name: POWER, RUN, REPEAT, TEACH_LOCK, CS, ERROR or a system switch such as ABS.SPEED",
                    )),
                }
            }
            (Sigil::None, "shift") => {
                self.arity(name, args, 2, 4, span)?;
                let loc = self.arg_expr(&args[0])?.clone();
                let t = self.trans_loc(&loc)?;
                // An omitted shift is 0 (`SHIFT(p BY , , 50)`).
                let d = self.reals_up_to(&args[1..], 3, "SHIFT", span)?;
                Ok(CExpr::T(TExpr::Shift(Box::new(t), d)))
            }
            (Sigil::None, "trans") => Ok(CExpr::T(TExpr::Trans(
                self.reals_up_to(args, 6, "TRANS", span)?,
            ))),
            (Sigil::Hash, "ppoint") => Ok(CExpr::J(JExpr::PPoint(
                self.reals_up_to(args, 6, "#PPOINT", span)?,
            ))),
            (Sigil::Dollar, "mid") => {
                self.arity(name, args, 2, 3, span)?;
                let s = self.arg_str(&args[0])?;
                let start = self.arg_real(&args[1])?;
                let n = args.get(2).map(|a| self.arg_real(a)).transpose()?;
                Ok(CExpr::S(SExpr::Mid(
                    Box::new(s),
                    Box::new(start),
                    n.map(Box::new),
                )))
            }
            (Sigil::Dollar, f @ ("left" | "right")) => {
                self.arity(name, args, 2, 2, span)?;
                let s = self.arg_str(&args[0])?;
                let n = self.arg_real(&args[1])?;
                Ok(CExpr::S(if f == "left" {
                    SExpr::Left(Box::new(s), Box::new(n))
                } else {
                    SExpr::Right(Box::new(s), Box::new(n))
                }))
            }
            (Sigil::Dollar, "chr") => {
                self.arity(name, args, 1, 1, span)?;
                Ok(CExpr::S(SExpr::Chr(Box::new(self.arg_real(&args[0])?))))
            }
            (Sigil::Dollar, "error") => {
                self.arity(name, args, 1, 1, span)?;
                Ok(CExpr::S(SExpr::ErrorMsg(Box::new(
                    self.arg_real(&args[0])?,
                ))))
            }
            (Sigil::Dollar, "encode") => {
                let items: Vec<PrintItem> = args
                    .iter()
                    .map(|a| match a {
                        Arg::Expr(e) => Ok(PrintItem::Expr(e.clone())),
                        Arg::Format(f, s) => Ok(PrintItem::Format(*f, *s)),
                        Arg::Keyword(k, s) if k.starts_with('/') => {
                            self.not_emulated_fn =
                                Some(format!("$ENCODE with the format {}", k.to_uppercase()));
                            Err(self.err(
                                *s,
                                format!("the format {} is not emulated", k.to_uppercase()),
                            ))
                        }
                        Arg::Omitted(s) | Arg::Keyword(_, s) => {
                            Err(self.err(*s, "expected a value or a format code in $ENCODE"))
                        }
                    })
                    .collect::<CResult<_>>()?;
                Ok(CExpr::S(SExpr::Encode(self.items(&items)?)))
            }
            (Sigil::Dollar, "decode") => {
                self.arity(name, args, 2, 3, span)?;
                let target =
                    match self.arg_expr(&args[0])? {
                        Expr {
                            kind: ExprKind::Var(lv),
                            ..
                        } if lv.name.sigil == Sigil::Dollar => lv.clone(),
                        other => return Err(self.err(
                            other.span,
                            "the first argument of $DECODE must be a string variable (it is cut)",
                        )),
                    };
                let l = self.lref(&target, Ty::Str)?;
                let delims = self.arg_str(&args[1])?;
                let mode = match args.get(2) {
                    Some(a) => self.arg_real(a)?,
                    None => RExpr::Const(0.0),
                };
                Ok(CExpr::S(SExpr::Decode(l, Box::new(delims), Box::new(mode))))
            }
            // A function of the keyword table the emulator does not compute, or a name in no
            // table (a function of another generation or option): the statement loads as not
            // emulated, and the lint names the unknown ones.
            _ => {
                self.not_emulated_fn = Some(display_fn(name));
                Err(self.err(span, format!("{} is not emulated", display_fn(name))))
            }
        }
    }
}

fn display_fn(name: &Name) -> String {
    name.to_string().to_uppercase()
}

/// Names that read as functions without parentheses (reserved, never variables).
fn is_name_function(n: &Name) -> bool {
    matches!(
        (n.sigil, n.text.as_str()),
        (
            Sigil::None,
            "true" | "false" | "on" | "off" | "pi" | "error" | "here" | "dest"
        ) | (Sigil::Hash, "here" | "dest")
    )
}

fn switch_ref(name: &str) -> Option<SwitchRef> {
    Some(match name {
        "power" => SwitchRef::Power,
        "run" => SwitchRef::Run,
        "repeat" => SwitchRef::Repeat,
        "teach_lock" => SwitchRef::TeachLock,
        "cs" => SwitchRef::CycleStart,
        "error" => SwitchRef::InError,
        "emergency" | "tp_emg" | "op_emg" | "ex_emg" => SwitchRef::EmergencyStop,
        other => SwitchRef::System(
            keywords::SYSTEM_SWITCHES
                .iter()
                .position(|(n, _)| *n == other)?,
        ),
    })
}

fn any_r(v: &[RExpr]) -> bool {
    v.iter().any(r_touches)
}

fn l_touches(l: &LRef) -> bool {
    any_r(&l.idx)
}

fn r_touches(e: &RExpr) -> bool {
    match e {
        RExpr::Const(_) => false,
        RExpr::Var(l) => l_touches(l),
        RExpr::Neg(a) | RExpr::Not(a) | RExpr::Com(a) => r_touches(a),
        RExpr::Bin(_, a, b) => r_touches(a) || r_touches(b),
        RExpr::StrCmp(_, a, b) => s_touches(a) || s_touches(b),
        RExpr::Func(f, args) => *f == RFunc::Task || any_r(args),
        RExpr::Val(a, b) | RExpr::Asc(a, b) => s_touches(a) || b.as_deref().is_some_and(r_touches),
        RExpr::Len(a) => s_touches(a),
        RExpr::Instr(a, b, c) => {
            a.as_deref().is_some_and(r_touches) || s_touches(b) || s_touches(c)
        }
        RExpr::Dext(l, n) => loc_touches(l) || r_touches(n),
        RExpr::Switch(_)
        | RExpr::Error
        | RExpr::Exist(..)
        | RExpr::WhichTask(_)
        | RExpr::NamedReal(_)
        | RExpr::ArrayIndex(..)
        | RExpr::SysData(..) => true,
        RExpr::Loc(_, t) => t.iter().any(t_touches),
    }
}

fn s_touches(e: &SExpr) -> bool {
    match e {
        SExpr::Const(_) => false,
        SExpr::Var(l) => l_touches(l),
        SExpr::Concat(a, b) => s_touches(a) || s_touches(b),
        SExpr::Mid(a, b, c) => s_touches(a) || r_touches(b) || c.as_deref().is_some_and(r_touches),
        SExpr::Left(a, b) | SExpr::Right(a, b) => s_touches(a) || r_touches(b),
        SExpr::Chr(a) | SExpr::ErrorMsg(a) | SExpr::Date(a) | SExpr::Space(a) => r_touches(a),
        SExpr::Time | SExpr::RobotName => false,
        SExpr::Encode(items) => items_touch(items),
        SExpr::Decode(l, d, m) => l_touches(l) || s_touches(d) || r_touches(m),
    }
}

fn items_touch(items: &[Item]) -> bool {
    items.iter().any(|i| match i {
        Item::Real(e) => r_touches(e),
        Item::Str(e) => s_touches(e),
        Item::Format(_) => false,
    })
}

fn loc_touches(l: &Loc) -> bool {
    match l {
        Loc::J(j) => j_touches(j),
        Loc::T(t) => t_touches(t),
        Loc::Named(s) => s_touches(s),
    }
}

fn j_touches(e: &JExpr) -> bool {
    match e {
        JExpr::Var(l) => l_touches(l),
        JExpr::PPoint(a) => any_r(a),
        JExpr::Here | JExpr::Inverse(_) | JExpr::Dest => true,
    }
}

fn t_touches(e: &TExpr) -> bool {
    match e {
        TExpr::Var(l) => l_touches(l),
        TExpr::Trans(a) => any_r(a),
        TExpr::Here | TExpr::Forward(_) | TExpr::Dest => true,
        TExpr::Compose(a, b) => t_touches(a) || t_touches(b),
        TExpr::Shift(t, d) => t_touches(t) || any_r(d),
        TExpr::Frame(t) => t.iter().any(t_touches),
        TExpr::Inverse(t) => t_touches(t),
        TExpr::Rot(_, a) => r_touches(a),
    }
}

fn c_touches(e: &CExpr) -> bool {
    match e {
        CExpr::R(r) => r_touches(r),
        CExpr::S(s) => s_touches(s),
        CExpr::J(j) => j_touches(j),
        CExpr::T(t) => t_touches(t),
    }
}

/// See [`CProgram::touches`].
fn op_touches(op: &Op) -> bool {
    let opt = |e: &Option<RExpr>| e.as_ref().is_some_and(r_touches);
    match op {
        Op::Nop | Op::Jump(_) | Op::Pause | Op::SetSwitch(..) | Op::Cp(_) => false,
        Op::AssignR(l, e) => l_touches(l) || r_touches(e),
        Op::AssignS(l, e) => l_touches(l) || s_touches(e),
        Op::AssignJ(l, e) => l_touches(l) || j_touches(e),
        Op::AssignT(l, e) => l_touches(l) || t_touches(e),
        Op::JumpIfNot(c, _) | Op::JumpIf(c, _) | Op::Twait(c) | Op::Ignore(c) => r_touches(c),
        Op::ForInit {
            var,
            from,
            to,
            step,
            ..
        } => l_touches(var) || r_touches(from) || r_touches(to) || opt(step),
        Op::ForNext { var, .. } => l_touches(var),
        Op::CaseSelR(e, _) => r_touches(e),
        Op::CaseSelS(e, _) => s_touches(e),
        Op::CaseTestR(v, _, _) => any_r(v),
        Op::CaseTestS(v, _, _) => v.iter().any(s_touches),
        Op::Call(_, args) => args.iter().any(|a| {
            a.value.as_ref().is_some_and(c_touches)
                || a.var.as_ref().is_some_and(|(_, l)| l_touches(l))
        }),
        Op::Print(items) => items_touch(items),
        Op::Signal(v) => any_r(v),
        Op::Pulse(a, b) => r_touches(a) || opt(b),
        Op::Dlysig(a, b) => r_touches(a) || r_touches(b),
        Op::RunMask(a, b) => r_touches(a) || opt(b),
        Op::Bits(_, a, b, c) => r_touches(a) || r_touches(b) || r_touches(c),
        Op::Sout(a, b) => r_touches(a) || r_touches(b),
        Op::Weight(v) => any_r(v),
        Op::IfpWrite(_, w) => {
            r_touches(&w.window) || w.place.iter().any(opt) || w.texts.iter().any(s_touches)
        }
        Op::IfpLabel(l) => r_touches(&l.0) || l.1.iter().flatten().any(s_touches),
        Op::IfpTitle(t) => r_touches(&t.0) || s_touches(&t.1),
        Op::On { signal, .. } => r_touches(signal),
        Op::Timer(a, b) => r_touches(a) || r_touches(b),
        Op::UTimer(l, e) => l_touches(l) || r_touches(e),
        Op::Speed(e, _, _) | Op::Accuracy(e, _, _) | Op::AccelDecel(_, e, _) => r_touches(e),
        Op::Decompose(l, loc) => l_touches(l) || loc_touches(loc),
        // The end of a program, motion, the panel, the error, sockets, other tasks.
        _ => true,
    }
}
