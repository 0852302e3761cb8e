//! `HMOVE` on the emulator's planner, on virtual time: the wrist centre on the straight line,
//! the wrist joints turning in step with it, the target reached at the program's speed.
#![allow(clippy::expect_used, clippy::unwrap_used)] // test code: a failure is a failed test

use std::time::Duration;

use fs020n_proto::JointsDeg;
use fs020n_sim::{Controller, ControllerConfig, ServerProgram};

fn ms(v: u64) -> Duration {
    Duration::from_millis(v)
}

const FROM: [f64; 6] = [-20.0, 10.0, -80.0, -30.0, -60.0, 20.0];
const TO: [f64; 6] = [25.0, 25.0, -70.0, 40.0, -90.0, -30.0];

fn controller() -> Controller {
    let src = format!(
        ".PROGRAM autostart.pc()\n  MC EXECUTE rob\n.END\n.PROGRAM rob()\n  JMOVE #PPOINT({})\n  BREAK\n  SIGNAL 1\n  SPEED 200 MM/S ALWAYS\n  HMOVE #PPOINT({})\n  BREAK\n  SIGNAL 2\n.END\n",
        FROM.map(|v| v.to_string()).join(", "),
        TO.map(|v| v.to_string()).join(", ")
    );
    let program = ServerProgram::from_source("t.as", &src).unwrap();
    let mut c = Controller::with_program(ControllerConfig::default(), program);
    c.set_monitor_speed(100.0).unwrap();
    c
}

#[test]
fn hmove_keeps_the_wrist_centre_on_the_line_and_turns_the_wrist_in_step() {
    let mut c = controller();
    let mut t = 0;
    while c.program().signal(1) != Some(true) {
        c.advance_by(ms(2));
        t += 2;
        assert!(t < 30_000);
    }
    let started = t;
    let model = c.model().clone();
    let w0 = model.wrist_centre_m(&JointsDeg::new(FROM).to_rad());
    let w1 = model.wrist_centre_m(&JointsDeg::new(TO).to_rad());
    let line = w1 - w0;
    let (mut off_line, mut out_of_step) = (0.0f64, 0.0f64);
    while c.program().signal(2) != Some(true) {
        c.advance_by(ms(2));
        t += 2;
        assert!(t < 60_000, "never reached the target");
        let q = c.joints();
        let w = model.wrist_centre_m(&q.to_rad());
        let along = (w - w0).dot(&line) / line.norm_squared();
        off_line = off_line.max(((w - w0) - line * along).norm() * 1000.0);
        for j in 3..6 {
            let f = (q[j] - FROM[j]) / (TO[j] - FROM[j]);
            out_of_step = out_of_step.max((f - along).abs());
        }
    }
    assert!(c.error().is_none(), "{}", c.error());
    assert!(
        off_line < 0.5,
        "the wrist centre left the line by {off_line} mm"
    );
    assert!(out_of_step < 0.01, "the wrist out of step by {out_of_step}");
    let end = c.joints();
    assert!(end.max_abs_diff(&JointsDeg::new(TO)) < 1e-9, "{end}");
    // The wrist centre's travel at 200 mm/s (no joint limits it here).
    let took_s = (t - started) as f64 / 1000.0;
    let nominal_s = line.norm() * 1000.0 / 200.0;
    assert!(
        (took_s - nominal_s).abs() < 0.02,
        "{took_s} s, nominal {nominal_s} s"
    );
}
