//! `ReplyDecoder` fed the input in chunks whose boundaries are derived from the data: never
//! panics, never holds more than `MAX_BUFFERED` bytes, every frame's text decodes to its
//! status, and without errors the frames plus the buffer are exactly the bytes pushed.
#![no_main]

use fs020n_proto::{ReplyDecoder, Status, MAX_BUFFERED};
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    // The first byte seeds the chunk sizes; the rest is the stream.
    let Some((&seed, stream)) = data.split_first() else {
        return;
    };
    let mut d = ReplyDecoder::new();
    let mut consumed: Vec<u8> = Vec::new();
    let mut clean = true;
    let mut state = u32::from(seed) | 1;
    let mut at = 0;
    while at < stream.len() {
        // A small xorshift over the seed and the byte at the cut gives sizes 1..=64.
        state ^= state << 13;
        state ^= state >> 17;
        state ^= state << 5;
        let size = 1 + ((state ^ u32::from(stream[at])) % 64) as usize;
        let end = (at + size).min(stream.len());
        let chunk = &stream[at..end];
        at = end;
        if d.push(chunk).is_err() {
            assert!(d.buffered().is_empty());
            clean = false;
            continue;
        }
        assert!(d.buffered().len() <= MAX_BUFFERED);
        loop {
            let before = d.buffered().len();
            match d.next_reply() {
                Ok(Some(frame)) => {
                    assert!(d.buffered().len() < before);
                    assert_eq!(Status::decode(&frame.text).as_ref(), Ok(&frame.status));
                    consumed.extend_from_slice(frame.text.as_bytes());
                }
                Ok(None) => break,
                Err(_) => {
                    assert!(d.buffered().is_empty());
                    clean = false;
                }
            }
        }
    }
    if clean {
        consumed.extend_from_slice(d.buffered());
        assert_eq!(consumed, stream);
    }
});
