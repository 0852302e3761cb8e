//! The system side of the interpreter: what a controller offers AS programs.
//!
//! The interpreter owns the programs, their variables, tasks, signals, timers and system
//! switches. Everything physical or external is behind [`System`]: the clock's effects on the
//! arm (motion), the panel switches, the controller's error, the monitor speed, TCP sockets
//! and the terminal. `fs020n-sim` implements it with its motion planner, panel and TCP server;
//! [`crate::testing::VirtualSystem`] (feature `testing`) is a minimal one for tests of AS
//! programs.
//!
//! # Time
//!
//! The interpreter runs on a clock it is given ([`crate::Interpreter::run_until`]). Before it
//! executes a statement at time `t` it calls [`System::advance_to`]`(t)`, so the system
//! integrates motion up to `t` first; times passed never decrease.
//!
//! # Motion and look-ahead
//!
//! A robot program hands each motion instruction to [`System::issue_motion`] and goes on at
//! once. The system either **starts** the motion (nothing in progress, or the tool already
//! within ACCURACY of the current target: it blends in) or **plans** it (it waits to blend in).
//! While a motion is planned the program waits at that instruction; the interpreter polls
//! [`System::motion_planned`] every poll period (the system starts the planned motion on its
//! own when the tool enters the ACCURACY range). So the program runs on to the next motion
//! instruction and waits there, exactly as spec §4 describes, with at most one motion queued
//! beyond the one in progress. [`System::brake`] (BRAKE from any task, an `ONI`, a stopping
//! error) stops the motion at once and drops the planned one.

use std::time::Duration;

use fs020n_proto::ErrorCode;

/// A joint-displacement value: JT1..JT6 in degrees.
pub type Joints = [f64; 6];

/// A transformation value: X, Y, Z (mm), O, A, T (degrees, Z-Y-Z Euler angles). A
/// [`Target::Pose`], [`System::pose`] and [`System::forward`] are the **flange** in the robot's
/// base frame: the interpreter applies the program's TOOL and BASE on its side.
pub type Trans = [f64; 6];

/// Where a motion goes.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Target {
    /// A joint-displacement point (`#p`, `#PPOINT(…)`, `HOME`).
    Joints(Joints),
    /// A transformation (the system solves inverse kinematics near the current pose).
    Pose(Trans),
}

/// Interpolation of a motion.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum MotionKind {
    /// `JMOVE`, `HOME`: joint-interpolated.
    Joint,
    /// `LMOVE`: the tool on a straight line.
    Linear,
    /// `DELAY t`: a motion that stands still for `t` seconds (it occupies the motion queue).
    Delay,
    /// `C1MOVE via` then `C2MOVE end`: the tool on the circle through where the previous
    /// motion ends, [`MotionRequest::via`] and the target.
    Circular,
    /// `HMOVE`: the wrist centre on a straight line, the wrist joints (JT4–JT6) interpolated
    /// as in a joint move.
    Hybrid,
}

/// The program speed of a motion.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Speed {
    /// Percent of the maximum speed (0.01–100).
    Percent(f64),
    /// Tool speed, mm/s.
    MmPerS(f64),
    /// The motion takes this many seconds (at monitor speed 100 %).
    Seconds(f64),
}

/// One motion instruction as the program issues it, with the motion parameters in force.
/// The monitor speed is the system's own; [`MotionRequest::abs_speed`] says how to combine.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MotionRequest {
    /// Joint, linear or delay.
    pub kind: MotionKind,
    /// The target (for a delay: where the robot will be, i.e. the current target).
    pub target: Target,
    /// Program speed.
    pub speed: Speed,
    /// For [`MotionKind::Delay`]: how long, seconds.
    pub delay_s: f64,
    /// For [`MotionKind::Circular`]: the intermediate point the circle passes through (the
    /// flange in the robot's base frame, like [`Target::Pose`]); `None` otherwise.
    pub via: Option<Trans>,
    /// ACCURACY, mm: the next motion may blend in once the tool is this close to this target.
    pub accuracy_mm: f64,
    /// ACCURACY … FINE: exact coincidence required.
    pub fine: bool,
    /// ACCEL, percent of the maximum acceleration.
    pub accel_percent: f64,
    /// DECEL, percent of the maximum deceleration.
    pub decel_percent: f64,
    /// CP ON: blend with the next motion (OFF: stop fully before it).
    pub cp: bool,
    /// The ABS.SPEED system switch: effective speed = min(program, monitor) instead of their
    /// product.
    pub abs_speed: bool,
}

/// What the system did with a motion instruction.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Issued {
    /// It started now (the program goes on).
    Started,
    /// It waits to blend in; the program waits until [`System::motion_planned`] is false.
    Planned,
}

/// The panel switches `SWITCH(name)` reads and the interpreter obeys (a robot program runs only
/// with power ON, REPEAT and TEACH LOCK OFF; HOLD pauses it).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct PanelState {
    /// Motor power ON.
    pub power: bool,
    /// RUN/HOLD on RUN.
    pub run: bool,
    /// TEACH/REPEAT on REPEAT.
    pub repeat: bool,
    /// TEACH LOCK ON.
    pub teach_lock: bool,
}

/// The outcome of a socket operation that may have to wait.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SockPoll<T> {
    /// Done: the value, or a negative AS error code (−34025 connection broken, …).
    Ready(Result<T, i32>),
    /// Not yet: the interpreter asks again later (until its timeout, then −34024).
    Pending,
}

/// Which task prints (for the terminal and traces).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, serde::Serialize)]
pub enum TaskId {
    /// Robot task 1 (robot programs: `MC EXECUTE`).
    Robot,
    /// PC task 1–5 (`PCEXECUTE`, `autostart.pc` … `autostart5.pc`).
    Pc(u8),
}

impl TaskId {
    /// The task's number as `TASK(n)` takes it: 1 for the robot task, 1001–1005 for PC tasks.
    pub fn number(self) -> u32 {
        match self {
            TaskId::Robot => 1,
            TaskId::Pc(n) => 1000 + u32::from(n),
        }
    }

    /// Index 0 (robot) … 5 (PC task 5).
    pub(crate) fn index(self) -> usize {
        match self {
            TaskId::Robot => 0,
            TaskId::Pc(n) => usize::from(n.clamp(1, 5)),
        }
    }

    pub(crate) fn from_index(i: usize) -> TaskId {
        if i == 0 {
            TaskId::Robot
        } else {
            TaskId::Pc(i.min(5) as u8)
        }
    }
}

impl std::fmt::Display for TaskId {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            TaskId::Robot => f.write_str("robot"),
            TaskId::Pc(n) => write!(f, "pc{n}"),
        }
    }
}

/// What the controller offers AS programs (see the module documentation).
///
/// Socket ids and error codes follow the AS TCP manual: a socket id is ≥ 0; errors are the
/// negative codes −34019 … −34057 (E4019 … E4057). The interpreter itself produces −34024
/// (timeout) for a [`SockPoll::Pending`] that outlives its timeout.
pub trait System {
    /// Brings the system to time `t` (integrates motion). Never called with a smaller `t`.
    fn advance_to(&mut self, t: Duration);

    // ------------------------------------------------------------------ robot

    /// Current joint angles (`#HERE`, `DECOMPOSE … = #HERE`), degrees.
    fn joints(&self) -> Joints;

    /// The tool pose of the current joints (`HERE`), `None` when the system has no
    /// kinematics.
    fn pose(&self) -> Option<Trans>;

    /// The flange pose of any joint values (`POINT t = #j`, `APPRO #j, d`), in the robot's base
    /// frame; `None` when the system has no kinematics. The interpreter applies TOOL and BASE.
    fn forward(&self, joints: &Joints) -> Option<Trans>;

    /// The joint values that put the flange at `pose` (robot base frame), the solution nearest
    /// `near` (`POINT #j = t`); `None` when out of reach or without kinematics.
    fn inverse(&self, pose: &Trans, near: &Joints) -> Option<Joints>;

    /// Every joint solution (within the joint limits) that puts the flange at `pose` (robot
    /// base frame): the posture commands choose among them. Empty when out of reach.
    fn inverse_all(&self, pose: &Trans) -> Vec<Joints>;

    /// The HOME pose (`HOME`), degrees.
    fn home(&self) -> Joints;

    /// A motion instruction (see the module documentation). `Err` is a controller error
    /// (e.g. E1088 "destination out of motion range"): the program stops with it. While the
    /// controller is in error (an error program of `ONE` runs) a motion is refused with that
    /// error: the arm does not move again before `MC ERESET`.
    fn issue_motion(&mut self, motion: &MotionRequest) -> Result<Issued, ErrorCode>;

    /// `true` while a motion issued as [`Issued::Planned`] still waits to blend in.
    fn motion_planned(&self) -> bool;

    /// `true` while the robot moves or a motion waits (for `BREAK` and `TASK(1) = 3`).
    fn motion_in_progress(&self) -> bool;

    /// `BRAKE`: stop the current motion at once. Whether a motion planned by look-ahead is
    /// then executed or dropped is the system's documented choice (the manuals are silent);
    /// the program waiting at it goes on once [`System::motion_planned`] is false.
    fn brake(&mut self);

    /// An `ONI` (or a stop of the robot program): stop the motion at once and drop the
    /// planned one — the program has left the instruction that waited for it.
    fn cut_motion(&mut self);

    /// `MC HOLD` (`true`) / `MC CONTINUE` (`false`): pause or resume the motion, as the panel's
    /// HOLD does.
    fn set_program_hold(&mut self, held: bool);

    // ------------------------------------------------------------------ panel, error, speed

    /// The panel switches.
    fn panel(&self) -> PanelState;

    /// The controller's current error (0 = none).
    fn error(&self) -> ErrorCode;

    /// Raises an error (a program error, or a motion refused). The robot stops; the error
    /// stays until reset.
    fn raise_error(&mut self, code: ErrorCode);

    /// `MC ERESET`: resets the error; `Err` with a reason when the system refuses (e.g. the
    /// emergency stop is pressed).
    fn reset_error(&mut self) -> Result<(), String>;

    /// `MC ZPOWER ON|OFF`: motor power; `Err` with a reason when the system refuses (the
    /// emergency stop is pressed).
    fn set_motor_power(&mut self, on: bool) -> Result<(), String>;

    /// Monitor speed, percent.
    fn monitor_speed(&self) -> f64;

    /// `MC SPEED p`: sets the monitor speed (applies from the next planned motion); `Err`
    /// with a reason when refused.
    fn set_monitor_speed(&mut self, percent: f64) -> Result<(), String>;

    // ------------------------------------------------------------------ sockets

    /// `TCP_LISTEN`: 0 or a negative code (−34055 port already listening).
    fn tcp_listen(&mut self, port: u16) -> i32;

    /// `TCP_END_LISTEN`: 0 or a negative code (−34056 not listening).
    fn tcp_end_listen(&mut self, port: u16) -> i32;

    /// `TCP_ACCEPT`: a waiting connection's socket id, −34056 when the port does not listen,
    /// or `Pending`.
    fn tcp_accept(&mut self, port: u16) -> SockPoll<(i32, [u8; 4])>;

    /// `TCP_CONNECT` to `ip:port`: a socket id, or `Pending` while connecting.
    fn tcp_connect(&mut self, ip: [u8; 4], port: u16) -> SockPoll<i32>;

    /// The `TCP_CONNECT` to `ip:port` that was `Pending` timed out: the program gave up, a
    /// connection made later must not stay open. Nothing by default.
    fn tcp_connect_abandon(&mut self, ip: [u8; 4], port: u16) {
        let _ = (ip, port);
    }

    /// `TCP_RECV`: the bytes available now (at most `max` bytes), `Pending` when none.
    /// A peer that closed gives −34025; an unknown socket −34057.
    fn tcp_recv(&mut self, sock: i32, max: usize) -> SockPoll<Vec<u8>>;

    /// `TCP_SEND`: hands `data` to the socket; `Pending` while it cannot take it (the peer
    /// does not read). Called again with the same data until it is `Ready`.
    fn tcp_send(&mut self, sock: i32, data: &[u8]) -> SockPoll<()>;

    /// `TCP_CLOSE`: 0 or a negative code (−34057 unknown socket).
    fn tcp_close(&mut self, sock: i32) -> i32;

    /// `TCP_STATUS`: the sockets the program holds open.
    fn tcp_status(&self) -> Vec<SocketStatus>;

    /// `UDP_RECVFROM` begins: opens its socket on `port`; 0, or a negative code (−34019 the
    /// socket cannot be opened, −34055 the port is in use).
    fn udp_open(&mut self, port: u16) -> i32;

    /// `UDP_RECVFROM` waits: the oldest datagram that reached `port` since it opened,
    /// `Pending` when none (the interpreter asks again until its timeout, then −34024).
    fn udp_recv(&mut self, port: u16) -> SockPoll<Datagram>;

    /// `UDP_RECVFROM` ends (received, timed out, or its task stopped): closes its socket.
    fn udp_close(&mut self, port: u16);

    /// `UDP_SENDTO`: sends one datagram to `ip:port`; 0 or a negative code (−34021 the
    /// network refused it).
    fn udp_send(&mut self, ip: [u8; 4], port: u16, data: &[u8]) -> i32;

    // ------------------------------------------------------------------ terminal

    /// A line printed by `PRINT`/`TYPE` (without its line ending) or a controller message.
    fn terminal(&mut self, task: TaskId, line: &str);
}

/// One socket as `TCP_STATUS` reports it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct SocketStatus {
    /// The socket id.
    pub sock: i32,
    /// The port it was accepted on (0 for the connecting end of a local connection).
    pub port: u16,
    /// The peer's address.
    pub ip: [u8; 4],
    /// 0, or [`TcpCode::Broken`](crate::sockets::TcpCode::Broken)'s code when the peer closed the connection.
    pub error: i32,
}

/// One UDP datagram: the bytes and the other end's address (the sender of one received, the
/// destination of one sent).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Datagram {
    /// The other end's IPv4 address.
    pub ip: [u8; 4],
    /// The other end's port.
    pub port: u16,
    /// The payload.
    pub bytes: Vec<u8>,
}
