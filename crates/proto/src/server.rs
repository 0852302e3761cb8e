//! Server-side request parsing with the controller's semantics.
//!
//! This is how the AS server program reads a request (the emulator uses it; a client never
//! needs it): only the first 255 bytes count; tokens are cut the way the program's alternating
//! `$DECODE(text, " ", 0)` / `$DECODE(text, " ", 1)` cut them ([`server_tokens`]: any run of
//! blanks *between* tokens is one separator, but a leading blank makes the first token empty);
//! every token goes through `VAL` ([`as_val`]); the version and command number are reals; and
//! COUNT_OF_ARGS is trusted (missing arguments read 0, extra ones are ignored).
//!
//! ```
//! use fs020n_proto::server::ServerRequest;
//! use fs020n_proto::Command;
//! let r = ServerRequest::parse(b"1040 3 1 50abc");
//! assert!(r.version_matches());
//! assert_eq!(r.command(), Command::SetSpeed { percent: 50.0 });
//! assert!(!ServerRequest::parse(b" 1040 3 1 50").version_matches());
//! // Runs of blanks between tokens act.
//! assert_eq!(ServerRequest::parse(b"1040  3 1   50").command(), Command::SetSpeed { percent: 50.0 });
//! ```

use crate::joints::{JointsDeg, JOINT_COUNT};
use crate::number::as_val;
use crate::request::{Command, StreamSample};
use crate::session::{MAX_REQUEST_BYTES, PROTOCOL_VERSION};

/// Most arguments kept: no command reads more than 21, and 255 bytes cannot hold more than 128
/// tokens.
pub const MAX_ARGS: usize = 128;

/// A request as the controller understands it.
#[derive(Debug, Clone, PartialEq)]
pub struct ServerRequest {
    /// `VAL` of the first token.
    pub version: f64,
    /// `VAL` of the second token.
    pub command_number: f64,
    /// The trusted argument count (`VAL` of the third token, truncated, at least 0).
    pub count: usize,
    /// `count` arguments (at most [`MAX_ARGS`]); missing ones are 0.
    pub args: Vec<f64>,
}

impl ServerRequest {
    /// Parses the bytes of one receive call. Never fails: every input means something to the
    /// controller.
    pub fn parse(bytes: &[u8]) -> ServerRequest {
        let head = &bytes[..bytes.len().min(MAX_REQUEST_BYTES)];
        let text = String::from_utf8_lossy(head);
        let tokens: Vec<&str> = server_tokens(&text).collect();
        let val = |i: usize| tokens.get(i).map_or(0.0, |t| as_val(t));
        let count_val = val(2);
        let count = if count_val >= 1.0 {
            (count_val.trunc() as usize).min(MAX_ARGS)
        } else {
            0
        };
        let args = (0..count).map(|i| val(3 + i)).collect();
        ServerRequest {
            version: val(0),
            command_number: val(1),
            count,
            args,
        }
    }

    /// `true` when the version is 1040: only then does the server act.
    pub fn version_matches(&self) -> bool {
        self.version == PROTOCOL_VERSION as f64
    }

    /// Argument `i` (0-based), 0 when missing.
    pub fn arg(&self, i: usize) -> f64 {
        self.args.get(i).copied().unwrap_or(0.0)
    }

    fn joints_from(&self, first: usize) -> JointsDeg {
        let mut j = [0.0; JOINT_COUNT];
        for (k, v) in j.iter_mut().enumerate() {
            *v = self.arg(first + k);
        }
        JointsDeg(j)
    }

    /// The command the server sees.
    pub fn command(&self) -> Command {
        match self.command_number {
            1.0 => Command::StartProgram,
            2.0 => Command::StopProgram,
            3.0 => Command::SetSpeed {
                percent: self.arg(0),
            },
            4.0 => Command::Reserved,
            5.0 => Command::CancelMotion,
            6.0 => Command::JointMove {
                target: self.joints_from(3),
            },
            7.0 => Command::StreamedMove(StreamSample {
                t0_s: self.arg(0),
                lookahead_passes: self.arg(1),
                position: self.joints_from(3),
                velocity: self.joints_from(9),
                acceleration: self.joints_from(15),
            }),
            255.0 => Command::EndSession,
            number => Command::Other {
                number,
                args: self.args.clone(),
            },
        }
    }
}

/// The tokens of a request as the AS server program cuts them: `$DECODE(text, " ", 0)` takes
/// the text before the next blank (nothing when the text starts with one), then
/// `$DECODE(text, " ", 1)` removes the whole run of blanks that follows, and so on. So runs of
/// blanks between tokens are one separator, trailing blanks end the tokens, and a leading blank
/// yields an empty first token (`VAL("")` is 0: a version mismatch). Only the blank (0x20)
/// separates; a tab is part of a token.
///
/// ```
/// use fs020n_proto::server::server_tokens;
/// assert_eq!(server_tokens("1040  3 1 50 ").collect::<Vec<_>>(), ["1040", "3", "1", "50"]);
/// assert_eq!(server_tokens(" 1040 3").collect::<Vec<_>>(), ["", "1040", "3"]);
/// ```
pub fn server_tokens(text: &str) -> impl Iterator<Item = &str> {
    let mut rest = Some(text);
    std::iter::from_fn(move || {
        let r = rest?;
        let cut = r.find(' ').unwrap_or(r.len());
        let (token, after) = r.split_at(cut);
        let after = after.trim_start_matches(' ');
        rest = (!after.is_empty()).then_some(after);
        // The first cut of a text that starts with a blank is an empty token; afterwards the
        // blanks are gone, so an empty token only ends the text.
        (!token.is_empty() || cut == 0 && r.len() == text.len()).then_some(token)
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn controller_semantics() {
        let r = ServerRequest::parse(b"1040 6 9 0 0 0 1 2 3 4 5 6");
        assert_eq!(
            r.command(),
            Command::JointMove {
                target: JointsDeg::new([1.0, 2.0, 3.0, 4.0, 5.0, 6.0])
            }
        );
        // COUNT too large: missing args are 0.
        let r = ServerRequest::parse(b"1040 6 9 0 0 0 1 2");
        assert_eq!(
            r.command(),
            Command::JointMove {
                target: JointsDeg::new([1.0, 2.0, 0.0, 0.0, 0.0, 0.0])
            }
        );
        // COUNT too small: extra tokens ignored.
        let r = ServerRequest::parse(b"1040 6 4 0 0 0 1 2 3");
        assert_eq!(
            r.command(),
            Command::JointMove {
                target: JointsDeg::new([1.0, 0.0, 0.0, 0.0, 0.0, 0.0])
            }
        );
        // 6.5 matches nothing.
        assert!(
            matches!(ServerRequest::parse(b"1040 6.5 0").command(), Command::Other { number, .. } if number == 6.5)
        );
        // Empty / non-numeric tokens are 0; "12abc" is 12.
        let r = ServerRequest::parse(b"1040 3 1 12abc");
        assert_eq!(r.command(), Command::SetSpeed { percent: 12.0 });
        let r = ServerRequest::parse(b"");
        assert!(!r.version_matches());
        assert_eq!(r.command_number, 0.0);
        // A run of blanks between tokens is one separator (the program cuts the whole run).
        let r = ServerRequest::parse(b"1040  3 1 50");
        assert_eq!(r.command(), Command::SetSpeed { percent: 50.0 });
        let r = ServerRequest::parse(b"1040 6   9 0 0 0  1 2 3    4 5 6   ");
        assert_eq!(
            r.command(),
            Command::JointMove {
                target: JointsDeg::new([1.0, 2.0, 3.0, 4.0, 5.0, 6.0])
            }
        );
        // A leading blank (or several) still empties the version token.
        assert!(!ServerRequest::parse(b" 1040 3 1 50").version_matches());
        assert!(!ServerRequest::parse(b"   1040 3 1 50").version_matches());
        // Only blanks separate.
        // Only blanks separate: "1040\t3" is one token whose VAL is 1040, so "1" is the command.
        let r = ServerRequest::parse(b"1040\t3 1 50");
        assert!(r.version_matches());
        assert_eq!(r.command_number, 1.0);
        assert!(ServerRequest::parse(b"1040.0 1 0").version_matches());
    }

    #[test]
    fn only_the_first_255_bytes_count() {
        let mut text = String::from("1040 3 1 ");
        text.push_str(&" ".repeat(MAX_REQUEST_BYTES - text.len()));
        text.push_str("50");
        let r = ServerRequest::parse(text.as_bytes());
        assert_eq!(r.command(), Command::SetSpeed { percent: 0.0 });
        let mut text = String::from("1040 3 1 ");
        text.push_str(&"7".repeat(MAX_REQUEST_BYTES - text.len() - 1));
        let cut = ServerRequest::parse(format!("{text}99").as_bytes());
        let whole = ServerRequest::parse(format!("{text}9").as_bytes());
        assert_eq!(cut.args, whole.args);
    }

    #[test]
    fn client_encoding_round_trips_through_the_server_parser() {
        let c = Command::StreamedMove(StreamSample {
            t0_s: 3.25,
            lookahead_passes: 2.0,
            position: JointsDeg::new([1.5, -2.0, -90.0, 0.0, -90.0, 10.0]),
            velocity: JointsDeg::new([1.0; 6]),
            acceleration: JointsDeg::new([-1.0; 6]),
        });
        let text = crate::Request::new(c.clone()).encode().unwrap();
        let r = ServerRequest::parse(text.as_bytes());
        assert!(r.version_matches());
        assert_eq!(r.command(), c);
    }
}
