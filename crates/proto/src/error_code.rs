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
    /// E0102 Variable is not defined (a program read a variable or array element never
    /// assigned).
    pub const VARIABLE_NOT_DEFINED: ErrorCode = ErrorCode(-30102);

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

    /// The message of the codes the protocol reference names, in English.
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

/// Messages of the error codes named in the protocol reference (from Kawasaki's AS manuals,
/// E series; the FS020N's D controller may word them differently).
pub(crate) const ERROR_MESSAGES: &[(i32, &str)] = &[
    (-11000, "Motor power OFF, cannot execute program"),
    (-11001, "Cannot execute program in TEACH mode"),
    (-11002, "Teach lock ON, cannot execute program"),
    (-11009, "Program is already running"),
    (
        -11013,
        "In error; cannot execute program; reset the error first",
    ),
    (-30102, "Variable is not defined"),
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
}
