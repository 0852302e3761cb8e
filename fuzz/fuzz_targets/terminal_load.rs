//! The deploy client's LOAD (fs020n-term) against arbitrary controller text: the input is cut
//! into pieces at the bytes 0x00 (each piece arrives at its own millisecond, so quiet times
//! and questions happen between them). Never panics; never sends a block of the file after a
//! refusal line; always ends a transfer it began (end of file or the end frame) unless the
//! controller returned to its prompt; idle again by its deadlines.
#![no_main]

use fs020n_term::testing::load_against;
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let pieces: Vec<&[u8]> = data.split(|&b| b == 0).collect();
    let run = load_against(&pieces);
    assert!(!run.block_after_refusal, "{run:?}");
    assert!(!run.began || run.ended || run.returned, "{run:?}");
    assert!(run.idle && run.finished, "{run:?}");
});
