//! Property tests of the codec: round trips, stream splitting, and robustness on arbitrary
//! input.

mod common;

use common::*;
use fs020n_proto::MAX_REQUEST_BYTES;
use fs020n_proto::{
    number::as_val, Command, DecodeError, EncodeError, JointsDeg, ReplyDecoder, Request, Status,
    StreamSample, Timer, MAX_BUFFERED,
};
use fs020n_proto::{ServerRequest, MAX_ARGS};
use proptest::prelude::*;
use proptest::sample::Index;

proptest! {
    #![proptest_config(ProptestConfig::with_cases(512))]

    // (1) Every valid status survives encode → decode unchanged, also through the stream
    // decoder (whole and byte by byte).
    #[test]
    fn reply_round_trip(s in arb_status()) {
        let text = s.encode();
        prop_assert_eq!(text.len(), text.trim_end().len() + 1, "one final blank");
        prop_assert_eq!(Status::decode(&text), Ok(s.clone()));
        // Without its final blank (the last reply of a stream) and without its leading blank.
        prop_assert_eq!(Status::decode(text.trim_end()), Ok(s.clone()));
        prop_assert_eq!(Status::decode(text.trim_start()), Ok(s.clone()));
        let (whole, d) = decode_in_chunks(text.as_bytes(), &[]);
        prop_assert_eq!(whole, vec![Ok(s.clone())]);
        prop_assert!(d.is_empty());
        let cuts: Vec<usize> = (1..text.len()).collect();
        let (bytewise, d) = decode_in_chunks(text.as_bytes(), &cuts);
        prop_assert_eq!(bytewise, vec![Ok(s)]);
        prop_assert!(d.is_empty());
    }

    // Every rendering the decoder must tolerate decodes to the same status.
    #[test]
    fn tolerant_renderings_decode_the_same(s in arb_status(), v in arb_variant()) {
        let text = render(&s, &v);
        prop_assert_eq!(Status::decode(&text), Ok(s), "{:?}", text);
    }
}

/// A request number: thousandths within what an AS real holds to about 7 significant digits
/// and what the 255-byte budget allows (21 arguments of at most 10 characters).
fn req_value() -> impl Strategy<Value = f64> {
    milli(99_999_999).prop_map(|m| m as f64 / 1000.0)
}

fn joints() -> BoxedStrategy<JointsDeg> {
    proptest::array::uniform6(req_value())
        .prop_map(JointsDeg::new)
        .boxed()
}

fn is_named_command(number: f64) -> bool {
    [1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 255.0].contains(&as_real(number))
}

fn arb_command() -> BoxedStrategy<Command> {
    prop_oneof![
        Just(Command::StartProgram),
        Just(Command::StopProgram),
        req_value().prop_map(|percent| Command::SetSpeed { percent }),
        Just(Command::Reserved),
        Just(Command::CancelMotion),
        joints().prop_map(|target| Command::JointMove { target }),
        (req_value(), req_value(), joints(), joints(), joints()).prop_map(
            |(t0_s, lookahead_passes, position, velocity, acceleration)| {
                Command::StreamedMove(StreamSample {
                    t0_s,
                    lookahead_passes,
                    position,
                    velocity,
                    acceleration,
                })
            }
        ),
        Just(Command::EndSession),
        (
            milli(9_999_999).prop_map(|m| m as f64 / 1000.0),
            proptest::collection::vec(req_value(), 0..=21)
        )
            .prop_filter("not a named command", |(n, _)| !is_named_command(*n))
            .prop_map(|(number, args)| Command::Other { number, args }),
    ]
    .boxed()
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(512))]

    // (2) What the client encodes, the controller reads as the same command (to the precision
    // of an AS real), and the version decides whether it acts.
    #[test]
    fn request_round_trip_through_the_server_parser(
        c in arb_command(),
        version in prop_oneof![3 => Just(1040i64), 1 => -99_999i64..=99_999],
    ) {
        let req = Request { version, command: c.clone() };
        let bytes = match req.encode() {
            Ok(b) => b,
            Err(EncodeError::TooLong { len, max }) => {
                // Only long `Other` argument lists can exceed the budget here.
                let is_other = matches!(c, Command::Other { .. });
                prop_assert!(is_other);
                prop_assert!(len > max);
                return Ok(());
            }
            Err(e) => return Err(TestCaseError::fail(format!("{e}"))),
        };
        prop_assert!(bytes.len() <= MAX_REQUEST_BYTES);
        prop_assert!(!bytes.starts_with(' ') && !bytes.ends_with(' ') && !bytes.contains("  "));
        prop_assert!(bytes.bytes().all(|b| b == b' ' || b == b'-' || b == b'.' || b.is_ascii_digit()));
        let parsed = ServerRequest::parse(bytes.as_bytes());
        prop_assert_eq!(parsed.version_matches(), version == 1040);
        prop_assert_eq!(parsed.version, version as f64);
        prop_assert_eq!(parsed.count, c.args().len());
        let seen = parsed.command();
        prop_assert!(commands_close(&seen, &c), "{:?} became {:?} via {:?}", c, seen, bytes);
        // Exactly the AS reals of the sent values: nothing is lost beyond f32 rounding.
        for ((_, sent), got) in c.args().iter().zip(&parsed.args) {
            prop_assert_eq!(*got, as_real(*sent));
        }
    }
}

/// One reply of a stream, with the way it is written.
fn arb_stream() -> impl Strategy<Value = Vec<(Status, Variant)>> {
    proptest::collection::vec((arb_status(), arb_variant()), 1..=5).prop_map(|mut replies| {
        // Between two replies at least one blank must separate the last field of one from the
        // first field of the next: with neither a final blank nor a leading blank the fields
        // run together ("0.0001040") and no reader can tell where one reply ends.
        for k in 1..replies.len() {
            if replies[k - 1].1.trailing.is_none() && matches!(replies[k].1.leading, Leading::None)
            {
                replies[k].1.leading = Leading::Blanks(1);
            }
        }
        replies
    })
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(384))]

    // (3) However the byte stream is cut, the decoder yields the same statuses as decoding
    // each reply whole.
    //
    // Decidable: a reply is complete once its 14th field is followed by a blank. A reply that
    // is the last of the stream and lacks its final blank is NOT complete (its last number
    // could still go on, "0.5" → "0.55", "0.000" → "0.0001"); it is yielded as soon as the
    // next blank arrives, or — the controller's fixed layout only — by `take_open_reply` when
    // the peer has gone quiet.
    #[test]
    fn any_split_of_a_stream_decodes_the_same(
        replies in arb_stream(),
        cuts in proptest::collection::vec(any::<Index>(), 0..24),
    ) {
        let mut stream = String::new();
        let mut expected = Vec::new();
        for (s, v) in &replies {
            let text = render(s, v);
            prop_assert_eq!(Status::decode(&text), Ok(s.clone()), "{:?}", text);
            stream.push_str(&text);
            expected.push(Ok(s.clone()));
        }
        prop_assume!(stream.len() <= MAX_BUFFERED);
        let cuts: Vec<usize> = cuts.iter().map(|i| i.index(stream.len() + 1)).collect();
        let (got, mut d) = decode_in_chunks(stream.as_bytes(), &cuts);

        let (last, lv) = replies.last().unwrap();
        if lv.trailing.is_none() {
            prop_assert_eq!(&got[..], &expected[..expected.len() - 1], "{:?}", stream);
            prop_assert!(!d.is_empty());
            if matches!(lv.layout, Layout::Exact) {
                prop_assert!(d.may_be_open_reply());
                prop_assert_eq!(d.take_open_reply().unwrap().map(|f| f.status), Some(last.clone()));
            } else {
                prop_assert_eq!(d.take_open_reply(), Ok(None));
                d.push(b" ").unwrap();
                prop_assert_eq!(d.next_reply().unwrap().map(|f| f.status), Some(last.clone()));
            }
        } else {
            prop_assert_eq!(got, expected, "{:?}", stream);
        }
        prop_assert!(d.is_empty(), "left over: {:?}", String::from_utf8_lossy(d.buffered()));
        prop_assert_eq!(d.next_reply(), Ok(None));
    }

    // (4) Arbitrary bytes, pushed in arbitrary chunks, never panic the decoder and never grow
    // its buffer beyond MAX_BUFFERED; every error is typed.
    #[test]
    fn arbitrary_bytes_never_panic_the_decoder(
        chunks in proptest::collection::vec(
            prop_oneof![
                proptest::collection::vec(any::<u8>(), 0..64),
                // Bytes a reply may contain, so the decoder gets past its byte filter.
                proptest::collection::vec(
                    proptest::sample::select(b" 0123456789-+.Ee*\r\n\t".to_vec()),
                    0..200
                ),
                arb_status().prop_map(|s| s.encode().into_bytes()),
            ],
            0..12
        ),
    ) {
        let mut d = ReplyDecoder::new();
        for chunk in &chunks {
            match d.push(chunk) {
                Ok(()) => {}
                Err(DecodeError::Overflow { len }) => {
                    prop_assert!(len > MAX_BUFFERED);
                    prop_assert!(d.buffered().is_empty());
                }
                Err(e) => return Err(TestCaseError::fail(format!("push failed with {e}"))),
            }
            prop_assert!(d.buffered().len() <= MAX_BUFFERED);
            let mut out = Vec::new();
            drain(&mut d, &mut out);
            for r in out {
                check_error_is_sensible(&r);
            }
        }
    }

    // (5) The server's parser never panics and always means something.
    #[test]
    fn server_parse_never_panics(bytes in proptest::collection::vec(any::<u8>(), 0..400)) {
        let r = ServerRequest::parse(&bytes);
        prop_assert!(r.count <= MAX_ARGS);
        prop_assert_eq!(r.args.len(), r.count);
        prop_assert!(r.version.is_finite() && r.command_number.is_finite());
        prop_assert!(r.args.iter().all(|a| a.is_finite() && *a == as_real(*a)));
        let _ = r.command();
        // Only the first 255 bytes count.
        let head = &bytes[..bytes.len().min(MAX_REQUEST_BYTES)];
        prop_assert_eq!(ServerRequest::parse(head), r);
    }

    #[test]
    fn server_parse_of_request_like_text(
        tokens in proptest::collection::vec(
            prop_oneof![
                "-?[0-9]{0,6}(\\.[0-9]{0,4})?([eE][-+]?[0-9]{0,3})?",
                "[0-9a-zA-Z.+-]{0,8}",
                Just(String::new()),
            ],
            0..40
        ),
    ) {
        let text = tokens.join(" ");
        let r = ServerRequest::parse(text.as_bytes());
        prop_assert!(r.version.is_finite());
        let _ = r.command();
        for t in &tokens {
            let v = as_val(t);
            prop_assert!(v.is_finite() && v == as_real(v));
        }
    }

    #[test]
    fn as_val_never_panics(text in ".{0,40}") {
        let v = as_val(&text);
        prop_assert!(v.is_finite());
        prop_assert_eq!(v, as_real(v));
    }

    #[test]
    fn status_decode_never_panics(text in "[ 0-9.eE*+\\-\r\n\t]{0,160}") {
        check_error_is_sensible(&Status::decode(&text));
    }
}

/// A decoding result that makes sense: a status with finite numbers, or a typed error whose
/// numbers are in range.
fn check_error_is_sensible(r: &Result<Status, DecodeError>) {
    match r {
        Ok(s) => {
            assert!(s.joints.is_finite());
            if let Timer::Seconds(t) = s.timer {
                assert!(t.is_finite());
            }
        }
        Err(DecodeError::Garbage { excerpt, .. }) => assert!(excerpt.chars().count() <= 40),
        Err(DecodeError::Incomplete { found }) => assert!(*found < 14),
        Err(DecodeError::TooManyFields { found }) => assert!(*found > 14),
        Err(DecodeError::JointOverflow { joint }) => assert!((1..=6).contains(joint)),
        Err(DecodeError::NotInteger { field, .. }) => assert!((1..=7).contains(field)),
        Err(DecodeError::Overflow { len }) => assert!(*len > MAX_BUFFERED),
    }
}

/// A sequence of statuses in which the joints often repeat (an arm standing still), sometimes
/// as `-0.0` against `0.0` or with any float (NaN, infinities, huge values).
fn arb_reply_sequence() -> impl Strategy<Value = Vec<Status>> {
    let any_joint = prop_oneof![
        4 => req_value(),
        1 => any::<f64>(),
        1 => Just(-0.0),
        1 => Just(0.0),
    ];
    let step = (
        arb_status(),
        proptest::bool::weighted(0.6),
        proptest::array::uniform6(any_joint),
    );
    proptest::collection::vec(step, 1..12).prop_map(|steps| {
        let mut out: Vec<Status> = Vec::new();
        for (mut s, repeat, joints) in steps {
            s.joints = match out.last() {
                Some(prev) if repeat => prev.joints,
                _ => JointsDeg::new(joints),
            };
            out.push(s);
        }
        out
    })
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(512))]

    // The memoizing encoder writes every reply byte for byte as `Status::encode_bytes`, whatever
    // came before it.
    #[test]
    fn reply_encoder_writes_what_encode_bytes_writes(seq in arb_reply_sequence()) {
        let mut encoder = fs020n_proto::ReplyEncoder::default();
        for s in &seq {
            prop_assert_eq!(encoder.encode(s), s.encode_bytes());
        }
    }
}
