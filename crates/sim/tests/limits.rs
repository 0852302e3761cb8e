//! Property-style: whatever a client streams, the joints never leave their ranges nor exceed
//! their maximum speeds (checked every 2 ms tick), and the controller stays consistent.

mod common;

use common::*;
use fs020n_kin::RobotModel;
use fs020n_proto::{Command, JointsDeg};
use fs020n_sim::{Controller, ControllerConfig, MotionTaskState};

/// A small deterministic generator (SplitMix64).
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }
    fn unit(&mut self) -> f64 {
        (self.next() >> 11) as f64 / (1u64 << 53) as f64
    }
    fn range(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * self.unit()
    }
}

fn random_joints(r: &mut Rng, model: &RobotModel, margin: f64) -> [f64; 6] {
    let mut q = [0.0; 6];
    for (j, spec) in model.joints.iter().enumerate() {
        q[j] = r.range(spec.min_deg + margin, spec.max_deg - margin);
    }
    q
}

fn check_tick(model: &RobotModel, prev: JointsDeg, c: &Controller, seed: u64) {
    let q = c.joints();
    let v = c.velocity();
    for (j, spec) in model.joints.iter().enumerate() {
        assert!(
            q[j] >= spec.min_deg && q[j] <= spec.max_deg,
            "seed {seed}: JT{} = {} out of range at {:?}",
            j + 1,
            q[j],
            c.now()
        );
        let max = spec.max_speed_deg_s * (1.0 + 1e-9);
        let step = (q[j] - prev[j]).abs() / 0.002;
        assert!(
            step <= max,
            "seed {seed}: JT{} moved at {step} deg/s > {max} at {:?}",
            j + 1,
            c.now()
        );
        assert!(
            v[j].abs() <= max,
            "seed {seed}: JT{} velocity {}",
            j + 1,
            v[j]
        );
    }
}

fn run(seed: u64, seconds: f64) -> (u64, u64) {
    let model = RobotModel::fs020n();
    let mut r = Rng(seed);
    let mut c = Controller::new(ControllerConfig::default());
    let id = c.try_accept().unwrap();
    raw(&mut c, id, "1040 1 0");
    raw(&mut c, id, "1040 3 1 100");
    let mut prev = c.joints();
    let mut errors = 0;
    // a wandering trajectory for command 7 starting where the robot stands; after a joint move
    // the stream resumes from the robot's new position
    let mut p = c.joints().values();
    let mut vel = [0.0; 6];
    let mut waiting = false;
    while c.now().as_secs_f64() < seconds {
        let dice = r.unit();
        if waiting {
            if is_still(&c) {
                waiting = false;
                p = c.joints().values();
                vel = [0.0; 6];
            }
            raw(&mut c, id, "0 0 0");
        } else if dice < 0.01 {
            let mut q = random_joints(&mut r, &model, 1.0);
            if r.unit() < 0.3 {
                q[2] = r.range(-6.0, 6.0); // into the singular zones: 7 then uses the 30 % JMOVE
            }
            if r.unit() < 0.3 {
                q[4] = r.range(-6.0, 6.0);
            }
            jmove(&mut c, id, q);
            waiting = true;
        } else if dice < 0.02 {
            raw(&mut c, id, "1040 5 0");
        } else if dice < 0.025 {
            raw(&mut c, id, &format!("1040 3 1 {:.0}", r.range(1.0, 120.0)));
        } else if dice < 0.028 {
            c.set_run(r.unit() < 0.7);
        } else if dice < 0.95 {
            for j in 0..6 {
                vel[j] = (vel[j] + r.range(-10.0, 10.0)).clamp(-60.0, 60.0);
                p[j] += vel[j] * 0.01;
                let spec = &model.joints[j];
                if p[j] < spec.min_deg + 5.0 || p[j] > spec.max_deg - 5.0 {
                    vel[j] = -vel[j];
                    p[j] = p[j].clamp(spec.min_deg + 5.0, spec.max_deg - 5.0);
                }
            }
            let s = sample(c.native().timer1_s(), r.range(0.0, 3.0), p, vel, [0.0; 6]);
            cmd(&mut c, id, Command::StreamedMove(s));
        } else {
            raw(&mut c, id, "0 0 0");
        }
        // 10 ms between requests, checked tick by tick
        for _ in 0..5 {
            c.advance_by(ms(2));
            check_tick(&model, prev, &c, seed);
            prev = c.joints();
        }
        if c.task() == MotionTaskState::NotRunning {
            // E1088 (no straight-line path): reset, restart, resume from where the robot is
            if !c.error().is_none() {
                errors += 1;
                c.reset_error().unwrap();
            }
            c.set_run(true);
            raw(&mut c, id, "1040 1 0");
            waiting = true;
        }
    }
    assert!(c.native().is_session_open(id));
    (c.counters().motions, errors)
}

#[test]
fn random_streams_never_leave_ranges_or_exceed_speeds() {
    let mut motions = 0;
    let mut errors = 0;
    for seed in 1..=6 {
        let (m, e) = run(seed, 20.0);
        motions += m;
        errors += e;
    }
    eprintln!("{motions} motions, {errors} errors");
    assert!(
        motions > 500,
        "the streams moved the robot: {motions} motions"
    );
}
