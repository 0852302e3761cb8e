//! Requests from the PC to the controller: commands and their exact encoding.
//!
//! A request is `VERSION COMMAND COUNT_OF_ARGS ARG1 ... ARGn`, ASCII, single blanks, no leading
//! blank, no terminator, at most [`MAX_REQUEST_BYTES`] bytes.

use std::fmt::Write as _;

use crate::error::EncodeError;
use crate::joints::{JointsDeg, JOINT_COUNT};
use crate::number::{format_request_number, push_request_number};
use crate::rules::{MAX_REQUEST_BYTES, PROTOCOL_VERSION};

/// One command-7 sample: where the trajectory is at server time `t0_s`, and how it moves.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct StreamSample {
    /// Time stamp in the server clock (seconds since the connection was accepted, TIMER(1)).
    pub t0_s: f64,
    /// Look-ahead, in passes of the motion program (ARG2).
    pub lookahead_passes: f64,
    /// Positions, degrees.
    pub position: JointsDeg,
    /// Velocities, degrees per second.
    pub velocity: JointsDeg,
    /// Accelerations, degrees per second squared.
    pub acceleration: JointsDeg,
}

impl StreamSample {
    /// Most time-stamp error the controller absorbs (seconds, either way).
    pub const TIME_CLAMP_S: f64 = 0.5;

    /// The position the controller aims at for this sample, exactly as the server program
    /// computes it on a pass starting at server time `now_s`, with its average pass duration
    /// `step_s`:
    ///
    /// ```text
    /// dt    = clamp(now - t0, -0.5, +0.5) + lookahead * step
    /// pt[i] = p[i] + dt * v[i] + 0.5 * dt^2 * a[i]
    /// ```
    ///
    /// ```
    /// use fs020n_proto::{JointsDeg, StreamSample};
    /// let s = StreamSample {
    ///     t0_s: 10.0,
    ///     lookahead_passes: 2.0,
    ///     position: JointsDeg::new([0.0, 0.0, -90.0, 0.0, -90.0, 0.0]),
    ///     velocity: JointsDeg::new([10.0, 0.0, 0.0, 0.0, 0.0, 0.0]),
    ///     acceleration: JointsDeg::new([2.0, 0.0, 0.0, 0.0, 0.0, 0.0]),
    /// };
    /// // 0.1 s late, two passes of 0.05 s ahead: dt = 0.2 s
    /// let p = s.extrapolate(10.1, 0.05);
    /// assert!((p[0] - (10.0 * 0.2 + 0.5 * 0.04 * 2.0)).abs() < 1e-12);
    /// ```
    pub fn extrapolate(&self, now_s: f64, step_s: f64) -> JointsDeg {
        let dt = (now_s - self.t0_s).clamp(-Self::TIME_CLAMP_S, Self::TIME_CLAMP_S)
            + self.lookahead_passes * step_s;
        let mut out = [0.0; JOINT_COUNT];
        for (i, o) in out.iter_mut().enumerate() {
            *o = self.position[i] + dt * self.velocity[i] + 0.5 * dt * dt * self.acceleration[i];
        }
        JointsDeg(out)
    }
}

/// A command of protocol 1040.
#[derive(Debug, Clone, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub enum Command {
    /// 1 — start the motion program `ros_move` (only if the panel allows it).
    StartProgram,
    /// 2 — stop the motion program: the robot stops at once, the program ends.
    StopProgram,
    /// 3 — set the monitor speed (percent) and switch ABS.SPEED on.
    SetSpeed {
        /// Monitor speed in percent (1–100 is meaningful).
        percent: f64,
    },
    /// 4 — reserved: recorded as the latest command, nothing else.
    Reserved,
    /// 5 — cancel the current motion (BRAKE); the program keeps running.
    CancelMotion,
    /// 6 — joint move (JMOVE) to six angles.
    JointMove {
        /// Target JT1..JT6, degrees.
        target: JointsDeg,
    },
    /// 7 — streamed move with extrapolation.
    StreamedMove(StreamSample),
    /// 255 — end the session.
    EndSession,
    /// Any other command number with its arguments: recorded as the latest command and
    /// otherwise ignored by the server.
    Other {
        /// The command number (the server compares it as a real: 6.5 matches nothing).
        number: f64,
        /// Arguments.
        args: Vec<f64>,
    },
}

impl Command {
    /// The command number on the wire.
    pub fn number(&self) -> f64 {
        match self {
            Command::StartProgram => 1.0,
            Command::StopProgram => 2.0,
            Command::SetSpeed { .. } => 3.0,
            Command::Reserved => 4.0,
            Command::CancelMotion => 5.0,
            Command::JointMove { .. } => 6.0,
            Command::StreamedMove(_) => 7.0,
            Command::EndSession => 255.0,
            Command::Other { number, .. } => *number,
        }
    }

    /// `true` for the commands that make the robot move (6 and 7).
    pub fn is_motion(&self) -> bool {
        matches!(self, Command::JointMove { .. } | Command::StreamedMove(_))
    }

    /// The arguments as sent, with their names for error messages.
    ///
    /// Command 6 sends nine: three unused zeros, then the six targets. Command 7 sends 21:
    /// t0, look-ahead, an unused zero, positions, velocities, accelerations.
    pub fn args(&self) -> Vec<(&'static str, f64)> {
        const TARGET: [&str; 6] = [
            "JT1 target",
            "JT2 target",
            "JT3 target",
            "JT4 target",
            "JT5 target",
            "JT6 target",
        ];
        const POS: [&str; 6] = [
            "JT1 position",
            "JT2 position",
            "JT3 position",
            "JT4 position",
            "JT5 position",
            "JT6 position",
        ];
        const VEL: [&str; 6] = [
            "JT1 velocity",
            "JT2 velocity",
            "JT3 velocity",
            "JT4 velocity",
            "JT5 velocity",
            "JT6 velocity",
        ];
        const ACC: [&str; 6] = [
            "JT1 acceleration",
            "JT2 acceleration",
            "JT3 acceleration",
            "JT4 acceleration",
            "JT5 acceleration",
            "JT6 acceleration",
        ];
        match self {
            Command::StartProgram
            | Command::StopProgram
            | Command::Reserved
            | Command::CancelMotion
            | Command::EndSession => Vec::new(),
            Command::SetSpeed { percent } => vec![("speed percent", *percent)],
            Command::JointMove { target } => {
                let mut v = vec![("unused", 0.0); 3];
                v.extend(TARGET.iter().zip(target.iter()).map(|(n, x)| (*n, x)));
                v
            }
            Command::StreamedMove(s) => {
                let mut v = vec![
                    ("t0", s.t0_s),
                    ("look-ahead", s.lookahead_passes),
                    ("unused", 0.0),
                ];
                v.extend(POS.iter().zip(s.position.iter()).map(|(n, x)| (*n, x)));
                v.extend(VEL.iter().zip(s.velocity.iter()).map(|(n, x)| (*n, x)));
                v.extend(ACC.iter().zip(s.acceleration.iter()).map(|(n, x)| (*n, x)));
                v
            }
            Command::Other { args, .. } => args.iter().map(|a| ("argument", *a)).collect(),
        }
    }
}

/// Command numbers with a meaning, as written on the wire.
const KNOWN_COMMANDS: [&str; 8] = ["1", "2", "3", "4", "5", "6", "7", "255"];

/// A request: protocol version and command.
///
/// ```
/// use fs020n_proto::{Command, JointsDeg, Request};
/// let r = Request::new(Command::JointMove { target: JointsDeg::new([0.0, 30.0, -90.0, 0.0, -90.0, 0.0]) });
/// assert_eq!(r.encode().unwrap(), "1040 6 9 0 0 0 0 30 -90 0 -90 0");
/// assert_eq!(Request::status_poll().encode().unwrap(), "0 0 0");
/// ```
#[derive(Debug, Clone, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct Request {
    /// Protocol version; the server acts only on [`PROTOCOL_VERSION`] (1040).
    pub version: i64,
    /// The command.
    pub command: Command,
}

impl Request {
    /// A request of the current protocol version.
    pub fn new(command: Command) -> Request {
        Request {
            version: PROTOCOL_VERSION,
            command,
        }
    }

    /// The side-effect-free status poll `0 0 0`: a mismatched version, so the server changes
    /// nothing and just replies. (A `1040 0 0` poll would become the latest command and stop a
    /// stream.)
    pub fn status_poll() -> Request {
        Request {
            version: 0,
            command: Command::Other {
                number: 0.0,
                args: Vec::new(),
            },
        }
    }

    /// `true` if the server will act on this request (version 1040).
    pub fn is_effective(&self) -> bool {
        self.version == PROTOCOL_VERSION
    }

    /// Encodes the request exactly: no leading blank, single blanks, no terminator, fixed-point
    /// numbers with bounded decimals, and at most [`MAX_REQUEST_BYTES`] bytes.
    pub fn encode(&self) -> Result<String, EncodeError> {
        if let Command::Other { number, .. } = &self.command {
            // An "other" number that reads as a real command would do what that command does
            // (the server compares the number after VAL): build that command instead.
            let written = format_request_number(*number, "command number")?;
            if KNOWN_COMMANDS.contains(&written.as_str()) {
                return Err(EncodeError::KnownCommandAsOther { number: written });
            }
        }
        let args = self.command.args();
        let mut out = String::with_capacity(MAX_REQUEST_BYTES);
        // Writing to a String cannot fail.
        let _ = write!(out, "{} ", self.version);
        push_request_number(&mut out, self.command.number(), "command number")?;
        let _ = write!(out, " {}", args.len());
        for (name, value) in args {
            out.push(' ');
            push_request_number(&mut out, value, name)?;
        }
        if out.len() > MAX_REQUEST_BYTES {
            return Err(EncodeError::TooLong {
                len: out.len(),
                max: MAX_REQUEST_BYTES,
            });
        }
        Ok(out)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn enc(c: Command) -> String {
        Request::new(c).encode().unwrap()
    }

    #[test]
    fn every_command_encodes_exactly() {
        assert_eq!(enc(Command::StartProgram), "1040 1 0");
        assert_eq!(enc(Command::StopProgram), "1040 2 0");
        assert_eq!(enc(Command::SetSpeed { percent: 50.0 }), "1040 3 1 50");
        assert_eq!(enc(Command::SetSpeed { percent: 12.5 }), "1040 3 1 12.5");
        assert_eq!(enc(Command::Reserved), "1040 4 0");
        assert_eq!(enc(Command::CancelMotion), "1040 5 0");
        assert_eq!(
            enc(Command::JointMove {
                target: JointsDeg::new([1.0, -2.5, 3.25, 0.0, -90.0, 360.0])
            }),
            "1040 6 9 0 0 0 1 -2.5 3.25 0 -90 360"
        );
        let s = StreamSample {
            t0_s: 12.345,
            lookahead_passes: 2.0,
            position: JointsDeg::new([1.0, 2.0, 3.0, 4.0, 5.0, 6.0]),
            velocity: JointsDeg::new([0.5, 0.0, 0.0, 0.0, 0.0, -0.5]),
            acceleration: JointsDeg::new([0.0, 0.0, 0.0, 0.0, 0.0, 100.0]),
        };
        assert_eq!(
            enc(Command::StreamedMove(s)),
            "1040 7 21 12.345 2 0 1 2 3 4 5 6 0.5 0 0 0 0 -0.5 0 0 0 0 0 100"
        );
        assert_eq!(enc(Command::EndSession), "1040 255 0");
        assert_eq!(
            enc(Command::Other {
                number: 42.0,
                args: vec![1.0, 2.0]
            }),
            "1040 42 2 1 2"
        );
    }

    #[test]
    fn numbers_and_traps() {
        assert_eq!(Command::EndSession.number(), 255.0);
        assert!(Command::JointMove {
            target: JointsDeg::ZERO
        }
        .is_motion());
        assert!(!Command::CancelMotion.is_motion());
        let poll = Request::status_poll();
        assert!(!poll.is_effective());
        assert_eq!(poll.encode().unwrap(), "0 0 0");
        let mut t = JointsDeg::ZERO;
        t[2] = f64::NAN;
        assert!(matches!(
            Request::new(Command::JointMove { target: t }).encode(),
            Err(EncodeError::NonFinite {
                field: "JT3 target",
                ..
            })
        ));
    }

    #[test]
    fn other_cannot_smuggle_a_real_command() {
        for number in [6.0, 6.0004, 1.0, 255.0] {
            let r = Request::new(Command::Other {
                number,
                args: vec![0.0; 9],
            });
            assert!(
                matches!(r.encode(), Err(EncodeError::KnownCommandAsOther { .. })),
                "{number}"
            );
        }
        assert!(Request::new(Command::Other {
            number: 6.5,
            args: vec![]
        })
        .encode()
        .is_ok());
        assert!(Request::new(Command::Other {
            number: 9.0,
            args: vec![]
        })
        .encode()
        .is_ok());
        assert_eq!(Request::status_poll().encode().unwrap(), "0 0 0");
    }

    #[test]
    fn oversize_requests_are_refused() {
        let big = JointsDeg::new([-9999999.999; 6]);
        let s = StreamSample {
            t0_s: 9999999.999,
            lookahead_passes: 1.0,
            position: big,
            velocity: big,
            acceleration: big,
        };
        match Request::new(Command::StreamedMove(s)).encode() {
            Err(EncodeError::TooLong { len, max: 255 }) => assert!(len > 255),
            other => panic!("expected TooLong, got {other:?}"),
        }
    }

    #[test]
    fn extrapolation_clamps_time_error() {
        let s = StreamSample {
            t0_s: 0.0,
            lookahead_passes: 0.0,
            position: JointsDeg::ZERO,
            velocity: JointsDeg::new([10.0; 6]),
            acceleration: JointsDeg::ZERO,
        };
        assert_eq!(s.extrapolate(100.0, 0.0)[0], 5.0);
        assert_eq!(s.extrapolate(-100.0, 0.0)[0], -5.0);
        assert_eq!(s.extrapolate(0.25, 0.0)[0], 2.5);
    }
}
