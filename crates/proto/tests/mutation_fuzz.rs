//! Bounded fuzzing inside the normal test run: random mutations of valid replies and
//! requests (byte flips, insertions, deletions, duplications, truncations) must never panic and
//! must give sensible results.
//!
//! The number of cases defaults to a few thousand (a few seconds in a debug build); set
//! `FS020N_FUZZ_CASES` to run more, e.g. `FS020N_FUZZ_CASES=200000 cargo test --release -p
//! fs020n-proto --test mutation_fuzz`. The coverage-guided fuzz targets live in `fuzz/`.

mod common;

use common::*;
use fs020n_proto::ServerRequest;
use fs020n_proto::{
    Command, DecodeError, ReplyDecoder, Request, Status, StreamSample, Timer, MAX_BUFFERED,
};
use proptest::prelude::*;
use proptest::sample::Index;

fn cases() -> u32 {
    std::env::var("FS020N_FUZZ_CASES")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(10_000)
}

/// One mutation of a byte string.
#[derive(Debug, Clone)]
enum Mutation {
    Flip(Index, u8),
    Insert(Index, u8),
    Delete(Index),
    Duplicate(Index, Index),
    Truncate(Index),
}

/// Bytes that matter to the decoder, and a few that do not.
fn interesting_byte() -> impl Strategy<Value = u8> {
    prop_oneof![
        4 => proptest::sample::select(b" 0123456789-+.Ee*".to_vec()),
        1 => proptest::sample::select(b"\r\n\t\0\xff,xO".to_vec()),
        1 => any::<u8>(),
    ]
}

fn mutation() -> impl Strategy<Value = Mutation> {
    prop_oneof![
        4 => (any::<Index>(), interesting_byte()).prop_map(|(i, b)| Mutation::Flip(i, b)),
        3 => (any::<Index>(), interesting_byte()).prop_map(|(i, b)| Mutation::Insert(i, b)),
        3 => any::<Index>().prop_map(Mutation::Delete),
        1 => (any::<Index>(), any::<Index>()).prop_map(|(a, b)| Mutation::Duplicate(a, b)),
        1 => any::<Index>().prop_map(Mutation::Truncate),
    ]
}

fn apply(bytes: &mut Vec<u8>, m: &Mutation) {
    let n = bytes.len();
    match m {
        Mutation::Flip(i, b) if n > 0 => bytes[i.index(n)] = *b,
        Mutation::Insert(i, b) => bytes.insert(i.index(n + 1), *b),
        Mutation::Delete(i) if n > 0 => {
            bytes.remove(i.index(n));
        }
        Mutation::Duplicate(a, b) if n > 0 => {
            let (a, b) = (a.index(n), b.index(n));
            let (lo, hi) = (a.min(b), a.max(b).min(a.min(b) + 16));
            let copy = bytes[lo..=hi.min(n - 1)].to_vec();
            bytes.splice(lo..lo, copy);
        }
        Mutation::Truncate(i) => bytes.truncate(i.index(n + 1)),
        _ => {}
    }
}

fn check_sensible(r: &Result<Status, DecodeError>, input_len: usize) {
    match r {
        Ok(s) => {
            assert!(s.joints.is_finite());
            if let Timer::Seconds(t) = s.timer {
                assert!(t.is_finite());
            }
        }
        Err(DecodeError::Garbage {
            offset, excerpt, ..
        }) => {
            assert!(*offset <= input_len.max(MAX_BUFFERED));
            assert!(excerpt.chars().count() <= 40);
        }
        Err(DecodeError::Incomplete { found }) => assert!(*found < 14),
        Err(DecodeError::TooManyFields { found }) => assert!(*found > 14),
        Err(DecodeError::JointOverflow { joint }) => assert!((1..=6).contains(joint)),
        Err(DecodeError::NotInteger { field, .. }) => assert!((1..=7).contains(field)),
        Err(DecodeError::Overflow { len }) => assert!(*len > MAX_BUFFERED),
    }
}

/// `true` when `a` and `b` agree to the 3 decimals of `/F10.3`.
fn same_to_3_decimals(a: f64, b: f64) -> bool {
    (a - b).abs() <= 0.0005 + 1e-12 * a.abs().max(b.abs())
}

proptest! {
    // A random seed on every run (proptest prints it with a failure, and records the case in
    // `mutation_fuzz.proptest-regressions`); set PROPTEST_RNG_SEED=<number> to replay one.
    #![proptest_config(ProptestConfig {
        cases: cases(),
        max_shrink_iters: 2000,
        rng_seed: std::env::var("PROPTEST_RNG_SEED")
            .ok()
            .and_then(|s| s.parse().ok())
            .map_or(proptest::test_runner::RngSeed::Random, proptest::test_runner::RngSeed::Fixed),
        ..ProptestConfig::default()
    })]

    #[test]
    fn mutated_replies(
        s in arb_status(),
        v in arb_variant(),
        mutations in proptest::collection::vec(mutation(), 1..6),
        split in any::<Index>(),
    ) {
        let mut bytes = render(&s, &v).into_bytes();
        for m in &mutations {
            apply(&mut bytes, m);
        }
        let text = String::from_utf8_lossy(&bytes).into_owned();

        // Whole decoding: no panic, a sensible result.
        let whole = Status::decode(&text);
        check_sensible(&whole, text.len());

        // Whatever decodes re-encodes and decodes to the same values (to 3 decimals) when it
        // fits the controller's formats.
        if let Ok(d) = &whole {
            let printable = |x: f64| (-99_999.999..=999_999.999).contains(&x);
            let timer_ok = match d.timer { Timer::Seconds(t) => printable(t), Timer::Overflow => true };
            if timer_ok && d.joints.iter().all(printable) && d.version.unsigned_abs() < 1 << 52 {
                let again = Status::decode(&d.encode()).expect("re-encoded status decodes");
                prop_assert_eq!(again.version, d.version);
                prop_assert_eq!(again.error, d.error);
                prop_assert_eq!(
                    [again.run, again.repeat, again.teach_lock, again.power, again.task_running],
                    [d.run, d.repeat, d.teach_lock, d.power, d.task_running]
                );
                match (again.timer, d.timer) {
                    (Timer::Seconds(a), Timer::Seconds(b)) => prop_assert!(same_to_3_decimals(a, b)),
                    (a, b) => prop_assert_eq!(a, b),
                }
                for (a, b) in again.joints.iter().zip(d.joints.iter()) {
                    prop_assert!(same_to_3_decimals(a, b), "{} vs {}", a, b);
                }
            }
        }

        // Stream decoding of the raw bytes in two chunks: no panic, bounded, sensible, and in
        // agreement with whole decoding on a reply that ends with a blank.
        let cut = split.index(bytes.len() + 1);
        let (results, dec) = decode_in_chunks(&bytes, &[cut]);
        prop_assert!(dec.buffered().len() <= MAX_BUFFERED);
        for r in &results {
            check_sensible(r, bytes.len());
        }
        if let Ok(s) = &whole {
            if bytes.last() == Some(&b' ') {
                prop_assert_eq!(results.first(), Some(&Ok(s.clone())), "{:?}", text);
            }
        }
    }

    #[test]
    fn mutated_requests(
        t in joint_value(),
        mutations in proptest::collection::vec(mutation(), 1..6),
        which in 0usize..4,
    ) {
        let command = match which {
            0 => Command::SetSpeed { percent: t },
            1 => Command::JointMove { target: [t; 6].into() },
            2 => Command::StreamedMove(StreamSample {
                t0_s: t,
                lookahead_passes: 2.0,
                position: [t; 6].into(),
                velocity: [1.0; 6].into(),
                acceleration: [0.0; 6].into(),
            }),
            _ => Command::EndSession,
        };
        let mut bytes = Request::new(command).encode().unwrap().into_bytes();
        for m in &mutations {
            apply(&mut bytes, m);
        }
        let r = ServerRequest::parse(&bytes);
        prop_assert_eq!(r.args.len(), r.count);
        prop_assert!(r.args.iter().all(|a| a.is_finite()));
        let _ = r.command();
    }
}

/// A long-running decoder fed many mutated replies in a row never exceeds its bound and
/// recovers after every error (the buffer is cleared).
#[test]
fn decoder_survives_a_stream_of_mutated_replies() {
    use proptest::strategy::ValueTree;
    use proptest::test_runner::TestRunner;
    let mut runner = TestRunner::deterministic();
    let strategy = (
        arb_status(),
        arb_variant(),
        proptest::collection::vec(mutation(), 0..3),
    );
    let mut d = ReplyDecoder::new();
    let mut ok = 0;
    for _ in 0..(cases() / 3).max(100) {
        let (s, v, ms) = strategy.new_tree(&mut runner).unwrap().current();
        let mut bytes = render(&s, &v).into_bytes();
        for m in &ms {
            apply(&mut bytes, m);
        }
        if d.push(&bytes).is_err() {
            assert!(d.buffered().is_empty());
            continue;
        }
        let mut out = Vec::new();
        drain(&mut d, &mut out);
        ok += out.iter().filter(|r| r.is_ok()).count();
        assert!(d.buffered().len() <= MAX_BUFFERED);
    }
    assert!(ok > 0, "some replies survive their mutations");
}
