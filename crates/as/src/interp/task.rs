//! A task's state: frames, what it waits for, interrupts, motion parameters.

use crate::compile::{Ty, VarRef};
use crate::system::{Speed, TaskId};
use crate::value::{Bytes, Store, Var};

use super::arith::Ns;

#[derive(Debug, Clone)]
pub(super) struct ByRef {
    pub(super) ty: Ty,
    pub(super) param: u32,
    pub(super) var: VarRef,
    pub(super) idx: Vec<i32>,
    /// The caller's frame (index in the task's stack) for a local variable.
    pub(super) frame: usize,
    /// The whole array goes back (`CALL p(.$data[])`), not one value.
    pub(super) whole: bool,
}

#[derive(Debug, Clone)]
pub(super) struct Frame {
    pub(super) prog: usize,
    pub(super) pc: usize,
    pub(super) locals: Store,
    pub(super) byref: Vec<ByRef>,
}

#[derive(Debug, Clone)]
pub(super) enum Wait {
    Until(Ns),
    Cond,
    MotionPlanned,
    MotionDone,
    /// `XMOVE … TILL`: the motion runs until it ends or the signal cuts it.
    Till,
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
    UdpRecv {
        port: u16,
        max: usize,
        deadline: Ns,
    },
}

impl Wait {
    pub(super) fn polled(&self) -> bool {
        matches!(
            self,
            Wait::Cond
                | Wait::MotionPlanned
                | Wait::MotionDone
                | Wait::Till
                | Wait::Held
                // A datagram may come from outside at any time (no generation to watch).
                | Wait::UdpRecv { .. }
        )
    }

    pub(super) fn socket(&self) -> bool {
        matches!(
            self,
            Wait::Accept { .. }
                | Wait::Connect { .. }
                | Wait::Recv { .. }
                | Wait::Send { .. }
                | Wait::UdpRecv { .. }
        )
    }

    /// A wait that is part of a step which completes by itself (a timed wait, a socket call
    /// with its timeout, a motion): `ABORT` lets it complete first. Other waits (`WAIT`
    /// condition, `HOLD`, `PAUSE`) end at `ABORT`.
    pub(super) fn completes(&self) -> bool {
        match self {
            Wait::Until(_)
            | Wait::Accept { .. }
            | Wait::Connect { .. }
            | Wait::Recv { .. }
            | Wait::Send { .. }
            | Wait::UdpRecv { .. } => true,
            // A motion step completes with its motion (AS-E p.5-42: "if the robot is in
            // motion, the execution stops after that motion is completed"), in every task.
            Wait::MotionPlanned | Wait::MotionDone | Wait::Till => true,
            Wait::Cond | Wait::Held | Wait::Paused => false,
        }
    }

    pub(super) fn describe(&self) -> String {
        match self {
            Wait::Until(_) => "TWAIT".into(),
            Wait::Cond => "WAIT condition".into(),
            Wait::MotionPlanned => {
                "motion: waiting for the current motion to come within ACCURACY".into()
            }
            Wait::MotionDone => "BREAK: waiting for the motion to finish".into(),
            Wait::Till => "XMOVE: moving until the motion ends or the TILL signal".into(),
            Wait::Held => "HOLD".into(),
            Wait::Paused => "PAUSE (MC CONTINUE resumes)".into(),
            Wait::Accept { port, .. } => format!("TCP_ACCEPT on port {port}"),
            Wait::Connect { port, .. } => format!("TCP_CONNECT to port {port}"),
            Wait::Recv { sock, .. } => format!("TCP_RECV on socket {sock}"),
            Wait::Send { sock, .. } => format!("TCP_SEND on socket {sock}"),
            Wait::UdpRecv { port, .. } => format!("UDP_RECVFROM on port {port}"),
        }
    }
}

#[derive(Debug, Clone, Copy)]
pub(super) struct Interrupt {
    pub(super) signal: i32,
    pub(super) immediate: bool,
    pub(super) goto: Option<usize>,
    pub(super) call: Option<usize>,
    pub(super) depth: usize,
    pub(super) armed_at: Ns,
}

#[derive(Debug, Clone, Copy)]
pub(super) struct MotionParams {
    pub(super) speed: Speed,
    pub(super) speed_once: Option<Speed>,
    pub(super) accuracy: (f64, bool),
    pub(super) accuracy_once: Option<(f64, bool)>,
    pub(super) accel: f64,
    pub(super) accel_once: Option<f64>,
    pub(super) decel: f64,
    pub(super) decel_once: Option<f64>,
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
pub(super) enum Run {
    Idle,
    Running,
    /// Robot task: the program ended, the motion is finishing (TASK = 3).
    Ending,
}

#[derive(Debug, Clone)]
pub(super) struct Task {
    pub(super) id: TaskId,
    pub(super) run: Run,
    pub(super) frames: Vec<Frame>,
    pub(super) ready_at: Ns,
    pub(super) wait: Option<Wait>,
    /// Re-check a socket wait now (another task used a socket).
    pub(super) kick: bool,
    /// Next poll of a polled wait (a grid point of the poll period).
    pub(super) poll_at: Ns,
    /// Cycles still to run, this one included; negative: for ever (`PCEXECUTE n: p, -1`).
    pub(super) cycles_left: i64,
    /// Cycles the task has completed since it was started.
    pub(super) cycles_done: u32,
    pub(super) motion: MotionParams,
    pub(super) interrupts: Vec<Interrupt>,
    pub(super) pending_on: Option<Interrupt>,
    pub(super) last_error: Option<String>,
    pub(super) steps: u64,
    pub(super) line_buf: String,
    /// The port its `UDP_RECVFROM` has open.
    pub(super) udp_port: Option<u16>,
    /// `ONE`: the program it runs when one of its statements fails.
    pub(super) error_program: Option<usize>,
    /// While that program runs: the depth of its frame (the task stops when it returns).
    pub(super) error_depth: Option<usize>,
    /// `ABORT`/`PCABORT` came while a step waited: the task stops once that step completes.
    /// `PCEND`: the task ends at the end of its current cycle, whatever cycles remain.
    pub(super) end_after_cycle: bool,
    pub(super) abort_after_step: bool,
}

impl Task {
    pub(super) fn new(id: TaskId) -> Task {
        Task {
            id,
            run: Run::Idle,
            frames: Vec::new(),
            ready_at: 0,
            wait: None,
            kick: false,
            poll_at: 0,
            cycles_left: 0,
            cycles_done: 0,
            motion: MotionParams::default(),
            interrupts: Vec::new(),
            pending_on: None,
            last_error: None,
            steps: 0,
            line_buf: String::new(),
            udp_port: None,
            error_program: None,
            error_depth: None,
            abort_after_step: false,
            end_after_cycle: false,
        }
    }
}

#[derive(Debug, Clone, Copy)]
pub(super) struct SignalState {
    pub(super) on: bool,
    pub(super) changed: Ns,
}

/// Flow after one step.
pub(super) enum Flow {
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
pub(super) enum LocVal {
    J([f32; 6]),
    T([f32; 6]),
}

#[derive(Debug, Clone)]
pub(super) enum ArgVal {
    R(f32),
    S(Bytes),
    J([f32; 6]),
    T([f32; 6]),
    /// A variable given as an argument that holds no value yet.
    Undefined,
    /// A whole array (`.$data[]`): every element and the scalar.
    Array(ArrayVal),
}

/// A whole variable, scalar and elements, of one type.
#[derive(Debug, Clone)]
pub(super) enum ArrayVal {
    R(Var<f32>),
    S(Var<Bytes>),
    J(Var<[f32; 6]>),
    T(Var<[f32; 6]>),
}

impl ArrayVal {
    /// A copy of the variable `slot` of type `ty` in `store`.
    pub(super) fn of(store: &Store, ty: Ty, slot: usize) -> Option<ArrayVal> {
        Some(match ty {
            Ty::Real => ArrayVal::R(store.reals.get(slot)?.clone()),
            Ty::Str => ArrayVal::S(store.strs.get(slot)?.clone()),
            Ty::Joint => ArrayVal::J(store.joints.get(slot)?.clone()),
            Ty::Trans => ArrayVal::T(store.trans.get(slot)?.clone()),
        })
    }

    /// Whether it is a variable of type `ty`.
    pub(super) fn fits(&self, ty: Ty) -> bool {
        matches!(
            (ty, self),
            (Ty::Real, ArrayVal::R(_))
                | (Ty::Str, ArrayVal::S(_))
                | (Ty::Joint, ArrayVal::J(_))
                | (Ty::Trans, ArrayVal::T(_))
        )
    }

    /// Puts it in the variable `slot` of `store` (when the types agree): how many elements
    /// the store holds more than before (negative: fewer).
    pub(super) fn put(self, store: &mut Store, ty: Ty, slot: usize) -> Option<isize> {
        fn swap<T>(v: &mut Var<T>, new: Var<T>) -> isize {
            let before = v.element_count() as isize;
            *v = new;
            v.element_count() as isize - before
        }
        Some(match (ty, self) {
            (Ty::Real, ArrayVal::R(v)) => swap(store.reals.get_mut(slot)?, v),
            (Ty::Str, ArrayVal::S(v)) => swap(store.strs.get_mut(slot)?, v),
            (Ty::Joint, ArrayVal::J(v)) => swap(store.joints.get_mut(slot)?, v),
            (Ty::Trans, ArrayVal::T(v)) => swap(store.trans.get_mut(slot)?, v),
            _ => return None,
        })
    }
}

/// Where a by-reference argument goes back.
#[derive(Debug, Clone)]
pub(super) struct ByRefTarget {
    pub(super) var: VarRef,
    pub(super) idx: Vec<i32>,
    pub(super) frame: usize,
    /// A whole array (`.$data[]`).
    pub(super) whole: bool,
}

/// A task's place in the interpreter's task table: 0 for the robot task, 1–5 for PC tasks
/// 1–5 (what [`TaskId`] names, as an index). One byte: it measured faster than a `usize`
/// in the loop of pure computation (the register allocator keeps the program there).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub(super) struct TaskSlot(u8);

impl TaskSlot {
    /// The robot task's slot.
    pub(super) const ROBOT: TaskSlot = TaskSlot(0);

    /// The slot of a task.
    #[inline]
    pub(super) fn of(id: TaskId) -> TaskSlot {
        TaskSlot(id.index() as u8)
    }

    /// The slot at `index` of the task table (callers pass 0–5: the table has six tasks).
    #[inline]
    pub(super) fn at(index: usize) -> TaskSlot {
        TaskSlot(index as u8)
    }

    /// The index in the task table.
    #[inline(always)]
    pub(super) fn index(self) -> usize {
        usize::from(self.0)
    }

    /// `true` for the robot task.
    #[inline(always)]
    pub(super) fn is_robot(self) -> bool {
        self.0 == 0
    }
}

impl std::ops::Index<TaskSlot> for Vec<Task> {
    type Output = Task;

    #[inline(always)]
    fn index(&self, slot: TaskSlot) -> &Task {
        &self[usize::from(slot.0)]
    }
}

impl std::ops::IndexMut<TaskSlot> for Vec<Task> {
    #[inline(always)]
    fn index_mut(&mut self, slot: TaskSlot) -> &mut Task {
        &mut self[usize::from(slot.0)]
    }
}
