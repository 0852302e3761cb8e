use fs020n_kin::RobotModel;
use fs020n_client::{JointsDeg, Trajectory, TrajectoryPoint};
fn main() {
    let m = RobotModel::fs020n();
    let text = include_str!("../../../examples/circle.csv");
    let pts: Vec<TrajectoryPoint> = text.lines().filter(|l| !l.starts_with('#') && !l.starts_with("time") && !l.trim().is_empty())
        .filter_map(|l| { let v: Vec<f64> = l.split(',').filter_map(|x| x.trim().parse().ok()).collect();
            (v.len()==7).then(|| TrajectoryPoint::new(v[0], JointsDeg::new([v[1],v[2],v[3],v[4],v[5],v[6]]))) }).collect();
    let c = Trajectory::new(pts).unwrap();
    let e = Trajectory::new((0..=250).map(|k| { let t = k as f64*0.02; let u=t/5.0; let ph = std::f64::consts::TAU*(u-(std::f64::consts::TAU*u).sin()/std::f64::consts::TAU);
        TrajectoryPoint::new(t, JointsDeg::new([15.0*ph.sin(),0.0,-90.0+6.0*(2.0*ph).sin(),0.0,-90.0+10.0*(1.0-ph.cos()),0.0]))}).collect()).unwrap();
    for (name, t) in [("circle", c), ("eight", e)] {
        let mut tau = t.start_s(); let mut out = String::new();
        while tau < t.end_s() {
            let a = m.flange_position_m(&t.sample(tau).position.to_rad());
            let b = m.flange_position_m(&t.sample(tau+0.001).position.to_rad());
            let v = t.sample(tau).velocity; let vmax = v.iter().fold(0.0f64, |x, y| x.max(y.abs()));
            out += &format!("{:.1}:{:.0}mm/s,{:.0}d/s ", tau, (b-a).norm()*1e6, vmax);
            tau += 0.25;
        }
        println!("{name}: {out}");
    }
}
