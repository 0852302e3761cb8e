//! Real-world reply strings, one per format of spec §3.1 and per trap, decoded both whole
//! ([`Status::decode`]) and as a byte stream ([`ReplyDecoder`], whole and byte by byte).

mod common;

use common::*;
use fs020n_proto::{DecodeError, ErrorCode, JointsDeg, ReplyDecoder, Status, Timer};

/// What a case must give.
enum Want {
    /// Decodes to this status; the stream decoder yields it as soon as the bytes are in.
    Status(Status),
    /// Decodes to this status, but as the last bytes of a stream it is not yet known to be
    /// complete (no final blank and not the fixed 10-character layout): the stream decoder
    /// waits for one more blank.
    OpenEnd(Status),
    /// Decodes to this status; as the last bytes of a stream it is the controller's fixed
    /// layout without its final blank: the stream decoder waits for a blank (the last number
    /// might go on), and `take_open_reply` yields it once the peer has gone quiet.
    QuietEnd(Status),
    /// Fails; the stream decoder reports the same error.
    Error(DecodeError),
    /// Fails as incomplete; the stream decoder waits for more bytes.
    Incomplete(usize),
}

fn ok(timer: f64, joints: [f64; 6]) -> Status {
    status_with(Timer::Seconds(timer), joints)
}

fn all_on(timer: Timer, joints: [f64; 6]) -> Status {
    Status {
        teach_lock: true,
        ..status_with(timer, joints)
    }
}

fn garbage(reason: &'static str, offset: usize, excerpt: &str) -> DecodeError {
    DecodeError::Garbage {
        reason,
        offset,
        excerpt: excerpt.to_owned(),
    }
}

fn cases() -> Vec<(&'static str, String, Want)> {
    let spec = spec_example_status();
    let z = [0.0; 6];
    let mut v: Vec<(&'static str, String, Want)> = vec![
        // --- The controller's exact format -----------------------------------------------
        ("spec example, exact bytes", SPEC_EXAMPLE.into(), Want::Status(spec.clone())),
        (
            "exact, no leading blank",
            SPEC_EXAMPLE[1..].into(),
            Want::Status(spec.clone()),
        ),
        (
            "exact, missing final blank (fixed layout: complete once the peer is quiet)",
            SPEC_EXAMPLE.trim_end().into(),
            Want::QuietEnd(spec.clone()),
        ),
        (
            "exact, neither leading nor final blank",
            SPEC_EXAMPLE.trim().into(),
            Want::QuietEnd(spec.clone()),
        ),
        (
            "exact, error E1088, program stopped, HOLD",
            " 1040 -31088 0 -1 0 -1 0   345.001   -12.345    45.000  -120.500     0.001   -89.999   180.000 ".into(),
            Want::Status(Status {
                error: ErrorCode::DESTINATION_OUT_OF_RANGE,
                run: false,
                task_running: false,
                ..ok(345.001, [-12.345, 45.0, -120.5, 0.001, -89.999, 180.0])
            }),
        ),
        // --- The seed's tidied-up example: integers in the real fields --------------------
        (
            "seed example",
            "1040 0 -1 -1 -1 -1 -1 10 0 0 0 0 0 0 ".into(),
            Want::Status(all_on(Timer::Seconds(10.0), z)),
        ),
        (
            "seed example without final blank",
            "1040 0 -1 -1 -1 -1 -1 10 0 0 0 0 0 0".into(),
            Want::OpenEnd(all_on(Timer::Seconds(10.0), z)),
        ),
        // --- Runs of blanks --------------------------------------------------------------
        (
            "runs of blanks everywhere",
            "   1040  0   -1 -1  0 -1   -1      12.500   0.000  30.000 0.000 0.000 0.000 0.000    ".into(),
            Want::Status(spec.clone()),
        ),
        (
            "runs of blanks, short numbers, missing final blank",
            "  1040  0  -1  -1  0  -1  -1  12.5  0  30  0  0  0  0".into(),
            Want::OpenEnd(spec.clone()),
        ),
        (
            "tabs as blanks",
            "1040\t0\t-1\t-1\t0\t-1\t-1\t12.5\t0\t30\t0\t0\t0\t0\t".into(),
            Want::Status(spec.clone()),
        ),
        (
            "extra blank between the integers and the fixed block",
            " 1040 0 -1 -1 0 -1 -1     12.500     0.000    30.000     0.000     0.000     0.000     0.000 ".into(),
            Want::Status(spec.clone()),
        ),
        // --- Touching 10-character fields ------------------------------------------------
        (
            "timer 123456.789 touching field 7",
            " 1040 0 -1 -1 0 -1 -1123456.789     0.000    30.000     0.000     0.000     0.000     0.000 ".into(),
            Want::Status(ok(123456.789, [0.0, 30.0, 0.0, 0.0, 0.0, 0.0])),
        ),
        (
            "timer touching field 7 = 0",
            " 1040 0 -1 -1 0 -1 0123456.789     0.000    30.000     0.000     0.000     0.000     0.000 ".into(),
            Want::Status(Status {
                task_running: false,
                ..ok(123456.789, [0.0, 30.0, 0.0, 0.0, 0.0, 0.0])
            }),
        ),
        (
            "largest timer /F10.3 prints, touching, no final blank",
            " 1040 0 -1 -1 0 -1 -1999999.999     0.000    30.000     0.000     0.000     0.000     0.000".into(),
            Want::QuietEnd(ok(999999.999, [0.0, 30.0, 0.0, 0.0, 0.0, 0.0])),
        ),
        (
            "negative joints touching each other",
            " 1040 0 -1 -1 0 -1 -1    12.500-12345.678-99999.999   -90.000-10000.000     0.000-54321.000 ".into(),
            Want::Status(ok(
                12.5,
                [-12345.678, -99999.999, -90.0, -10000.0, 0.0, -54321.0],
            )),
        ),
        (
            "every field touching",
            " 1040 0 -1 -1 0 -1 -1123456.789-12345.678-12345.678-12345.678-12345.678-12345.678-12345.678".into(),
            Want::QuietEnd(ok(123456.789, [-12345.678; 6])),
        ),
        (
            "positive 10-character joints touching",
            " 1040 0 -1 -1 0 -1 -1    12.500100000.000200000.000     0.000     0.000     0.000999999.999 ".into(),
            Want::Status(ok(12.5, [100000.0, 200000.0, 0.0, 0.0, 0.0, 999999.999])),
        ),
        // --- Exponent notation -----------------------------------------------------------
        (
            "exponent in a joint, blank-separated",
            " 1040 0 -1 -1 0 -1 -1 12.5 1.0E-03 30 0 0 0 0 ".into(),
            Want::Status(ok(12.5, [0.001, 30.0, 0.0, 0.0, 0.0, 0.0])),
        ),
        (
            "exponent in the fixed layout, lower-case e and explicit plus",
            " 1040 0 -1 -1 0 -1 -1    12.500   1.0E-03   3.0e+01  -1.5E+02     0.000     0.000     0.000 ".into(),
            Want::Status(ok(12.5, [0.001, 30.0, -150.0, 0.0, 0.0, 0.0])),
        ),
        (
            "exponent in the timer",
            " 1040 0 -1 -1 0 -1 -1  1.25E+01     0.000    30.000     0.000     0.000     0.000     0.000 ".into(),
            Want::Status(spec.clone()),
        ),
        (
            "integer field in exponent form that is an integer",
            " 1.04E+03 0 -1 -1 0 -1 -1    12.500     0.000    30.000     0.000     0.000     0.000     0.000 ".into(),
            Want::Status(spec.clone()),
        ),
        (
            "non-integer in exponent form in field 2",
            " 1040 1.0E-03 -1 -1 0 -1 -1    12.500     0.000    30.000     0.000     0.000     0.000     0.000 ".into(),
            Want::Error(DecodeError::NotInteger {
                field: 2,
                text: "0.001".into(),
            }),
        ),
        (
            "non-integer switch",
            "1040 0 -0.5 -1 0 -1 -1 12.5 0 30 0 0 0 0 ".into(),
            Want::Error(DecodeError::NotInteger {
                field: 3,
                text: "-0.5".into(),
            }),
        ),
        // --- Asterisks -------------------------------------------------------------------
        (
            "timer asterisks touching field 7",
            " 1040 0 -1 -1 0 -1 -1**********     0.000    30.000     0.000     0.000     0.000     0.000 ".into(),
            Want::Status(status_with(Timer::Overflow, [0.0, 30.0, 0.0, 0.0, 0.0, 0.0])),
        ),
        (
            "timer asterisks blank-separated",
            "1040 0 -1 -1 0 -1 -1 ********** 0 30 0 0 0 0 ".into(),
            Want::Status(status_with(Timer::Overflow, [0.0, 30.0, 0.0, 0.0, 0.0, 0.0])),
        ),
        (
            "timer asterisks, missing final blank",
            " 1040 0 -1 -1 0 -1 -1**********     0.000    30.000     0.000     0.000     0.000     0.000".into(),
            Want::QuietEnd(status_with(Timer::Overflow, [0.0, 30.0, 0.0, 0.0, 0.0, 0.0])),
        ),
        (
            "asterisks in JT1 after asterisks in the timer",
            " 1040 0 -1 -1 0 -1 -1********************    30.000     0.000     0.000     0.000     0.000 ".into(),
            Want::Error(DecodeError::JointOverflow { joint: 1 }),
        ),
        (
            "asterisks in a joint, blank-separated",
            "1040 0 -1 -1 0 -1 -1 12.5 0 30 ********** 0 0 0 ".into(),
            Want::Error(DecodeError::JointOverflow { joint: 3 }),
        ),
        // --- Tails -----------------------------------------------------------------------
        (
            "CR LF after the final blank",
            format!("{SPEC_EXAMPLE}\r\n"),
            Want::Status(spec.clone()),
        ),
        (
            "CR LF instead of the final blank",
            format!("{}\r\n", SPEC_EXAMPLE.trim_end()),
            Want::Status(spec.clone()),
        ),
        (
            "LF only, short numbers",
            "1040 0 -1 -1 0 -1 -1 12.5 0 30 0 0 0 0\n".into(),
            Want::Status(spec.clone()),
        ),
        // --- Negative zero ---------------------------------------------------------------
        (
            "negative zero everywhere",
            " 1040 -0 -1 -1 -0 -1 -1    -0.000    -0.000    30.000    -0.000    -0.000    -0.000    -0.000 ".into(),
            Want::Status(Status {
                timer: Timer::Seconds(-0.0),
                ..spec.clone()
            }),
        ),
        // --- AS truth and other integers --------------------------------------------------
        (
            "any non-zero switch is true (AS truth)",
            "1040 0 1 -2 0 7 -1 12.5 0 30 0 0 0 0 ".into(),
            Want::Status(spec.clone()),
        ),
        (
            "explicit plus signs",
            "+1040 +0 -1 -1 +0 -1 -1 +12.5 +0 +30 0 0 0 0 ".into(),
            Want::Status(spec.clone()),
        ),
        // --- Incomplete and too long -----------------------------------------------------
        ("empty", String::new(), Want::Incomplete(0)),
        ("blanks only", "   \r\n".into(), Want::Incomplete(0)),
        (
            "cut after the timer",
            " 1040 0 -1 -1 0 -1 -1    12.500".into(),
            Want::Incomplete(8),
        ),
        (
            "cut inside the fixed block",
            SPEC_EXAMPLE[..60].into(),
            Want::Incomplete(11),
        ),
        // --- Garbage ---------------------------------------------------------------------
        (
            "an HTTP request (wrong port or a browser)",
            "HTTP/1.1 400 Bad Request\r\nContent-Length: 0\r\n\r\n".into(),
            Want::Error(garbage(
                "unexpected byte",
                0,
                "HTTP/1.1 400 Bad Request\r\nContent-Length",
            )),
        ),
        (
            "an SSH banner",
            "SSH-2.0-OpenSSH_9.6\r\n".into(),
            Want::Error(garbage("unexpected byte", 0, "SSH-2.0-OpenSSH_9.6\r\n")),
        ),
        (
            "binary control bytes",
            "\u{0}\u{1}\u{2}\u{7f}".into(),
            Want::Error(garbage("unexpected byte", 0, "\u{0}\u{1}\u{2}\u{7f}")),
        ),
        (
            "a letter O for a zero inside a joint",
            " 1040 0 -1 -1 0 -1 -1    12.500     0.000    3O.000     0.000     0.000     0.000     0.000 ".into(),
            Want::Error(garbage(
                "unexpected byte",
                46,
                "O.000     0.000     0.000     0.000     ",
            )),
        ),
        (
            "a lone dot as a leading field",
            " 1040 . -1 -1 0 -1 -1    12.500     0.000    30.000     0.000     0.000     0.000     0.000 ".into(),
            Want::Error(garbage(
                "field is not a number",
                6,
                ". -1 -1 0 -1 -1    12.500     0.000    3",
            )),
        ),
    ];
    for k in 1..=6 {
        // Asterisks in each joint of the fixed layout.
        let mut text = String::from(" 1040 0 -1 -1 0 -1 -1    12.500");
        for j in 1..=6 {
            text.push_str(if j == k { "**********" } else { "     0.000" });
        }
        text.push(' ');
        v.push((
            "asterisks in a joint of the fixed layout",
            text,
            Want::Error(DecodeError::JointOverflow { joint: k }),
        ));
    }
    v
}

/// Decodes `bytes` as a stream: whole, then byte by byte. Returns both results.
fn stream(bytes: &[u8]) -> [(Vec<Result<Status, DecodeError>>, ReplyDecoder); 2] {
    let cuts: Vec<usize> = (1..bytes.len()).collect();
    [decode_in_chunks(bytes, &[]), decode_in_chunks(bytes, &cuts)]
}

#[test]
fn real_world_replies() {
    let mut failures = Vec::new();
    for (name, text, want) in cases() {
        let whole = Status::decode(&text);
        let streamed = stream(text.as_bytes());
        let mut check = |good: bool, what: String| {
            if !good {
                failures.push(format!("{name} {text:?}: {what}"));
            }
        };
        match &want {
            Want::Status(s) | Want::OpenEnd(s) | Want::QuietEnd(s) => {
                check(whole.as_ref() == Ok(s), format!("decode gave {whole:?}"));
                for (got, d) in &streamed {
                    if matches!(want, Want::Status(_)) {
                        check(
                            got == &vec![Ok(s.clone())] && d.is_empty(),
                            format!("stream gave {got:?}"),
                        );
                    } else {
                        check(
                            got.is_empty() && !d.is_empty(),
                            format!("open end: stream gave {got:?}"),
                        );
                        let quiet = d.clone().take_open_reply().map(|f| f.map(|f| f.status));
                        if matches!(want, Want::QuietEnd(_)) {
                            check(d.may_be_open_reply(), "may be an open reply".into());
                            check(
                                quiet == Ok(Some(s.clone())),
                                format!("quiet end gave {quiet:?}"),
                            );
                        } else {
                            check(quiet == Ok(None), format!("open end taken: {quiet:?}"));
                        }
                        let mut d = d.clone();
                        d.push(b" ").unwrap();
                        let next = d.next_reply().map(|f| f.map(|f| f.status));
                        check(
                            next == Ok(Some(s.clone())),
                            format!("open end + blank gave {next:?}"),
                        );
                    }
                }
                // Followed by another reply (which begins with a blank).
                let two = format!("{text}{SPEC_EXAMPLE}");
                for (got, _) in stream(two.as_bytes()) {
                    check(
                        got == vec![Ok(s.clone()), Ok(spec_example_status())],
                        format!("followed by a reply: {got:?}"),
                    );
                }
            }
            Want::Error(e) => {
                check(whole.as_ref() == Err(e), format!("decode gave {whole:?}"));
                // Pushed whole: exactly this error, and the buffer is cleared.
                let (got, d) = &streamed[0];
                check(
                    got == &vec![Err(e.clone())] && d.buffered().is_empty(),
                    format!("stream gave {got:?}"),
                );
                // Byte by byte: the first result is the same error, reported as soon as it is
                // certain — so a garbage quote holds only the bytes received by then. (What
                // follows an error is meaningless: the client drops the connection.)
                let (got, _) = &streamed[1];
                let first = got.first();
                let same = match (first, e) {
                    (
                        Some(Err(DecodeError::Garbage {
                            reason,
                            offset,
                            excerpt,
                        })),
                        DecodeError::Garbage {
                            reason: r,
                            offset: o,
                            excerpt: x,
                        },
                    ) => reason == r && offset == o && x.starts_with(excerpt.as_str()),
                    (Some(Err(got)), e) => got == e,
                    _ => false,
                };
                check(same, format!("byte by byte gave {got:?}"));
            }
            Want::Incomplete(found) => {
                check(
                    whole == Err(DecodeError::Incomplete { found: *found }),
                    format!("decode gave {whole:?}"),
                );
                for (got, d) in &streamed {
                    check(
                        got.is_empty() && d.buffered().len() == text.len(),
                        format!("stream gave {got:?}"),
                    );
                }
            }
        }
    }
    assert!(failures.is_empty(), "\n{}", failures.join("\n"));
}

#[test]
fn error_messages_quote_the_bytes() {
    let e = Status::decode("HTTP/1.1 200 OK\r\n").unwrap_err();
    let msg = e.to_string();
    assert!(msg.contains("HTTP/1.1 200 OK"), "{msg}");
    assert!(msg.contains("byte 0"), "{msg}");

    // Binary that is not UTF-8 reaches only the stream decoder: quoted lossily.
    let mut d = ReplyDecoder::new();
    d.push(b" 1040 0 \xff\xfe\x00 -1").unwrap();
    match d.next_reply() {
        Err(DecodeError::Garbage {
            offset, excerpt, ..
        }) => {
            assert_eq!(offset, 8);
            assert!(excerpt.starts_with('\u{fffd}'), "{excerpt:?}");
            assert!(excerpt.ends_with(" -1"), "{excerpt:?}");
        }
        other => panic!("{other:?}"),
    }
    assert!(d.buffered().is_empty());

    // At most 40 bytes are quoted.
    let long = "x".repeat(100);
    match Status::decode(&long) {
        Err(DecodeError::Garbage { excerpt, .. }) => assert_eq!(excerpt.len(), 40),
        other => panic!("{other:?}"),
    }
    let incomplete = Status::decode(" 1040 0 -1").unwrap_err().to_string();
    assert!(incomplete.contains("3 of 14"), "{incomplete}");
    let joint = DecodeError::JointOverflow { joint: 4 }.to_string();
    assert!(joint.contains("JT4"), "{joint}");
}

#[test]
fn too_many_fields_and_desynchronisation() {
    let text = format!("{SPEC_EXAMPLE}    0.000 ");
    assert_eq!(
        Status::decode(&text),
        Err(DecodeError::TooManyFields { found: 15 })
    );
    // Without a terminator the stream decoder cannot know that the extra field belongs to
    // this reply: it yields the 14 fields and keeps the rest as the start of the next reply.
    let mut d = ReplyDecoder::new();
    d.push(text.as_bytes()).unwrap();
    assert_eq!(
        d.next_reply().unwrap().map(|f| f.status),
        Some(spec_example_status())
    );
    assert!(!d.is_empty());
    assert_eq!(d.next_reply(), Ok(None));
    // The next reply is then read shifted by one field. Here the shifted fields happen to be
    // 14 valid numbers, so the decoder yields a status — with VERSION 0 and ERROR 1040. This is
    // why a client checks that VERSION is 1040 in every reply: it is the only sign of a
    // desynchronised stream.
    d.push(SPEC_EXAMPLE.as_bytes()).unwrap();
    let shifted = d.next_reply().unwrap().unwrap().status;
    assert_eq!(shifted.version, 0);
    assert_eq!(shifted.error, ErrorCode(1040));
    assert_ne!(shifted.version, fs020n_proto::PROTOCOL_VERSION);
}

#[test]
fn replies_without_any_blank_between_them_are_undecidable() {
    // A reply without its final blank followed by one without its leading blank: the last
    // field of the first runs into the version of the second ("0.0001040"). No reader can
    // split that; the decoder must neither panic nor loop, and the exact controller format
    // (which always has both blanks) never produces it.
    let a = SPEC_EXAMPLE.trim_end();
    let b = &SPEC_EXAMPLE[1..];
    let text = format!("{a}{b}");
    for (got, d) in stream(text.as_bytes()) {
        assert!(!got.is_empty() || !d.is_empty());
    }
    // With one blank between them (either reply's) both decode, however the bytes are cut.
    let text = format!("{a} {b}");
    for (got, d) in stream(text.as_bytes()) {
        assert_eq!(got, vec![Ok(spec_example_status()); 2]);
        assert!(d.is_empty());
    }
}

#[test]
fn a_joint_error_does_not_poison_the_next_reply() {
    // The decoder clears its buffer after an error; the next reply decodes.
    let bad = " 1040 0 -1 -1 0 -1 -1    12.500**********     0.000    30.000     0.000     0.000     0.000 ";
    let mut d = ReplyDecoder::new();
    d.push(bad.as_bytes()).unwrap();
    assert_eq!(d.next_reply(), Err(DecodeError::JointOverflow { joint: 1 }));
    d.push(SPEC_EXAMPLE.as_bytes()).unwrap();
    assert_eq!(
        d.next_reply().unwrap().map(|f| f.status),
        Some(spec_example_status())
    );
}

#[test]
fn joints_read_as_degrees() {
    let s = Status::decode(SPEC_EXAMPLE).unwrap();
    assert_eq!(s.joints, JointsDeg::new([0.0, 30.0, 0.0, 0.0, 0.0, 0.0]));
    assert!((s.joints.to_rad()[1] - std::f64::consts::FRAC_PI_6).abs() < 1e-12);
}
