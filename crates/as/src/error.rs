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

/// E0112, "circular motion not defined" ([`RuntimeError::Circular`]; the system's code for a
/// circle it cannot plan, too).
pub const CIRCLE_NOT_DEFINED: ErrorCode = ErrorCode(-30112);

/// An error while a program runs: the task stops and the controller's `ERROR` becomes
/// [`RuntimeError::code`], as on the controller.
///
/// Only E0102 ("variable not defined") is confirmed by the AS manuals this interpreter was
/// written from; the other E01xx numbers are this interpreter's own (docs/AS.md, "Runtime
/// errors"), chosen in the range AS uses for program errors.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum RuntimeError {
    /// A variable or array element was read before anything was assigned to it.
    #[error("(E0102) variable not defined: {0}")]
    Undefined(String),
    /// Division (or MOD) by zero.
    #[error("(E0103) division by zero")]
    DivisionByZero,
    /// An array index outside 0–9999, or more than 3 dimensions.
    #[error("(E0104) array index out of range: {0}")]
    IndexRange(String),
    /// An argument outside what the instruction or function accepts.
    #[error("(E0105) illegal value: {0}")]
    IllegalValue(String),
    /// A result too large for a 32-bit real, or not a number (`SQRT(-1)`).
    #[error("(E0106) value out of range: {0}")]
    Overflow(String),
    /// A string longer than 255 characters.
    #[error("(E0107) string too long ({0} characters, at most 255)")]
    StringTooLong(usize),
    /// An instruction that this kind of task cannot execute (a motion in a PC program, `MC`
    /// in a robot program, `ONI` in a PC program).
    #[error("(E0108) {0}")]
    WrongTask(String),
    /// `CALL`s nested deeper than the interpreter allows (runaway recursion).
    #[error("(E0109) too many nested CALLs (at most {0})")]
    CallDepth(usize),
    /// More array elements or variables than the interpreter's memory holds.
    #[error("(E0110) variable memory full (at most {0} array elements)")]
    MemoryFull(usize),
    /// An instruction that loads but is not emulated was reached (the emulator's own code:
    /// the controller would run it).
    #[error("(E0111) {0} is not emulated (fs020n as check lists these; --stub makes one a no-op)")]
    NotEmulated(String),
    /// A circular motion that is not defined: a `C2MOVE` without its `C1MOVE`, a `C1MOVE`
    /// followed by another motion (or by the program's end), or three points that define no
    /// circle (two coincide, or all on one line).
    #[error("(E0112) circular motion not defined: {0}")]
    Circular(String),
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
            RuntimeError::Undefined(_) => ErrorCode(-30102),
            RuntimeError::DivisionByZero => ErrorCode(-30103),
            RuntimeError::IndexRange(_) => ErrorCode(-30104),
            RuntimeError::IllegalValue(_) => ErrorCode(-30105),
            RuntimeError::Overflow(_) => ErrorCode(-30106),
            RuntimeError::StringTooLong(_) => ErrorCode(-30107),
            RuntimeError::WrongTask(_) => ErrorCode(-30108),
            RuntimeError::CallDepth(_) => ErrorCode(-30109),
            RuntimeError::MemoryFull(_) => ErrorCode(-30110),
            RuntimeError::NotEmulated(_) => ErrorCode(-30111),
            RuntimeError::NoProgram(_) => ErrorCode(-30119),
            RuntimeError::NoLabel(_) => ErrorCode(-30101),
            RuntimeError::Circular(_) => CIRCLE_NOT_DEFINED,
            RuntimeError::System(c) => *c,
        }
    }
}

/// The message `$ERROR(code)` returns for the codes this interpreter raises (and those the
/// protocol reference names).
pub fn error_message(code: i32) -> Option<&'static str> {
    match code {
        -30102 => Some("Variable not defined"),
        -30103 => Some("Division by zero"),
        -30104 => Some("Array index out of range"),
        -30105 => Some("Illegal value"),
        -30106 => Some("Value out of range"),
        -30107 => Some("String too long"),
        -30108 => Some("Instruction not allowed in this task"),
        -30109 => Some("Too many nested CALLs"),
        -30110 => Some("Variable memory full"),
        -30111 => Some("Instruction not emulated"),
        -30112 => Some("Circular motion not defined"),
        other => match TcpCode::from_code(other) {
            Some(tcp) => Some(tcp.message()),
            None => ErrorCode(other).message(),
        },
    }
}
