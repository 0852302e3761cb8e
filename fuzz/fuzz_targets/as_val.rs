//! `as_val` (the AS `VAL` function) on arbitrary text: never panics, always returns a finite AS
//! real (a 32-bit float), skips leading blanks, and ignores what follows the number.
#![no_main]

use fs020n_proto::number::as_val;
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    let v = as_val(text);
    assert!(v.is_finite());
    assert_eq!(v, f64::from(v as f32));
    assert_eq!(as_val(&format!("  {text}")), v);
    // A blank ends a number, so anything after one cannot change it (unless the text is only
    // blanks: then what follows is the first token).
    if text.trim_start_matches([' ', '\t']).len() > 0 {
        assert_eq!(as_val(&format!("{text} 9")), v);
    }
    // A number followed by a letter that cannot continue it.
    assert_eq!(as_val(&format!("{text}x")), v);
});
