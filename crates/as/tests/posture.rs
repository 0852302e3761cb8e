//! Posture commands on virtual time: `LEFTY`/`RIGHTY`, `ABOVE`/`BELOW`, `UWRIST`/`DWRIST`
//! choose the inverse-kinematics branch of the next joint motion to a transformation.
#![allow(clippy::expect_used)] // test code: a failed expectation is a failed test

mod common;

use common::{ms, pc, start};
use fs020n_as::system::System;
use fs020n_as::testing::VirtualSystem;
use fs020n_as::Interpreter;
use fs020n_proto::ErrorCode;

fn arr(i: &Interpreter, name: &str) -> [f64; 6] {
    std::array::from_fn(|k| {
        f64::from(
            i.real_at(name, &[k as i32])
                .unwrap_or_else(|| panic!("{name}[{k}] was not set")),
        )
    })
}

fn run(body: &str, secs: u64) -> (Interpreter, VirtualSystem) {
    let src = format!("{}.PROGRAM rob()\n{body}\n.END\n", pc("  MC EXECUTE rob"));
    let (mut i, mut s) = start(&src);
    i.run_until(&mut s, ms(secs * 1000));
    (i, s)
}

/// `q` puts the flange on `pose` (within 0.05 mm and 0.05°).
fn reaches(s: &VirtualSystem, q: &[f64; 6], pose: &[f64; 6]) {
    let f = s.forward(q).expect("kinematics");
    for k in 0..6 {
        assert!(
            (f[k] - pose[k]).abs() < 0.05,
            "{q:?} reaches {f:?}, not {pose:?}"
        );
    }
}

/// A pose the FS020N reaches with the elbow up and down (shoulder in front).
const POSE: [f64; 6] = [1200.0, 0.0, 1000.0, 0.0, 90.0, 0.0];
const T: &str = "TRANS(1200, 0, 1000, 0, 90, 0)";

#[test]
fn above_and_below_choose_the_elbow_and_the_wrist_commands_the_sign_of_jt5() {
    let (i, s) = run(
        &format!("  ABOVE\n  JMOVE {T}\n  BREAK\n  HERE #a\n  DECOMPOSE a[0] = #a\n  BELOW\n  JMOVE {T}\n  BREAK\n  HERE #b\n  DECOMPOSE b[0] = #b\n  UWRIST\n  JMOVE {T}\n  BREAK\n  HERE #c\n  DECOMPOSE c[0] = #c\n  DWRIST\n  JMOVE {T}\n  BREAK\n  HERE #d\n  DECOMPOSE d[0] = #d"),
        40,
    );
    assert!(s.raised.is_empty(), "{:?} {:?}", s.raised, s.terminal);
    let (a, b, c, d) = (arr(&i, "a"), arr(&i, "b"), arr(&i, "c"), arr(&i, "d"));
    for q in [&a, &b, &c, &d] {
        reaches(&s, q, &POSE);
    }
    assert!(a[2] < 0.0, "ABOVE (front shoulder): JT3 < 0: {a:?}");
    assert!(b[2] > 0.0, "BELOW: JT3 > 0: {b:?}");
    assert!(c[4] > 0.0, "UWRIST: JT5 > 0: {c:?}");
    assert!(d[4] < 0.0, "DWRIST: JT5 < 0: {d:?}");
}

#[test]
fn a_posture_without_a_solution_in_range_stops_with_e1088() {
    // Behind the JT1 axis for this pose, JT1 would leave its range.
    let (_, s) = run("  LEFTY\n  JMOVE TRANS(900, 100, 600, 0, 180, 0)", 5);
    assert_eq!(s.raised, vec![ErrorCode(-31088)]);
}

#[test]
fn lefty_reaches_a_pose_with_the_shoulder_behind_and_righty_cannot() {
    // A pose behind the robot: the FK of a back-configuration joint set (JT1 0°, the arm
    // leaning back).
    let s = VirtualSystem::new();
    let p = s
        .forward(&[0.0, -40.0, 20.0, 0.0, 60.0, 0.0])
        .expect("kinematics");
    let t = format!(
        "TRANS({}, {}, {}, {}, {}, {})",
        p[0], p[1], p[2], p[3], p[4], p[5]
    );
    let (i, s) = run(
        &format!("  LEFTY\n  ABOVE\n  JMOVE {t}\n  BREAK\n  HERE #a\n  DECOMPOSE a[0] = #a\n  LEFTY\n  BELOW\n  JMOVE {t}\n  BREAK\n  HERE #b\n  DECOMPOSE b[0] = #b\n  RIGHTY\n  JMOVE {t}"),
        40,
    );
    let (a, b) = (arr(&i, "a"), arr(&i, "b"));
    let p32 = p.map(|v| f64::from(v as f32));
    reaches(&s, &a, &p32);
    reaches(&s, &b, &p32);
    assert!(a[0].abs() < 0.01 && b[0].abs() < 0.01, "{a:?} {b:?}");
    assert!(a[2] > 0.0, "behind, elbow up is JT3 > 0: {a:?}");
    assert!(b[2] < 0.0, "{b:?}");
    assert_eq!(
        s.raised,
        vec![ErrorCode(-31088)],
        "RIGHTY: JT1 would be 180°"
    );
}

#[test]
fn a_posture_is_used_by_the_next_joint_motion_only() {
    let (i, s) = run(
        &format!("  BELOW\n  JMOVE {T}\n  BREAK\n  JMOVE #PPOINT(0, 30, -80, 0, -60, 0)\n  BREAK\n  JMOVE {T}\n  BREAK\n  HERE #a\n  DECOMPOSE a[0] = #a"),
        40,
    );
    assert!(s.raised.is_empty(), "{:?}", s.raised);
    // From an elbow-up start the nearest solution is elbow up again.
    assert!(arr(&i, "a")[2] < 0.0, "{:?}", arr(&i, "a"));
}
