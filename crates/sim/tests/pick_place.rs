//! The pick-and-place example (`crates/as/programs/examples/pick_place.as`) on the emulator:
//! TOOL and BASE, APPRO/DEPART around each pick and place, OPENI/CLOSEI, SWAIT on the
//! part-present input (scripted here on virtual time), and the PC program reporting over TCP.
#![allow(clippy::expect_used, clippy::unwrap_used)] // test code: a failure is a failed test

use std::time::Duration;

use fs020n_kin::{Pose, Xyzoat};
use fs020n_sim::{Controller, ControllerConfig, ServerProgram};

const PATH: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/../as/programs/examples/pick_place.as"
);

fn xyzoat(v: [f64; 6]) -> Pose {
    Pose::from_xyzoat(Xyzoat {
        x_mm: v[0],
        y_mm: v[1],
        z_mm: v[2],
        o_deg: v[3],
        a_deg: v[4],
        t_deg: v[5],
    })
}

/// The tool tip in the world as the program defines it: BASE (the 200 mm pedestal) · flange ·
/// TOOL (120 mm along the flange's Z axis).
fn tip(c: &Controller) -> [f64; 3] {
    let flange = c.model().forward(&c.joints().to_rad());
    let world = xyzoat([0.0, 0.0, 200.0, 0.0, 0.0, 0.0])
        * flange
        * xyzoat([0.0, 0.0, 120.0, 0.0, 0.0, 0.0]);
    let x = world.to_xyzoat();
    [x.x_mm, x.y_mm, x.z_mm]
}

fn near(a: [f64; 3], b: [f64; 3], mm: f64) -> bool {
    a.iter().zip(b).all(|(x, y)| (x - y).abs() <= mm)
}

const PICK: [f64; 3] = [900.0, 300.0, 800.0];
const PLACE: [f64; 3] = [900.0, -300.0, 800.0];

#[test]
fn the_pick_and_place_example_picks_on_the_sensor_and_reports_each_part() {
    let program = ServerProgram::from_file(std::path::Path::new(PATH)).unwrap();
    assert!(program.warnings().is_empty(), "{:?}", program.warnings());
    let mut c = Controller::with_program(ControllerConfig::default(), program);
    c.advance_by(Duration::from_secs(3));
    // Started, hand open, at #safe, waiting for a part.
    assert_eq!(c.program().signal(1), Some(true), "OPENI: output 1 ON");
    assert_eq!(c.program().signal(2), Some(false));
    let safe = c.joints().0;
    assert!(
        safe.iter()
            .zip([0.0, 0.0, -90.0, 0.0, -90.0, 0.0])
            .all(|(a, b)| (a - b).abs() < 0.01),
        "{safe:?}"
    );
    let tasks = c.program().tasks().unwrap();
    assert!(
        tasks[0].waiting.is_some(),
        "the robot waits at SWAIT: {tasks:?}"
    );
    let client = c
        .program_mut()
        .connect(Some(10060), [127, 0, 0, 1])
        .unwrap();
    c.advance_by(Duration::from_secs(2));
    assert_eq!(c.joints().0, safe, "no part, no motion");

    // A part arrives.
    c.program_mut().set_input(1001, true);
    let (mut closed_at, mut opened_at) = (None, None);
    let mut received = Vec::new();
    let mut t = 0;
    while t < 30_000 && received.is_empty() {
        c.advance_by(Duration::from_millis(2));
        t += 2;
        if closed_at.is_none() && c.program().signal(2) == Some(true) {
            closed_at = Some(tip(&c));
            // The part leaves the sensor once picked.
            c.program_mut().set_input(1001, false);
        }
        if closed_at.is_some() && opened_at.is_none() && c.program().signal(1) == Some(true) {
            opened_at = Some(tip(&c));
        }
        received.extend(c.program_mut().recv(client).bytes);
    }
    let closed_at = closed_at.expect("the hand closed");
    let opened_at = opened_at.expect("the hand opened again");
    assert!(
        near(closed_at, PICK, 0.5),
        "CLOSEI at the pick point: {closed_at:?}"
    );
    assert!(
        near(opened_at, PLACE, 0.5),
        "OPENI at the place point: {opened_at:?}"
    );
    assert_eq!(String::from_utf8_lossy(&received), "PLACED 1\r\n");
    assert_eq!(c.program().real("pp_placed"), Some(1.0));
    // LDEPART 100 from the place point, then back to SWAIT: no part, the robot waits there.
    c.advance_by(Duration::from_secs(3));
    assert!(near(tip(&c), [900.0, -300.0, 900.0], 0.5), "{:?}", tip(&c));
    c.advance_by(Duration::from_secs(5));
    assert_eq!(c.program().real("pp_placed"), Some(1.0));
    assert!(c
        .program()
        .terminal()
        .iter()
        .any(|l| l.text == "placed part  1"));
}
