//! The byte-exact examples of `docs/PROTOCOL.md` are what the crate produces and accepts.
//! Each example is looked up in the document verbatim (with its quotes), so editing one there
//! without fixing it here fails this test.

mod common;

use common::*;
use fs020n_proto::number::{as_val, format_request_number};
use fs020n_proto::ServerRequest;
use fs020n_proto::{
    Command, ErrorCode, JointsDeg, Request, Status, StreamSample, Timer, PROTOCOL_VERSION,
};

const DOC: &str = include_str!("../../../docs/PROTOCOL.md");

fn in_doc(bytes: &str) {
    let quoted = format!("\"{bytes}\"");
    assert!(DOC.contains(&quoted), "docs/PROTOCOL.md lacks {quoted}");
}

#[test]
fn request_examples() {
    let stream = StreamSample {
        t0_s: 12.345,
        lookahead_passes: 2.0,
        position: JointsDeg::new([10.0, -20.5, -90.0, 0.0, -45.25, 180.0]),
        velocity: JointsDeg::new([1.0, 0.0, 0.0, 0.0, 0.0, -1.0]),
        acceleration: JointsDeg::new([0.0, 0.5, 0.0, 0.0, 0.0, 0.0]),
    };
    let examples = [
        ("1040 1 0", Command::StartProgram),
        ("1040 2 0", Command::StopProgram),
        ("1040 3 1 40", Command::SetSpeed { percent: 40.0 }),
        ("1040 4 0", Command::Reserved),
        ("1040 5 0", Command::CancelMotion),
        (
            "1040 6 9 0 0 0 0 30 -90 0 -90 0",
            Command::JointMove {
                target: JointsDeg::new([0.0, 30.0, -90.0, 0.0, -90.0, 0.0]),
            },
        ),
        (
            "1040 6 9 0 0 0 0 0 0 0 0 0",
            Command::JointMove {
                target: JointsDeg::ZERO,
            },
        ),
        (
            "1040 7 21 12.345 2 0 10 -20.5 -90 0 -45.25 180 1 0 0 0 0 -1 0 0.5 0 0 0 0",
            Command::StreamedMove(stream),
        ),
        ("1040 255 0", Command::EndSession),
        (
            "1040 8 1 1.5",
            Command::Other {
                number: 8.0,
                args: vec![1.5],
            },
        ),
    ];
    for (bytes, command) in examples {
        in_doc(bytes);
        assert_eq!(Request::new(command.clone()).encode().unwrap(), bytes);
        let seen = ServerRequest::parse(bytes.as_bytes());
        assert!(seen.version_matches());
        assert!(commands_close(&seen.command(), &command), "{bytes}");
    }
    // The command-7 example is at most 240 bytes for numbers of at most 10 characters.
    in_doc("0 0 0");
    assert_eq!(Request::status_poll().encode().unwrap(), "0 0 0");
    in_doc(" 1040 1 0");
    assert!(!ServerRequest::parse(b" 1040 1 0").version_matches());
    in_doc("1040 0 0");
    assert!(ServerRequest::parse(b"1040 0 0").version_matches());
    in_doc("1040  3 1 50");
    let r = ServerRequest::parse(b"1040  3 1 50");
    assert_eq!((r.version, r.command_number, r.count), (1040.0, 3.0, 1));
    assert_eq!(r.command(), Command::SetSpeed { percent: 50.0 });
    in_doc("-12.346");
    assert_eq!(format_request_number(-12.34567, "x").unwrap(), "-12.346");
    in_doc("-9999999.999");
    assert_eq!(format_request_number(-9999999.999, "x").unwrap().len(), 12);
}

#[test]
fn val_table() {
    for (text, value) in [
        ("1040", 1040.0),
        ("  -7.5", -7.5),
        ("12abc", 12.0),
        ("40\\n", 40.0),
        ("", 0.0),
        ("abc", 0.0),
        ("-", 0.0),
        (".", 0.0),
        ("1.5E2x", 150.0),
        ("6.5", 6.5),
    ] {
        in_doc(text);
        assert_eq!(as_val(&text.replace("\\n", "\n")), value, "{text:?}");
    }
    in_doc("0.1");
    assert!(DOC.contains("0.100000001490116"));
    assert_eq!(as_val("0.1"), f64::from(0.1f32));
    assert!(f64::from(0.1f32)
        .to_string()
        .starts_with("0.100000001490116"));
}

#[test]
fn reply_examples() {
    let spec = spec_example_status();
    in_doc(SPEC_EXAMPLE);
    assert_eq!(spec.encode(), SPEC_EXAMPLE);
    assert_eq!(SPEC_EXAMPLE.len(), 92);

    let e1088 = " 1040 -31088 0 -1 0 -1 0   345.001   -12.345    45.000  -120.500     0.001   -89.999   180.000 ";
    in_doc(e1088);
    let s = Status::decode(e1088).unwrap();
    assert_eq!(s.error, ErrorCode::DESTINATION_OUT_OF_RANGE);
    assert_eq!(s.error.to_string(), "E1088");
    assert!(!s.run && s.repeat && !s.teach_lock && s.power && !s.task_running);
    assert_eq!(s.timer, Timer::Seconds(345.001));
    assert_eq!(s.encode(), e1088);

    let seed = "1040 0 -1 -1 -1 -1 -1 10 0 0 0 0 0 0 ";
    in_doc(seed);
    let s = Status::decode(seed).unwrap();
    assert!(s.teach_lock && s.task_running);
    assert_eq!(s.timer, Timer::Seconds(10.0));

    let touching = " 1040 0 -1 -1 0 -1 -1123456.789     0.000    30.000     0.000     0.000     0.000     0.000 ";
    in_doc(touching);
    assert_eq!(
        Status::decode(touching).unwrap(),
        status_with(Timer::Seconds(123456.789), [0.0, 30.0, 0.0, 0.0, 0.0, 0.0])
    );
    in_doc("-1123456.789");

    let asterisks = " 1040 0 -1 -1 0 -1 -1**********     0.000    30.000     0.000     0.000     0.000     0.000 ";
    in_doc(asterisks);
    assert_eq!(Status::decode(asterisks).unwrap().timer, Timer::Overflow);

    in_doc("    12.500-12345.678-99999.999   -90.000");
    in_doc("   1.0E-03");
    in_doc("     0.000");
    in_doc("    -0.000");
    in_doc("**********");
    in_doc(" 1040 0 -1 -1 0 -1 -1");
    assert!(SPEC_EXAMPLE.starts_with(" 1040 0 -1 -1 0 -1 -1"));
    assert_eq!(spec.version, PROTOCOL_VERSION);
}

#[test]
fn ruler_lines_match_their_examples() {
    // Each ruler line in the document sits under a 92-byte reply: one mark per byte.
    let lines: Vec<&str> = DOC.lines().collect();
    let mut rulers = 0;
    for w in lines.windows(2) {
        if w[1].trim_start().starts_with("11111") {
            rulers += 1;
            // The ruler starts under the first byte, one column after the opening quote.
            let quote = w[0].find('"').unwrap();
            let reply = w[0].trim().trim_matches('"');
            let ruler = &w[1][quote + 1..];
            assert_eq!(reply.len(), ruler.len(), "{reply:?}");
            // Field 8 starts right after the last '7' mark: 70 characters before the final blank.
            let f8 = ruler.find('8').unwrap();
            assert_eq!(f8, reply.len() - 1 - 70);
            assert!(ruler.ends_with('^') && reply.ends_with(' '));
        }
    }
    assert_eq!(rulers, 2);
}
