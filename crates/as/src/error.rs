//! Errors: a program text that does not parse ([`ParseError`], [`LoadError`]) and errors
//! while a program runs ([`RuntimeError`], each with its AS error code).

use std::sync::Arc;

use fs020n_proto::ErrorCode;

use crate::sockets::TcpCode;
use crate::span::Span;

/// One reason a program text is refused, with where and what was expected.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("{file}:{span}: {message}")]
pub struct ParseError {
    /// The file (or source name) the text came from.
    pub file: Arc<str>,
    /// Line and column.
    pub span: Span,
    /// What is wrong, and what was expected.
    pub message: String,
}

impl ParseError {
    /// An error at `span` of `file`.
    pub fn new(file: &str, span: Span, message: impl Into<String>) -> ParseError {
        ParseError {
            file: Arc::from(file),
            span,
            message: message.into(),
        }
    }
}

/// Every reason a set of program texts is refused (at most [`MAX_REPORTED`] are kept). Nothing
/// runs until all of them are fixed.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub struct LoadError {
    /// The errors, in file and line order.
    pub errors: Vec<ParseError>,
}

/// Most errors one load reports.
pub const MAX_REPORTED: usize = 50;

impl std::fmt::Display for LoadError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        for (i, e) in self.errors.iter().enumerate() {
            if i > 0 {
                f.write_str("\n")?;
            }
            write!(f, "{e}")?;
        }
        if self.errors.is_empty() {
            f.write_str("the program text was refused")?;
        }
        Ok(())
    }
}

impl From<ParseError> for LoadError {
    fn from(e: ParseError) -> LoadError {
        LoadError { errors: vec![e] }
    }
}

/// The code a task stops with when it reaches an instruction that loads but is not emulated
/// (E0199, the emulator's own: the AS manual's error list has no E0122–E0899, and its E0111
/// means "operation with a negative exponent").
pub const NOT_EMULATED: ErrorCode = ErrorCode(-30199);

/// An error while a program runs: the task stops and the controller's `ERROR` becomes
/// [`RuntimeError::code`], as on the controller.
///
/// The codes are those of the error list of the AS manual (E series, Appendix 4), except
/// [`RuntimeError::NotEmulated`] ([`NOT_EMULATED`], the emulator's own). docs/AS.md, "Runtime
/// errors", maps each.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum RuntimeError {
    /// A real variable or array element was read before anything was assigned to it (E0102).
    #[error("(E0102) variable not defined: {0} (assign it before reading it)")]
    Undefined(String),
    /// A location (transformation or joint) variable was read before anything was assigned to
    /// it (E0103).
    #[error("(E0103) location not defined: {0} (teach it with HERE or assign it with POINT before using it)")]
    LocationUndefined(String),
    /// A string variable was read before anything was assigned to it (E0104).
    #[error("(E0104) string variable not defined: {0} (assign it before reading it)")]
    StringUndefined(String),
    /// Division (or MOD) by zero (E0108).
    #[error("(E0108) division by zero (check the divisor before dividing)")]
    DivisionByZero,
    /// An array index outside 0–9999, or more than 3 dimensions (E0115).
    #[error("(E0115) array index out of range: {0} (indices go from 0 to 9999)")]
    IndexRange(String),
    /// An argument outside what the instruction or function accepts (E0106).
    #[error("(E0106) value out of range: {0}")]
    IllegalValue(String),
    /// A result too large for a 32-bit real, or not a number (E0109).
    #[error("(E0109) floating point overflow: {0}")]
    Overflow(String),
    /// `SQRT` of a negative number (E0114).
    #[error("(E0114) SQRT of a negative number: {0}")]
    SqrtNegative(String),
    /// A string longer than 255 characters (E0110).
    #[error("(E0110) string too long ({0} characters, at most 255)")]
    StringTooLong(usize),
    /// An instruction only a robot program may execute (a motion, `ONI`, …) reached in a PC
    /// program (E1095).
    #[error("(E1095) {0} (move it to the robot program)")]
    RobotOnly(String),
    /// An instruction only a PC program may execute (`EXECUTE`, `MC …`) reached in the robot
    /// program (P1023).
    #[error("(P1023) {0} (move it to a PC program)")]
    PcOnly(String),
    /// `CALL`s nested deeper than the interpreter allows (runaway recursion; E0118).
    #[error("(E0118) too many nested CALLs (at most {0}): a subroutine that calls itself needs a condition that ends it")]
    CallDepth(usize),
    /// More array elements or variables than the interpreter's memory holds (P1031).
    #[error("(P1031) no free memory: variable memory is full (at most {0} array elements)")]
    MemoryFull(usize),
    /// An instruction that loads but is not emulated was reached ([`NOT_EMULATED`], the
    /// emulator's own code: the controller would run it).
    #[error("(E0199) {0} is not emulated (fs020n as check lists these; --stub makes one a no-op)")]
    NotEmulated(String),
    /// A `C2MOVE` without a `C1MOVE` before it (E1098).
    #[error("(E1098) {0}")]
    C1MoveRequired(String),
    /// A `C1MOVE` not followed by its `C2MOVE`: another `C1MOVE`, another motion or the end of
    /// the program comes next (E1097).
    #[error("(E1097) {0}")]
    C2MoveMissing(String),
    /// Three points of a circular motion that define no circle: two coincide, or all lie on one
    /// line (E1099).
    #[error("(E1099) cannot create the arc: {0} (check the three points: all distinct, not on one line)")]
    NoArc(String),
    /// A program named by CALL, EXECUTE, PCEXECUTE or ON … CALL that no loaded file defines
    /// (the manual's E0119 "Nonexistent subroutine.").
    #[error(
        "(E0119) nonexistent subroutine: program {0} is not loaded (load the file that holds it)"
    )]
    NoProgram(String),
    /// A jump to a label the program does not have (the manual's E0101 "Nonexistent label.").
    #[error("(E0101) nonexistent label: {0}")]
    NoLabel(String),
    /// A controller error raised by the system (a motion refused, e.g. E1088).
    #[error("{}", describe(*.0))]
    System(ErrorCode),
}

fn describe(code: ErrorCode) -> String {
    match code.message() {
        Some(m) => format!("({code}) {m}"),
        None => format!("({code})"),
    }
}

impl RuntimeError {
    /// The AS error code that `ERROR` returns after this error (E0102 → −30102).
    pub fn code(&self) -> ErrorCode {
        match self {
            RuntimeError::Undefined(_) => ErrorCode::VARIABLE_NOT_DEFINED,
            RuntimeError::LocationUndefined(_) => ErrorCode::LOCATION_NOT_DEFINED,
            RuntimeError::StringUndefined(_) => ErrorCode::STRING_NOT_DEFINED,
            RuntimeError::DivisionByZero => ErrorCode::DIVIDED_BY_ZERO,
            RuntimeError::IndexRange(_) => ErrorCode::ARRAY_INDEX_OUT_OF_RANGE,
            RuntimeError::IllegalValue(_) => ErrorCode::VALUE_OUT_OF_RANGE,
            RuntimeError::Overflow(_) => ErrorCode::FLOATING_POINT_OVERFLOW,
            RuntimeError::SqrtNegative(_) => ErrorCode::SQRT_OF_NEGATIVE,
            RuntimeError::StringTooLong(_) => ErrorCode::STRING_TOO_LONG,
            RuntimeError::RobotOnly(_) => ErrorCode::MOTION_IN_PC_PROGRAM,
            RuntimeError::PcOnly(_) => ErrorCode::NOT_IN_ROBOT_PROGRAM,
            RuntimeError::CallDepth(_) => ErrorCode::TOO_MANY_SUBROUTINE_CALLS,
            RuntimeError::MemoryFull(_) => ErrorCode::NO_FREE_MEMORY,
            RuntimeError::NotEmulated(_) => NOT_EMULATED,
            RuntimeError::C1MoveRequired(_) => ErrorCode::C1MOVE_REQUIRED_BEFORE_C2MOVE,
            RuntimeError::C2MoveMissing(_) => ErrorCode::C1MOVE_OR_C2MOVE_MISSING,
            RuntimeError::NoArc(_) => ErrorCode::NO_ARC_THROUGH_POINTS,
            RuntimeError::NoProgram(_) => ErrorCode::NONEXISTENT_SUBROUTINE,
            RuntimeError::NoLabel(_) => ErrorCode::NONEXISTENT_LABEL,
            RuntimeError::System(c) => *c,
        }
    }

    /// Whether this is the error of reading a variable never assigned (E0102, E0103 or E0104,
    /// whatever its type).
    pub fn is_undefined(&self) -> bool {
        matches!(
            self,
            RuntimeError::Undefined(_)
                | RuntimeError::LocationUndefined(_)
                | RuntimeError::StringUndefined(_)
        )
    }
}

/// The message `$ERROR(code)` returns: the controller's codes ([`ErrorCode::message`]), the
/// socket codes ([`TcpCode`]) and [`NOT_EMULATED`].
pub fn error_message(code: i32) -> Option<&'static str> {
    if code == NOT_EMULATED.0 {
        return Some("Instruction not emulated");
    }
    match TcpCode::from_code(code) {
        Some(tcp) => Some(tcp.message()),
        None => ErrorCode(code).message(),
    }
}
