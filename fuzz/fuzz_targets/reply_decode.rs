//! `Status::decode` on arbitrary text: never panics; every result is sensible; whatever decodes
//! re-encodes (when it fits the controller's formats) and decodes to the same values.
#![no_main]

use fs020n_proto::{DecodeError, Status, Timer};
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    match Status::decode(text) {
        Ok(s) => {
            assert!(s.joints.is_finite());
            let printable = |x: f64| (-99_999.999..=999_999.999).contains(&x);
            let timer_ok = match s.timer {
                Timer::Seconds(t) => {
                    assert!(t.is_finite());
                    printable(t)
                }
                Timer::Overflow => true,
            };
            if timer_ok && s.joints.iter().all(printable) && s.version.unsigned_abs() < 1 << 52 {
                let again = Status::decode(&s.encode()).expect("a re-encoded status decodes");
                assert_eq!(again.version, s.version);
                assert_eq!(again.error, s.error);
                for (a, b) in again.joints.iter().zip(s.joints.iter()) {
                    assert!((a - b).abs() <= 0.0005 + 1e-12 * a.abs().max(b.abs()));
                }
            }
        }
        Err(DecodeError::Garbage {
            offset, excerpt, ..
        }) => {
            assert!(offset <= text.len());
            assert!(excerpt.chars().count() <= 40);
        }
        Err(DecodeError::Incomplete { found }) => assert!(found < 14),
        Err(DecodeError::TooManyFields { found }) => assert!(found > 14),
        Err(DecodeError::JointOverflow { joint }) => assert!((1..=6).contains(&joint)),
        Err(DecodeError::NotInteger { field, .. }) => assert!((1..=7).contains(&field)),
        Err(DecodeError::Overflow { .. }) => panic!("Status::decode never buffers"),
    }
});
