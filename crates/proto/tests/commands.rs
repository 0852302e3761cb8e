//! Every command of spec §2.1: the exact request bytes, how the controller reads them back,
//! and the traps of §2 (version mismatch, leading blank, COUNT trusted, 255 bytes).

mod common;

use common::*;
use fs020n_proto::ServerRequest;
use fs020n_proto::MAX_REQUEST_BYTES;
use fs020n_proto::{Command, EncodeError, JointsDeg, Request, StreamSample, PROTOCOL_VERSION};

fn sample() -> StreamSample {
    StreamSample {
        t0_s: 12.345,
        lookahead_passes: 2.0,
        position: JointsDeg::new([10.0, -20.5, -90.0, 0.0, -45.25, 180.0]),
        velocity: JointsDeg::new([1.0, 0.0, 0.0, 0.0, 0.0, -1.0]),
        acceleration: JointsDeg::new([0.0, 0.5, 0.0, 0.0, 0.0, 0.0]),
    }
}

/// (command, exact bytes, COUNT_OF_ARGS) for every command of §2.1.
fn table() -> Vec<(Command, &'static str, usize)> {
    vec![
        (Command::StartProgram, "1040 1 0", 0),
        (Command::StopProgram, "1040 2 0", 0),
        (Command::SetSpeed { percent: 40.0 }, "1040 3 1 40", 1),
        (Command::Reserved, "1040 4 0", 0),
        (Command::CancelMotion, "1040 5 0", 0),
        (
            Command::JointMove {
                target: JointsDeg::ZERO,
            },
            "1040 6 9 0 0 0 0 0 0 0 0 0",
            9,
        ),
        (
            Command::StreamedMove(sample()),
            "1040 7 21 12.345 2 0 10 -20.5 -90 0 -45.25 180 1 0 0 0 0 -1 0 0.5 0 0 0 0",
            21,
        ),
        (Command::EndSession, "1040 255 0", 0),
        (
            Command::Other {
                number: 8.0,
                args: vec![1.5],
            },
            "1040 8 1 1.5",
            1,
        ),
    ]
}

#[test]
fn every_command_encodes_and_the_server_reads_it_back() {
    for (command, bytes, count) in table() {
        let encoded = Request::new(command.clone()).encode().unwrap();
        assert_eq!(encoded, bytes, "{command:?}");
        assert_eq!(command.args().len(), count, "{command:?}");
        let seen = ServerRequest::parse(bytes.as_bytes());
        assert!(seen.version_matches(), "{bytes}");
        assert_eq!(seen.command_number, command.number());
        assert_eq!(seen.count, count);
        assert!(commands_close(&seen.command(), &command), "{bytes}");
    }
}

#[test]
fn the_seed_examples_are_byte_exact() {
    // The examples of the original note, with the commands they mean.
    let seed = [
        ("1040 1 0", Command::StartProgram),
        ("1040 2 0", Command::StopProgram),
        ("1040 3 1 40", Command::SetSpeed { percent: 40.0 }),
        ("1040 5 0", Command::CancelMotion),
        (
            "1040 6 9 0 0 0 0 0 0 0 0 0",
            Command::JointMove {
                target: JointsDeg::ZERO,
            },
        ),
        ("1040 255 0", Command::EndSession),
    ];
    for (bytes, command) in seed {
        assert_eq!(Request::new(command.clone()).encode().unwrap(), bytes);
        assert_eq!(ServerRequest::parse(bytes.as_bytes()).command(), command);
    }
}

#[test]
fn command_numbers_and_motion_flags() {
    let expect = [
        (Command::StartProgram, 1.0, false),
        (Command::StopProgram, 2.0, false),
        (Command::SetSpeed { percent: 1.0 }, 3.0, false),
        (Command::Reserved, 4.0, false),
        (Command::CancelMotion, 5.0, false),
        (
            Command::JointMove {
                target: JointsDeg::ZERO,
            },
            6.0,
            true,
        ),
        (Command::StreamedMove(sample()), 7.0, true),
        (Command::EndSession, 255.0, false),
        (
            Command::Other {
                number: 6.5,
                args: vec![],
            },
            6.5,
            false,
        ),
    ];
    for (c, n, motion) in expect {
        assert_eq!(c.number(), n, "{c:?}");
        assert_eq!(c.is_motion(), motion, "{c:?}");
    }
}

#[test]
fn command_6_sends_three_unused_zeros_then_the_targets() {
    let target = JointsDeg::new([1.0, 2.0, 3.0, 4.0, 5.0, 6.0]);
    let args = Command::JointMove { target }.args();
    assert_eq!(args.len(), 9);
    assert!(args[..3].iter().all(|(n, v)| *n == "unused" && *v == 0.0));
    let names: Vec<&str> = args[3..].iter().map(|(n, _)| *n).collect();
    assert_eq!(
        names,
        [
            "JT1 target",
            "JT2 target",
            "JT3 target",
            "JT4 target",
            "JT5 target",
            "JT6 target"
        ]
    );
    // The server ignores ARG1–ARG3 whatever they hold.
    let r = ServerRequest::parse(b"1040 6 9 7 8 9 1 2 3 4 5 6");
    assert_eq!(r.command(), Command::JointMove { target });
}

#[test]
fn command_7_argument_order() {
    let args = Command::StreamedMove(sample()).args();
    assert_eq!(args.len(), 21);
    assert_eq!(args[0], ("t0", 12.345));
    assert_eq!(args[1], ("look-ahead", 2.0));
    assert_eq!(args[2], ("unused", 0.0));
    assert_eq!(args[3], ("JT1 position", 10.0));
    assert_eq!(args[8], ("JT6 position", 180.0));
    assert_eq!(args[9], ("JT1 velocity", 1.0));
    assert_eq!(args[14], ("JT6 velocity", -1.0));
    assert_eq!(args[15], ("JT1 acceleration", 0.0));
    assert_eq!(args[16], ("JT2 acceleration", 0.5));
    assert_eq!(args[20].0, "JT6 acceleration");
    // ARG3 is ignored by the server.
    let mut text = Request::new(Command::StreamedMove(sample()))
        .encode()
        .unwrap();
    text = text.replacen(" 2 0 10 ", " 2 99 10 ", 1);
    assert_eq!(
        ServerRequest::parse(text.as_bytes()).command(),
        Command::StreamedMove(StreamSample {
            t0_s: as_real(12.345),
            ..sample()
        })
    );
}

#[test]
fn command_7_extrapolation() {
    let s = StreamSample {
        t0_s: 10.0,
        lookahead_passes: 3.0,
        position: JointsDeg::new([1.0; 6]),
        velocity: JointsDeg::new([2.0, 0.0, 0.0, 0.0, 0.0, -2.0]),
        acceleration: JointsDeg::new([0.0, 4.0, 0.0, 0.0, 0.0, 0.0]),
    };
    // On time, no look-ahead: the sample itself.
    assert_eq!(s.extrapolate(10.0, 0.0), s.position);
    // 0.1 s late plus 3 passes of 0.1 s: dt = 0.4 s.
    let p = s.extrapolate(10.1, 0.1);
    assert!((p[0] - (1.0 + 0.4 * 2.0)).abs() < 1e-12);
    assert!((p[1] - (1.0 + 0.5 * 0.16 * 4.0)).abs() < 1e-12);
    assert!((p[5] - (1.0 - 0.4 * 2.0)).abs() < 1e-12);
    // The time error is clamped to ±0.5 s before the look-ahead is added.
    let late = s.extrapolate(99.0, 0.1);
    assert!((late[0] - (1.0 + 0.8 * 2.0)).abs() < 1e-12);
    let early = s.extrapolate(-99.0, 0.0);
    assert!((early[0] - (1.0 - 0.5 * 2.0)).abs() < 1e-12);
    assert_eq!(StreamSample::TIME_CLAMP_S, 0.5);
}

#[test]
fn status_poll_is_a_version_mismatch() {
    let poll = Request::status_poll();
    assert_eq!(poll.encode().unwrap(), "0 0 0");
    assert!(!poll.is_effective());
    assert!(!ServerRequest::parse(b"0 0 0").version_matches());
    // The trap: "1040 0 0" is an effective request (command 0, unknown) that becomes the
    // latest command and stops a stream.
    let trap = ServerRequest::parse(b"1040 0 0");
    assert!(trap.version_matches());
    assert!(matches!(trap.command(), Command::Other { number, .. } if number == 0.0));
    // Any command with another version is a no-op poll too.
    let r = Request {
        version: 1041,
        command: Command::StartProgram,
    };
    assert_eq!(r.encode().unwrap(), "1041 1 0");
    assert!(!r.is_effective());
    assert!(!ServerRequest::parse(b"1041 1 0").version_matches());
}

#[test]
fn leading_blank_makes_a_version_mismatch() {
    let r = ServerRequest::parse(b" 1040 1 0");
    assert!(!r.version_matches());
    assert_eq!(r.version, 0.0);
    // Everything shifts by one token: "1040" is read as the command number.
    assert_eq!(r.command_number, 1040.0);
    // The encoder never writes a leading, trailing or double blank, nor a terminator.
    for (c, _, _) in table() {
        let e = Request::new(c).encode().unwrap();
        assert!(!e.starts_with(' ') && !e.ends_with(' ') && !e.contains("  "));
        assert!(!e.contains('\n') && !e.contains('\r'));
    }
}

#[test]
fn count_of_args_is_trusted() {
    // Too large: missing arguments read 0.
    let r = ServerRequest::parse(b"1040 3 5");
    assert_eq!(r.args, vec![0.0; 5]);
    assert_eq!(r.command(), Command::SetSpeed { percent: 0.0 });
    // Too small: the extra tokens are ignored.
    let r = ServerRequest::parse(b"1040 7 2 5 1 0 10 20 30 40 50 60");
    assert_eq!(r.args, vec![5.0, 1.0]);
    match r.command() {
        Command::StreamedMove(s) => {
            assert_eq!(s.t0_s, 5.0);
            assert_eq!(s.position, JointsDeg::ZERO);
        }
        other => panic!("{other:?}"),
    }
    // Fractional and negative counts.
    assert_eq!(ServerRequest::parse(b"1040 3 1.9 40").count, 1);
    assert_eq!(ServerRequest::parse(b"1040 3 -4 40").count, 0);
    assert_eq!(ServerRequest::parse(b"1040 3 0.5 40").count, 0);
}

#[test]
fn val_semantics_of_request_tokens() {
    let r = ServerRequest::parse(b"1040 3 1 1.5E1");
    assert_eq!(r.command(), Command::SetSpeed { percent: 15.0 });
    let r = ServerRequest::parse(b"1040 3 1 40%");
    assert_eq!(r.command(), Command::SetSpeed { percent: 40.0 });
    let r = ServerRequest::parse(b"1040 3 1 fast");
    assert_eq!(r.command(), Command::SetSpeed { percent: 0.0 });
    // The command number is compared as a real.
    assert!(matches!(
        ServerRequest::parse(b"1040 6.5 0").command(),
        Command::Other { number, .. } if number == 6.5
    ));
    assert_eq!(
        ServerRequest::parse(b"1040 6.0 9 0 0 0 1 2 3 4 5 6").command(),
        Command::JointMove {
            target: JointsDeg::new([1.0, 2.0, 3.0, 4.0, 5.0, 6.0])
        }
    );
    // A terminator sent by a careless client ends up in the last token; VAL stops at it.
    let r = ServerRequest::parse(b"1040 3 1 40\r\n");
    assert_eq!(r.command(), Command::SetSpeed { percent: 40.0 });
    // ... but a terminator after a command without arguments is harmless too.
    assert_eq!(
        ServerRequest::parse(b"1040 1 0\n").command(),
        Command::StartProgram
    );
}

#[test]
fn request_numbers_are_bounded_fixed_point() {
    let r = Request::new(Command::JointMove {
        target: JointsDeg::new([1e-7, -0.0004, 0.0005, 123.4567, -1.0 / 3.0, 2.0 / 3.0]),
    });
    assert_eq!(
        r.encode().unwrap(),
        "1040 6 9 0 0 0 0 0 0.001 123.457 -0.333 0.667"
    );
    let r = Request::new(Command::SetSpeed { percent: 1e-20 });
    assert_eq!(r.encode().unwrap(), "1040 3 1 0");
    // Never exponent notation, even for big numbers.
    let r = Request::new(Command::SetSpeed {
        percent: 9_999_999.0,
    });
    assert_eq!(r.encode().unwrap(), "1040 3 1 9999999");
}

#[test]
fn invalid_values_are_refused_with_their_name() {
    let mut s = sample();
    s.velocity[3] = f64::INFINITY;
    assert!(matches!(
        Request::new(Command::StreamedMove(s)).encode(),
        Err(EncodeError::NonFinite {
            field: "JT4 velocity",
            ..
        })
    ));
    let mut s = sample();
    s.t0_s = f64::NAN;
    assert!(matches!(
        Request::new(Command::StreamedMove(s)).encode(),
        Err(EncodeError::NonFinite { field: "t0", .. })
    ));
    let mut s = sample();
    s.acceleration[5] = -2e7;
    assert!(matches!(
        Request::new(Command::StreamedMove(s)).encode(),
        Err(EncodeError::OutOfRange {
            field: "JT6 acceleration",
            ..
        })
    ));
    assert!(matches!(
        Request::new(Command::SetSpeed { percent: f64::NAN }).encode(),
        Err(EncodeError::NonFinite {
            field: "speed percent",
            ..
        })
    ));
    assert!(matches!(
        Request::new(Command::Other {
            number: f64::NAN,
            args: vec![]
        })
        .encode(),
        Err(EncodeError::NonFinite {
            field: "command number",
            ..
        })
    ));
    let msg = Request::new(Command::SetSpeed { percent: f64::NAN })
        .encode()
        .unwrap_err()
        .to_string();
    assert!(msg.contains("speed percent"), "{msg}");
}

#[test]
fn the_255_byte_limit() {
    // The widest command 7 with values of up to 10 characters still fits.
    let wide = JointsDeg::new([-99999.999; 6]);
    let s = StreamSample {
        t0_s: 99999.999,
        lookahead_passes: -9999.999,
        position: wide,
        velocity: wide,
        acceleration: wide,
    };
    let text = Request::new(Command::StreamedMove(s)).encode().unwrap();
    assert!(text.len() <= MAX_REQUEST_BYTES, "{}", text.len());
    // One more digit everywhere does not, and is refused rather than cut.
    let wider = JointsDeg::new([-9_999_999.999; 6]);
    let s = StreamSample {
        position: wider,
        velocity: wider,
        acceleration: wider,
        ..s
    };
    match Request::new(Command::StreamedMove(s)).encode() {
        Err(EncodeError::TooLong { len, max }) => {
            assert_eq!(max, 255);
            assert!(len > 255);
        }
        other => panic!("{other:?}"),
    }
    // What the server would do with it: only the first 255 bytes count.
    let mut long = String::from("1040 6 9 0 0 0 1 2 3 4 5 6");
    long.push_str(&" ".repeat(300));
    assert_eq!(
        ServerRequest::parse(long.as_bytes()),
        ServerRequest::parse(&long.as_bytes()[..255])
    );
}

#[test]
fn session_constants_match_the_spec() {
    assert_eq!(PROTOCOL_VERSION, 1040);
    assert_eq!(fs020n_proto::DEFAULT_PORT, 10050);
    assert_eq!(fs020n_proto::MAX_REQUEST_BYTES, 255);
    assert_eq!(fs020n_proto::ACCEPT_WINDOW.as_secs(), 3);
    assert_eq!(fs020n_proto::RECEIVE_TIMEOUT.as_secs(), 5);
    assert_eq!(fs020n_proto::SEND_TIMEOUT.as_secs(), 2);
    assert_eq!(fs020n_proto::COMMAND_RING_LEN, 16);
    assert_eq!(fs020n_proto::SINGULAR_ZONE_DEG, 5.0);
    assert_eq!(fs020n_proto::SINGULAR_JMOVE_SPEED_PERCENT, 30.0);
    assert_eq!(fs020n_proto::STREAM_LMOVE_TIME_S, 0.1);
    assert_eq!(fs020n_proto::ACCURACY_MM, 10.0);
    assert_eq!(fs020n_proto::STEP_AVERAGE_WEIGHT, 0.1);
    assert_eq!((fs020n_proto::AS_TRUE, fs020n_proto::AS_FALSE), (-1, 0));
}
