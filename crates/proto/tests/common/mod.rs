//! Shared generators and helpers of the integration tests.
//!
//! Every test binary includes this module with `mod common;`; not every binary uses every item.
#![allow(dead_code)]

use fs020n_proto::number::format_f10_3;
use fs020n_proto::{
    Command, DecodeError, ErrorCode, JointsDeg, ReplyDecoder, Status, Timer, MAX_BUFFERED,
};
use proptest::prelude::*;

/// The spec's example reply (§3.1), byte for byte.
pub(crate) const SPEC_EXAMPLE: &str =
    " 1040 0 -1 -1 0 -1 -1    12.500     0.000    30.000     0.000     0.000     0.000     0.000 ";

/// The status of [`SPEC_EXAMPLE`].
pub(crate) fn spec_example_status() -> Status {
    Status {
        version: 1040,
        error: ErrorCode::NONE,
        run: true,
        repeat: true,
        teach_lock: false,
        power: true,
        task_running: true,
        timer: Timer::Seconds(12.5),
        joints: JointsDeg::new([0.0, 30.0, 0.0, 0.0, 0.0, 0.0]),
    }
}

/// A status with the given timer and joints, everything else as in the spec example.
pub(crate) fn status_with(timer: Timer, joints: [f64; 6]) -> Status {
    Status {
        timer,
        joints: JointsDeg::new(joints),
        ..spec_example_status()
    }
}

/// `value` rounded to 3 decimals the way `/F10.3` keeps it.
pub(crate) fn round3(value: f64) -> f64 {
    (value * 1000.0).round() / 1000.0
}

/// `value` as the controller stores it: an AS real, a 32-bit float.
pub(crate) fn as_real(value: f64) -> f64 {
    f64::from(value as f32)
}

/// `true` when `a` and `b` agree to the precision of an AS real (32-bit float).
pub(crate) fn close_f32(a: f64, b: f64) -> bool {
    (a - b).abs() <= a.abs().max(b.abs()) * f64::from(f32::EPSILON) + 1e-30
}

/// A value in thousandths, spread over the widths `/F10.3` prints (1 to 10 characters).
pub(crate) fn milli(max_abs: i64) -> impl Strategy<Value = i64> {
    prop_oneof![
        Just(0i64),
        -999i64..=999,
        -999_999i64..=999_999,
        -max_abs..=max_abs,
        Just(max_abs),
        Just(-max_abs),
    ]
}

/// A joint angle within ±99999.999, already at the 3 decimals the wire keeps.
pub(crate) fn joint_value() -> impl Strategy<Value = f64> {
    milli(99_999_999).prop_map(|m| m as f64 / 1000.0)
}

/// TIMER(1): 0..=99999.999 s or overflow.
pub(crate) fn timer_value() -> impl Strategy<Value = Timer> {
    prop_oneof![
        9 => (0i64..=99_999_999).prop_map(|m| Timer::Seconds(m as f64 / 1000.0)),
        1 => (0i64..=999).prop_map(|m| Timer::Seconds(m as f64 / 1000.0)),
        1 => Just(Timer::Overflow),
    ]
}

/// Any valid status: the version as a real server (1040) or any 32-bit number, any 32-bit
/// error code, any switches, a timer and six joints as above.
pub(crate) fn arb_status() -> impl Strategy<Value = Status> {
    (
        prop_oneof![3 => Just(1040i64), 1 => any::<i32>().prop_map(i64::from)],
        prop_oneof![Just(0i32), Just(-31088), -49_999i32..=-10_000, any::<i32>()],
        any::<[bool; 5]>(),
        timer_value(),
        proptest::array::uniform6(joint_value()),
    )
        .prop_map(|(version, error, b, timer, joints)| Status {
            version,
            error: ErrorCode(error),
            run: b[0],
            repeat: b[1],
            teach_lock: b[2],
            power: b[3],
            task_running: b[4],
            timer,
            joints: JointsDeg::new(joints),
        })
}

/// How a reply's fields are laid out on the wire.
#[derive(Debug, Clone)]
pub(crate) enum Layout {
    /// The controller's exact layout ([`Status::encode`]), without its leading and final blank
    /// (those are chosen separately). Touching 10-character fields happen here.
    Exact,
    /// The 14 fields trimmed and separated by runs of blanks (`seps[k]` blanks before field
    /// `k + 2`); `exponent[k]` writes real field `k + 8` in exponent notation.
    Spread {
        seps: Vec<usize>,
        exponent: Vec<bool>,
    },
}

/// What comes before the first field.
#[derive(Debug, Clone, Copy)]
pub(crate) enum Leading {
    None,
    Blanks(usize),
}

/// What comes after the last field.
#[derive(Debug, Clone, Copy)]
pub(crate) enum Trailing {
    None,
    Blanks(usize),
    CrLf,
    BlankCrLf,
}

impl Trailing {
    pub(crate) fn is_none(self) -> bool {
        matches!(self, Trailing::None)
    }
}

/// One way of writing a reply.
#[derive(Debug, Clone)]
pub(crate) struct Variant {
    pub layout: Layout,
    pub leading: Leading,
    pub trailing: Trailing,
}

impl Variant {
    /// The controller's exact bytes.
    pub(crate) fn exact() -> Variant {
        Variant {
            layout: Layout::Exact,
            leading: Leading::Blanks(1),
            trailing: Trailing::Blanks(1),
        }
    }
}

pub(crate) fn arb_layout() -> impl Strategy<Value = Layout> {
    prop_oneof![
        2 => Just(Layout::Exact),
        1 => (
            proptest::collection::vec(1usize..=4, 13),
            proptest::collection::vec(any::<bool>(), 7)
        )
            .prop_map(|(seps, exponent)| Layout::Spread { seps, exponent }),
    ]
}

pub(crate) fn arb_leading() -> impl Strategy<Value = Leading> {
    prop_oneof![
        1 => Just(Leading::None),
        3 => Just(Leading::Blanks(1)),
        1 => (2usize..=5).prop_map(Leading::Blanks),
    ]
}

pub(crate) fn arb_trailing() -> impl Strategy<Value = Trailing> {
    prop_oneof![
        1 => Just(Trailing::None),
        3 => Just(Trailing::Blanks(1)),
        1 => (2usize..=5).prop_map(Trailing::Blanks),
        1 => Just(Trailing::CrLf),
        1 => Just(Trailing::BlankCrLf),
    ]
}

pub(crate) fn arb_variant() -> impl Strategy<Value = Variant> {
    (arb_layout(), arb_leading(), arb_trailing()).prop_map(|(layout, leading, trailing)| Variant {
        layout,
        leading,
        trailing,
    })
}

/// A real field (timer or joint) in exponent notation: thousandths `E-3`.
fn exponent_form(value: f64) -> String {
    let m = (value * 1000.0).round() as i64;
    format!("{m}E-3")
}

/// The 14 fields of `s`, trimmed, as the controller would print them.
pub(crate) fn field_texts(s: &Status, exponent: &[bool]) -> Vec<String> {
    let b = |v: bool| if v { "-1" } else { "0" }.to_owned();
    let mut out = vec![
        s.version.to_string(),
        s.error.raw().to_string(),
        b(s.run),
        b(s.repeat),
        b(s.teach_lock),
        b(s.power),
        b(s.task_running),
    ];
    let real = |k: usize, v: f64| {
        if exponent.get(k).copied().unwrap_or(false) {
            exponent_form(v)
        } else {
            format_f10_3(v).trim_start().to_owned()
        }
    };
    out.push(match s.timer {
        Timer::Seconds(t) => real(0, t),
        Timer::Overflow => "**********".to_owned(),
    });
    for (i, j) in s.joints.iter().enumerate() {
        out.push(real(i + 1, j));
    }
    out
}

/// Renders `s` in the given variant.
pub(crate) fn render(s: &Status, v: &Variant) -> String {
    let body = match &v.layout {
        Layout::Exact => {
            let e = s.encode();
            e[1..e.len() - 1].to_owned()
        }
        Layout::Spread { seps, exponent } => {
            let fields = field_texts(s, exponent);
            let mut out = fields[0].clone();
            for (k, f) in fields[1..].iter().enumerate() {
                out.push_str(&" ".repeat(seps[k]));
                out.push_str(f);
            }
            out
        }
    };
    let lead = match v.leading {
        Leading::None => String::new(),
        Leading::Blanks(n) => " ".repeat(n),
    };
    let tail = match v.trailing {
        Trailing::None => "",
        Trailing::Blanks(n) => return format!("{lead}{body}{}", " ".repeat(n)),
        Trailing::CrLf => "\r\n",
        Trailing::BlankCrLf => " \r\n",
    };
    format!("{lead}{body}{tail}")
}

/// Pushes `stream` into a fresh decoder in the given chunks and collects every reply, checking
/// after each push that the buffer stays bounded. Returns the statuses and the decoder.
pub(crate) fn decode_in_chunks(
    stream: &[u8],
    cuts: &[usize],
) -> (Vec<Result<Status, DecodeError>>, ReplyDecoder) {
    let mut points: Vec<usize> = cuts.iter().map(|&c| c.min(stream.len())).collect();
    points.push(0);
    points.push(stream.len());
    points.sort_unstable();
    points.dedup();
    let mut d = ReplyDecoder::new();
    let mut out = Vec::new();
    for w in points.windows(2) {
        if let Err(e) = d.push(&stream[w[0]..w[1]]) {
            out.push(Err(e));
            continue;
        }
        assert!(d.buffered().len() <= MAX_BUFFERED);
        drain(&mut d, &mut out);
    }
    (out, d)
}

/// Takes every reply (or error) the decoder can give now.
pub(crate) fn drain(d: &mut ReplyDecoder, out: &mut Vec<Result<Status, DecodeError>>) {
    loop {
        let before = d.buffered().len();
        match d.next_reply() {
            Ok(Some(frame)) => {
                assert!(d.buffered().len() < before, "a reply must consume bytes");
                assert_eq!(
                    Status::decode(&frame.text).as_ref(),
                    Ok(&frame.status),
                    "a frame's text decodes to its status"
                );
                out.push(Ok(frame.status));
            }
            Ok(None) => break,
            Err(e) => {
                assert!(d.buffered().is_empty(), "an error clears the buffer");
                out.push(Err(e));
            }
        }
        assert!(d.buffered().len() <= MAX_BUFFERED);
    }
}

/// Compares two commands with the precision of an AS real.
pub(crate) fn commands_close(a: &Command, b: &Command) -> bool {
    let joints =
        |x: &JointsDeg, y: &JointsDeg| x.iter().zip(y.iter()).all(|(p, q)| close_f32(p, q));
    match (a, b) {
        (Command::SetSpeed { percent: p }, Command::SetSpeed { percent: q }) => close_f32(*p, *q),
        (Command::JointMove { target: p }, Command::JointMove { target: q }) => joints(p, q),
        (Command::StreamedMove(p), Command::StreamedMove(q)) => {
            close_f32(p.t0_s, q.t0_s)
                && close_f32(p.lookahead_passes, q.lookahead_passes)
                && joints(&p.position, &q.position)
                && joints(&p.velocity, &q.velocity)
                && joints(&p.acceleration, &q.acceleration)
        }
        (Command::Other { number: n, args: x }, Command::Other { number: m, args: y }) => {
            close_f32(*n, *m)
                && x.len() == y.len()
                && x.iter().zip(y).all(|(p, q)| close_f32(*p, *q))
        }
        _ => a == b,
    }
}
