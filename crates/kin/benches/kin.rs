//! Kinematics benchmarks: forward kinematics, all IK solutions, nearest IK solution, Jacobian,
//! joint-move planning. Figures are recorded in docs/KINEMATICS.md.

use std::hint::black_box;

use criterion::{criterion_group, criterion_main, Criterion};
use fs020n_kin::{JointMove, JointsDeg, JointsRad, Pose, RobotModel};

/// A fixed set of generic configurations inside the ranges (cycled through so that the
/// benchmark does not measure one lucky branch).
fn configurations() -> Vec<JointsRad> {
    let mut out = Vec::new();
    let mut x: u64 = 0x9E37_79B9_7F4A_7C15;
    let mut next = || {
        // xorshift64*
        x ^= x >> 12;
        x ^= x << 25;
        x ^= x >> 27;
        (x.wrapping_mul(0x2545_F491_4F6C_DD1D) >> 11) as f64 / (1u64 << 53) as f64
    };
    let model = RobotModel::fs020n();
    while out.len() < 64 {
        let mut q = JointsDeg::ZERO;
        for (i, spec) in model.joints.iter().enumerate() {
            q[i] = spec.min_deg + (spec.max_deg - spec.min_deg) * next();
        }
        let m = model.singularity_margins(&q.to_rad());
        if m.elbow_deg > 5.0 && m.wrist_deg > 5.0 && m.shoulder_m > 0.05 {
            out.push(q.to_rad());
        }
    }
    out
}

fn bench(c: &mut Criterion) {
    let model = RobotModel::fs020n();
    let qs = configurations();
    let poses: Vec<Pose> = qs.iter().map(|q| model.forward(q)).collect();

    let mut i = 0usize;
    c.bench_function("fk_flange", |b| {
        b.iter(|| {
            i = (i + 1) % qs.len();
            black_box(model.forward(black_box(&qs[i])))
        })
    });

    let mut i = 0usize;
    c.bench_function("ik_all_solutions", |b| {
        b.iter(|| {
            i = (i + 1) % poses.len();
            black_box(model.inverse_all(black_box(&poses[i])))
        })
    });

    let mut i = 0usize;
    c.bench_function("ik_nearest", |b| {
        b.iter(|| {
            i = (i + 1) % poses.len();
            black_box(model.inverse_nearest(black_box(&poses[i]), black_box(&qs[i])))
        })
    });

    let mut i = 0usize;
    c.bench_function("jacobian", |b| {
        b.iter(|| {
            i = (i + 1) % qs.len();
            black_box(model.jacobian(black_box(&qs[i])))
        })
    });

    let mut i = 0usize;
    c.bench_function("singularity_distance_svd", |b| {
        b.iter(|| {
            i = (i + 1) % qs.len();
            black_box(model.singularity_distance(black_box(&qs[i])))
        })
    });

    let mut i = 0usize;
    c.bench_function("joint_move_plan_and_sample", |b| {
        b.iter(|| {
            i = (i + 1) % qs.len();
            let j = (i + 7) % qs.len();
            let mv = JointMove::plan(&model, qs[i].to_deg(), qs[j].to_deg(), black_box(0.3));
            black_box(mv.position_at(mv.duration_s() * 0.4))
        })
    });
}

criterion_group!(benches, bench);
criterion_main!(benches);
