//! `ServerRequest::parse` on arbitrary bytes: never panics, keeps COUNT arguments (bounded),
//! reads only AS reals, and ignores everything after byte 255.
#![no_main]

use fs020n_proto::{ServerRequest, MAX_ARGS};
use fs020n_proto::MAX_REQUEST_BYTES;
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let r = ServerRequest::parse(data);
    assert!(r.count <= MAX_ARGS);
    assert_eq!(r.args.len(), r.count);
    let real = |v: f64| v.is_finite() && v == f64::from(v as f32);
    assert!(real(r.version) && real(r.command_number));
    assert!(r.args.iter().all(|&a| real(a)));
    let _ = r.command();
    let head = &data[..data.len().min(MAX_REQUEST_BYTES)];
    assert_eq!(ServerRequest::parse(head), r);
});
