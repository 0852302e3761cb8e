//! Encoding and decoding speed of the protocol core.

use criterion::{black_box, criterion_group, criterion_main, Criterion};
use fs020n_proto::ServerRequest;
use fs020n_proto::{Command, JointsDeg, ReplyDecoder, Request, Status, StreamSample, Timer};

fn status() -> Status {
    Status {
        timer: Timer::Seconds(1234.567),
        joints: JointsDeg::new([12.345, -45.678, -90.123, 170.5, -33.25, 359.999]),
        run: true,
        repeat: true,
        power: true,
        task_running: true,
        ..Status::default()
    }
}

fn bench(c: &mut Criterion) {
    let s = status();
    let text = s.encode();
    c.bench_function("reply/encode", |b| b.iter(|| black_box(&s).encode()));
    c.bench_function("reply/decode_whole", |b| {
        b.iter(|| Status::decode(black_box(&text)))
    });
    c.bench_function("reply/decoder_one_read", |b| {
        let mut d = ReplyDecoder::new();
        b.iter(|| {
            d.push(black_box(text.as_bytes())).ok();
            d.next_reply()
        })
    });
    c.bench_function("reply/decoder_two_halves", |b| {
        let mut d = ReplyDecoder::new();
        let (h1, h2) = text.as_bytes().split_at(text.len() / 2);
        b.iter(|| {
            d.push(black_box(h1)).ok();
            let none = d.next_reply();
            d.push(black_box(h2)).ok();
            (none, d.next_reply())
        })
    });
    let sample = StreamSample {
        t0_s: 12.345,
        lookahead_passes: 2.0,
        position: JointsDeg::new([1.5, -20.25, -90.0, 10.0, -60.5, 5.0]),
        velocity: JointsDeg::new([10.0, -2.0, 0.5, 0.0, 1.0, -3.0]),
        acceleration: JointsDeg::new([1.0; 6]),
    };
    let req = Request::new(Command::StreamedMove(sample));
    c.bench_function("request/encode_cmd7", |b| {
        b.iter(|| black_box(&req).encode())
    });
    let wire = req.encode().unwrap_or_default();
    c.bench_function("request/server_parse_cmd7", |b| {
        b.iter(|| ServerRequest::parse(black_box(wire.as_bytes())).command())
    });
}

criterion_group!(benches, bench);
criterion_main!(benches);
