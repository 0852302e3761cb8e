//! Controller error codes as AS reports them in reply field 2.
//!
//! AS encodes an error `Pxxxx` as −1xxxx, `Wxxxx` as −2xxxx, `Exxxx` as −3xxxx and `Dxxxx` as
//! −4xxxx; 0 means no error. So `E1088` travels as `-31088`.

use std::fmt;
use std::str::FromStr;

/// Class letter of an AS error code.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub enum ErrorClass {
    /// `P` — operation error (e.g. P1001 "cannot execute program in TEACH mode").
    P,
    /// `W` — warning.
    W,
    /// `E` — error (stops the robot).
    E,
    /// `D` — fatal/hardware error.
    D,
}

impl ErrorClass {
    /// The class letter.
    pub fn letter(self) -> char {
        match self {
            ErrorClass::P => 'P',
            ErrorClass::W => 'W',
            ErrorClass::E => 'E',
            ErrorClass::D => 'D',
        }
    }

    fn digit(self) -> i32 {
        match self {
            ErrorClass::P => 1,
            ErrorClass::W => 2,
            ErrorClass::E => 3,
            ErrorClass::D => 4,
        }
    }
}

/// The controller's current error as the number AS `ERROR` returns (0 = no error).
///
/// ```
/// use fs020n_proto::ErrorCode;
/// let e: ErrorCode = "E1088".parse().unwrap();
/// assert_eq!(e.raw(), -31088);
/// assert_eq!(e.to_string(), "E1088");
/// assert_eq!(e.message(), Some("Destination is out of motion range"));
/// assert!(ErrorCode::NONE.is_none());
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "serde", serde(transparent))]
pub struct ErrorCode(pub i32);

impl ErrorCode {
    /// No error.
    pub const NONE: ErrorCode = ErrorCode(0);
    /// E1088 Destination is out of motion range.
    pub const DESTINATION_OUT_OF_RANGE: ErrorCode = ErrorCode(-31088);
    /// E3808 External emergency stop pressed.
    pub const EMERGENCY_STOP: ErrorCode = ErrorCode(-33808);
    /// E1135 Motor power OFF.
    pub const MOTOR_POWER_OFF: ErrorCode = ErrorCode(-31135);
    /// E0102 Variable is not defined (a program read a real variable or array element never
    /// assigned).
    pub const VARIABLE_NOT_DEFINED: ErrorCode = ErrorCode(-30102);
    /// E0101 Nonexistent label (a jump to a label the program does not have).
    pub const NONEXISTENT_LABEL: ErrorCode = ErrorCode(-30101);
    /// E0103 Location data is not defined (a transformation or joint variable never assigned).
    pub const LOCATION_NOT_DEFINED: ErrorCode = ErrorCode(-30103);
    /// E0104 String variable is not defined.
    pub const STRING_NOT_DEFINED: ErrorCode = ErrorCode(-30104);
    /// E0106 Value is out of range (an argument outside what the instruction accepts).
    pub const VALUE_OUT_OF_RANGE: ErrorCode = ErrorCode(-30106);
    /// E0108 Divided by zero.
    pub const DIVIDED_BY_ZERO: ErrorCode = ErrorCode(-30108);
    /// E0109 Floating point overflow.
    pub const FLOATING_POINT_OVERFLOW: ErrorCode = ErrorCode(-30109);
    /// E0110 String too long.
    pub const STRING_TOO_LONG: ErrorCode = ErrorCode(-30110);
    /// E0114 SQRT parameter is negative.
    pub const SQRT_OF_NEGATIVE: ErrorCode = ErrorCode(-30114);
    /// E0115 Array suffix value outside range.
    pub const ARRAY_INDEX_OUT_OF_RANGE: ErrorCode = ErrorCode(-30115);
    /// E0118 Too many subroutine calls (CALLs nested too deep).
    pub const TOO_MANY_SUBROUTINE_CALLS: ErrorCode = ErrorCode(-30118);
    /// E0119 Nonexistent subroutine (a program that is not loaded).
    pub const NONEXISTENT_SUBROUTINE: ErrorCode = ErrorCode(-30119);
    /// E1095 Cannot execute motion instruction in PC program.
    pub const MOTION_IN_PC_PROGRAM: ErrorCode = ErrorCode(-31095);
    /// E1097 Missing C1MOVE or C2MOVE instruction (a C1MOVE not followed by its C2MOVE).
    pub const C1MOVE_OR_C2MOVE_MISSING: ErrorCode = ErrorCode(-31097);
    /// E1098 C1MOVE instruction required before C2MOVE.
    pub const C1MOVE_REQUIRED_BEFORE_C2MOVE: ErrorCode = ErrorCode(-31098);
    /// E1099 Unable to create arc path: the three points of a circular motion define no circle
    /// (two coincide, or all lie on one line).
    pub const NO_ARC_THROUGH_POINTS: ErrorCode = ErrorCode(-31099);
    /// P1023 Cannot execute in robot program (an instruction only PC programs may run).
    pub const NOT_IN_ROBOT_PROGRAM: ErrorCode = ErrorCode(-11023);
    /// P1031 No free memory (variable memory full).
    pub const NO_FREE_MEMORY: ErrorCode = ErrorCode(-11031);

    /// Builds a code from its class and four-digit number (`E`, 1088 → −31088).
    pub fn new(class: ErrorClass, number: u16) -> ErrorCode {
        ErrorCode(-(class.digit() * 10000 + i32::from(number % 10000)))
    }

    /// The raw number as sent on the wire.
    pub fn raw(self) -> i32 {
        self.0
    }

    /// `true` when there is no error.
    pub fn is_none(self) -> bool {
        self.0 == 0
    }

    /// The class, when the number follows the AS encoding (−1xxxx … −4xxxx).
    pub fn class(self) -> Option<ErrorClass> {
        match self.0 {
            -19999..=-10000 => Some(ErrorClass::P),
            -29999..=-20000 => Some(ErrorClass::W),
            -39999..=-30000 => Some(ErrorClass::E),
            -49999..=-40000 => Some(ErrorClass::D),
            _ => None,
        }
    }

    /// The four-digit number within the class (E1088 → 1088).
    pub fn number(self) -> Option<u16> {
        self.class().map(|_| (self.0.unsigned_abs() % 10000) as u16)
    }

    /// The message of the codes the protocol reference names and of the program-execution
    /// errors of the AS manual's error list (E0101–E0121, E1095–E1099, P1023, P1031), in
    /// English.
    pub fn message(self) -> Option<&'static str> {
        ERROR_MESSAGES
            .iter()
            .find(|(code, _)| *code == self.0)
            .map(|(_, m)| *m)
    }
}

impl fmt::Display for ErrorCode {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match (self.class(), self.number()) {
            _ if self.is_none() => write!(f, "none"),
            (Some(c), Some(n)) => write!(f, "{}{:04}", c.letter(), n),
            _ => write!(f, "code {}", self.0),
        }
    }
}

/// Error of parsing an error name such as `"E1088"`.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("{0:?} is not an AS error code: expected a class letter P, W, E or D and four digits (e.g. E1088), or a raw number (e.g. -31088)")]
pub struct ParseErrorCodeError(pub String);

impl FromStr for ErrorCode {
    type Err = ParseErrorCodeError;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        let t = s.trim();
        let err = || ParseErrorCodeError(s.to_owned());
        if let Ok(raw) = t.parse::<i32>() {
            return Ok(ErrorCode(raw));
        }
        let mut chars = t.chars();
        let class = match chars.next().map(|c| c.to_ascii_uppercase()) {
            Some('P') => ErrorClass::P,
            Some('W') => ErrorClass::W,
            Some('E') => ErrorClass::E,
            Some('D') => ErrorClass::D,
            _ => return Err(err()),
        };
        let digits = chars.as_str();
        if digits.len() != 4 || !digits.bytes().all(|b| b.is_ascii_digit()) {
            return Err(err());
        }
        let number = digits.parse::<u16>().map_err(|_| err())?;
        Ok(ErrorCode::new(class, number))
    }
}

/// Messages of the error codes named in the protocol reference and of the program-execution
/// errors (the numbers of the error list of Kawasaki's AS manual, E series, Appendix 4; the
/// wording is this crate's, and the FS020N's D controller may word them differently).
pub(crate) const ERROR_MESSAGES: &[(i32, &str)] = &[
    (-11000, "Motor power OFF, cannot execute program"),
    (-11001, "Cannot execute program in TEACH mode"),
    (-11002, "Teach lock ON, cannot execute program"),
    (-11009, "Program is already running"),
    (
        -11013,
        "In error; cannot execute program; reset the error first",
    ),
    (-11023, "Cannot execute in a robot program"),
    (-11031, "No free memory"),
    (-30101, "Nonexistent label"),
    (-30102, "Variable is not defined"),
    (-30103, "Location data is not defined"),
    (-30104, "String variable is not defined"),
    (-30105, "Program or label is not defined"),
    (-30106, "Value is out of range"),
    (-30107, "No array index"),
    (-30108, "Division by zero"),
    (-30109, "Floating point overflow"),
    (-30110, "String too long"),
    (-30111, "Operation with a negative exponent"),
    (-30112, "Expression too complicated"),
    (-30113, "No expression to evaluate"),
    (-30114, "SQRT of a negative number"),
    (-30115, "Array index out of range"),
    (-30116, "Argument value wrong or missing"),
    (-30117, "Incorrect joint number"),
    (-30118, "Too many nested subroutine calls"),
    (-30119, "Nonexistent subroutine"),
    (-30120, "No destination program"),
    (-30121, "Cannot jump to the program the jump comes from"),
    (
        -31095,
        "Cannot execute a motion instruction in a PC program",
    ),
    (-31097, "C1MOVE or C2MOVE instruction missing"),
    (-31098, "C2MOVE needs a C1MOVE before it"),
    (
        -31099,
        "Cannot create the arc: check the positions of the three points",
    ),
    (-31082, "Beyond absolute lower motion limit"),
    (-31083, "Beyond absolute upper motion limit"),
    (-31084, "Beyond set lower motion limit"),
    (-31085, "Beyond set upper motion limit"),
    (-31086, "Start point out of motion range"),
    (-31087, "End point out of motion range"),
    (-31088, "Destination is out of motion range"),
    (-31122, "Motor power unexpectedly OFF"),
    (-31130, "Collision detected"),
    (-31135, "Motor power OFF"),
    (-33808, "External emergency stop pressed"),
    (-36007, "Singular point 1 (wrist straight)"),
    (-36008, "Singular point 2 (wrist bent)"),
    (-36016, "Singular point 3 (arm stretched)"),
    (-34007, "Received data too long (max 255 characters)"),
];

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn decoding_classes() {
        assert_eq!(ErrorCode(-31088).to_string(), "E1088");
        assert_eq!(ErrorCode(-11001).to_string(), "P1001");
        assert_eq!(ErrorCode(-21004).to_string(), "W1004");
        assert_eq!(ErrorCode(-40952).to_string(), "D0952");
        assert_eq!(ErrorCode(0).to_string(), "none");
        assert_eq!(ErrorCode(-5).to_string(), "code -5");
        assert_eq!(ErrorCode(12).class(), None);
        assert_eq!(ErrorCode(-33808).number(), Some(3808));
        assert_eq!(ErrorCode::new(ErrorClass::D, 952), ErrorCode(-40952));
    }

    #[test]
    fn parsing_names() {
        assert_eq!("E1088".parse::<ErrorCode>().unwrap(), ErrorCode(-31088));
        assert_eq!("p1000".parse::<ErrorCode>().unwrap(), ErrorCode(-11000));
        assert_eq!(
            "-33808".parse::<ErrorCode>().unwrap(),
            ErrorCode::EMERGENCY_STOP
        );
        assert!("X1088".parse::<ErrorCode>().is_err());
        assert!("E10888".parse::<ErrorCode>().is_err());
        assert!("".parse::<ErrorCode>().is_err());
    }

    #[test]
    fn every_named_code_round_trips_through_its_name() {
        for (raw, msg) in ERROR_MESSAGES {
            let code = ErrorCode(*raw);
            assert_eq!(code.to_string().parse::<ErrorCode>().unwrap(), code);
            assert_eq!(code.message(), Some(*msg));
        }
        assert_eq!(ErrorCode(-39999).message(), None);
    }

    #[test]
    fn program_execution_codes_carry_the_manuals_numbers_and_a_message() {
        let named = [
            (ErrorCode::NONEXISTENT_LABEL, "E0101"),
            (ErrorCode::VARIABLE_NOT_DEFINED, "E0102"),
            (ErrorCode::LOCATION_NOT_DEFINED, "E0103"),
            (ErrorCode::STRING_NOT_DEFINED, "E0104"),
            (ErrorCode::VALUE_OUT_OF_RANGE, "E0106"),
            (ErrorCode::DIVIDED_BY_ZERO, "E0108"),
            (ErrorCode::FLOATING_POINT_OVERFLOW, "E0109"),
            (ErrorCode::STRING_TOO_LONG, "E0110"),
            (ErrorCode::SQRT_OF_NEGATIVE, "E0114"),
            (ErrorCode::ARRAY_INDEX_OUT_OF_RANGE, "E0115"),
            (ErrorCode::TOO_MANY_SUBROUTINE_CALLS, "E0118"),
            (ErrorCode::NONEXISTENT_SUBROUTINE, "E0119"),
            (ErrorCode::MOTION_IN_PC_PROGRAM, "E1095"),
            (ErrorCode::C1MOVE_OR_C2MOVE_MISSING, "E1097"),
            (ErrorCode::C1MOVE_REQUIRED_BEFORE_C2MOVE, "E1098"),
            (ErrorCode::NO_ARC_THROUGH_POINTS, "E1099"),
            (ErrorCode::NOT_IN_ROBOT_PROGRAM, "P1023"),
            (ErrorCode::NO_FREE_MEMORY, "P1031"),
        ];
        for (code, name) in named {
            assert_eq!(code.to_string(), name);
            assert!(code.message().is_some(), "{name} has no message");
        }
        for n in 101..=121 {
            let code = ErrorCode::new(ErrorClass::E, n);
            assert!(code.message().is_some(), "{code} has no message");
        }
    }
}
