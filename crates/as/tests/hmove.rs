//! `HMOVE` on the test system: a hybrid motion to the location (converted by TOOL and BASE as
//! any target); the emulator's planner draws its path (`fs020n-sim`'s tests/hmove.rs).
#![allow(clippy::expect_used)] // test code: a failed expectation is a failed test

mod common;

use common::{ms, pc, start};
use fs020n_as::system::{MotionKind, System, Target};
use fs020n_proto::ErrorCode;

#[test]
fn hmove_issues_a_hybrid_motion_to_the_flange_of_the_tool_target() {
    let src = format!(
        "{}.PROGRAM rob()\n  TOOL TRANS(0, 0, 150)\n  HMOVE TRANS(900, 100, 600, 0, 180, 0)\n  BREAK\n  HMOVE #PPOINT(10, 20, -80, 0, -70, 5)\n  BREAK\n.END\n",
        pc("  MC EXECUTE rob")
    );
    let (mut i, mut s) = start(&src);
    i.run_until(&mut s, ms(20_000));
    assert!(s.raised.is_empty(), "{:?}", s.raised);
    assert_eq!(s.motions.len(), 2);
    assert!(s.motions.iter().all(|(_, m)| m.kind == MotionKind::Hybrid));
    match s.motions[0].1.target {
        // The tool points down: the flange 150 mm above the tip.
        Target::Pose(p) => assert!((p[2] - 750.0).abs() < 1e-3, "{p:?}"),
        other => panic!("{other:?}"),
    }
    let q = s.joints();
    let want = [10.0, 20.0, -80.0, 0.0, -70.0, 5.0];
    assert!(
        q.iter().zip(want).all(|(a, b)| (a - b).abs() < 1e-6),
        "{q:?}"
    );
}

#[test]
fn hmove_in_a_pc_program_is_e1095() {
    let (mut i, mut s) = start(&pc("  HMOVE #PPOINT(0, 0, -90, 0, -90, 0)"));
    i.run_until(&mut s, ms(10));
    assert_eq!(s.raised, vec![ErrorCode(-31095)]);
}

#[test]
fn hmove_out_of_reach_is_e1088() {
    let src = format!(
        "{}.PROGRAM rob()\n  HMOVE TRANS(5000, 0, 600, 0, 180, 0)\n.END\n",
        pc("  MC EXECUTE rob")
    );
    let (mut i, mut s) = start(&src);
    i.run_until(&mut s, ms(100));
    assert_eq!(s.raised, vec![ErrorCode::DESTINATION_OUT_OF_RANGE]);
}
