//! A circular tool path through three poses (the AS `C1MOVE`/`C2MOVE` pair): the position runs
//! on the circle through the three positions, from the start through the via point to the end;
//! the orientation turns from the start's to the via point's, then to the end's (each part a
//! spherical linear interpolation, as a straight line's), so the path passes through the via
//! pose exactly.

use nalgebra::{UnitQuaternion, Vector3};

use crate::pose::Pose;

/// Two of the three positions closer than this, metres (0.1 mm): no circle.
pub const ARC_MIN_POINT_DISTANCE_M: f64 = 1.0e-4;

/// The via point closer than this to the straight line through the start and the end, metres
/// (0.01 mm): the three points are collinear, no circle.
pub const ARC_MIN_BULGE_M: f64 = 1.0e-5;

/// Why three positions define no circle.
#[derive(Debug, Clone, Copy, PartialEq, thiserror::Error)]
pub enum ArcError {
    /// Two of the positions coincide (closer than [`ARC_MIN_POINT_DISTANCE_M`]).
    #[error("two of the three points of the circle coincide ({distance_mm:.3} mm apart): teach three distinct points")]
    Coincident {
        /// The smallest distance between two of them, millimetres.
        distance_mm: f64,
    },
    /// The via point lies on the line through the start and the end (closer than
    /// [`ARC_MIN_BULGE_M`]).
    #[error("the three points of the circle are on one straight line (the via point is {bulge_mm:.4} mm off it): move the via point off the line, or use LMOVE")]
    Collinear {
        /// The via point's distance from the line, millimetres.
        bulge_mm: f64,
    },
    /// A position is not a finite number.
    #[error("a point of the circle is not a finite position")]
    NotFinite,
}

/// The circular path through three poses (see the module documentation).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CircularArc {
    center_m: Vector3<f64>,
    /// Unit vector from the centre to the start.
    u: Vector3<f64>,
    /// Unit vector in the circle's plane, 90° ahead of `u` in the direction of travel.
    v: Vector3<f64>,
    radius_m: f64,
    /// The angle swept from the start to the end, radians, in (0, 2π).
    sweep_rad: f64,
    /// The fraction of the path at the via point, in (0, 1).
    via_fraction: f64,
    rotations: [UnitQuaternion<f64>; 3],
}

impl CircularArc {
    /// The circle from `start` through `via` to `end` (their positions; the orientations are
    /// interpolated along it). Fails when two positions coincide or the three are collinear.
    pub fn through(start: &Pose, via: &Pose, end: &Pose) -> Result<CircularArc, ArcError> {
        let (p0, p1, p2) = (start.position_m(), via.position_m(), end.position_m());
        if !(start.is_finite() && via.is_finite() && end.is_finite()) {
            return Err(ArcError::NotFinite);
        }
        let closest = (p1 - p0).norm().min((p2 - p1).norm()).min((p2 - p0).norm());
        if closest < ARC_MIN_POINT_DISTANCE_M {
            return Err(ArcError::Coincident {
                distance_mm: closest * 1000.0,
            });
        }
        // The via point's distance from the line through the start and the end.
        let chord = p2 - p0;
        let a = p1 - p0;
        let cross = a.cross(&chord);
        let bulge = cross.norm() / chord.norm();
        if bulge < ARC_MIN_BULGE_M {
            return Err(ArcError::Collinear {
                bulge_mm: bulge * 1000.0,
            });
        }
        // The circumcentre: p0 + (|a|² (b × n) + |b|² (n × a)) / (2 |n|²), with b = p2 − p0
        // and n = a × b.
        let b = chord;
        let n = a.cross(&b);
        let n2 = n.norm_squared();
        let center =
            p0 + (b.cross(&n) * a.norm_squared() + n.cross(&a) * b.norm_squared()) / (2.0 * n2);
        let radius = (p0 - center).norm();
        // Travel is counter-clockwise about `normal` = a × b: the order start → via → end.
        let normal = n / n2.sqrt();
        let u = (p0 - center) / radius;
        let v = normal.cross(&u);
        let angle_of = |p: &Vector3<f64>| {
            let d = p - center;
            let t = d.dot(&v).atan2(d.dot(&u));
            if t <= 0.0 {
                t + 2.0 * std::f64::consts::PI
            } else {
                t
            }
        };
        let (via_angle, sweep) = (angle_of(&p1), angle_of(&p2));
        if !(via_angle > 0.0 && via_angle < sweep && radius.is_finite()) {
            // Only rounding can put the via point outside (0, sweep) for distinct, non-collinear
            // points; treat it as the collinear case.
            return Err(ArcError::Collinear {
                bulge_mm: bulge * 1000.0,
            });
        }
        Ok(CircularArc {
            center_m: center,
            u,
            v,
            radius_m: radius,
            sweep_rad: sweep,
            via_fraction: via_angle / sweep,
            rotations: [start.rotation(), via.rotation(), end.rotation()],
        })
    }

    /// The centre of the circle, metres.
    pub fn center_m(&self) -> Vector3<f64> {
        self.center_m
    }

    /// The radius, metres.
    pub fn radius_m(&self) -> f64 {
        self.radius_m
    }

    /// The length of the path from the start to the end, metres.
    pub fn length_m(&self) -> f64 {
        self.radius_m * self.sweep_rad
    }

    /// The angle swept from the start to the end, radians.
    pub fn sweep_rad(&self) -> f64 {
        self.sweep_rad
    }

    /// The fraction of the path (of its length) at which it passes the via point.
    pub fn via_fraction(&self) -> f64 {
        self.via_fraction
    }

    /// The total rotation of the tool along the path (start to via, then via to end), radians.
    pub fn rotation_rad(&self) -> f64 {
        let [r0, r1, r2] = &self.rotations;
        r0.angle_to(r1) + r1.angle_to(r2)
    }

    /// The pose at fraction `s` (0 = start, 1 = end) of the path's length.
    pub fn pose_at(&self, s: f64) -> Pose {
        let s = s.clamp(0.0, 1.0);
        let angle = s * self.sweep_rad;
        let position =
            self.center_m + (self.u * angle.cos() + self.v * angle.sin()) * self.radius_m;
        let [r0, r1, r2] = &self.rotations;
        let f = self.via_fraction;
        let rotation = if s <= f {
            r0.slerp(r1, s / f)
        } else {
            r1.slerp(r2, (s - f) / (1.0 - f))
        };
        Pose::new(position, rotation)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::pose::Xyzoat;

    fn pose(x_mm: f64, y_mm: f64, z_mm: f64, o: f64, a: f64, t: f64) -> Pose {
        Pose::from_xyzoat(Xyzoat {
            x_mm,
            y_mm,
            z_mm,
            o_deg: o,
            a_deg: a,
            t_deg: t,
        })
    }

    #[test]
    fn a_half_circle_through_three_points_has_their_centre_and_radius() {
        let arc = CircularArc::through(
            &pose(900.0, 0.0, 600.0, 0.0, 180.0, 0.0),
            &pose(1000.0, 100.0, 600.0, 0.0, 180.0, 0.0),
            &pose(1100.0, 0.0, 600.0, 0.0, 180.0, 0.0),
        )
        .expect("a circle");
        assert!((arc.radius_m() - 0.1).abs() < 1e-12);
        assert!((arc.center_m() - Vector3::new(1.0, 0.0, 0.6)).norm() < 1e-12);
        assert!((arc.sweep_rad() - std::f64::consts::PI).abs() < 1e-12);
        assert!((arc.via_fraction() - 0.5).abs() < 1e-12);
        assert!((arc.length_m() - 0.1 * std::f64::consts::PI).abs() < 1e-12);
    }

    #[test]
    fn every_pose_of_the_path_is_on_the_circle_and_the_ends_and_via_are_exact() {
        let (a, b, c) = (
            pose(800.0, -100.0, 500.0, 0.0, 180.0, 0.0),
            pose(850.0, 50.0, 650.0, 20.0, 170.0, 10.0),
            pose(700.0, 120.0, 700.0, -30.0, 160.0, 40.0),
        );
        let arc = CircularArc::through(&a, &b, &c).expect("a circle");
        for k in 0..=100 {
            let p = arc.pose_at(f64::from(k) / 100.0);
            let r = (p.position_m() - arc.center_m()).norm();
            assert!((r - arc.radius_m()).abs() < 1e-12, "{k}: {r}");
        }
        assert!(arc.pose_at(0.0).distance_m(&a) < 1e-12);
        assert!(arc.pose_at(1.0).distance_m(&c) < 1e-12);
        assert!(arc.pose_at(1.0).angle_to_rad(&c) < 1e-9);
        let at_via = arc.pose_at(arc.via_fraction());
        assert!(at_via.distance_m(&b) < 1e-12);
        assert!(at_via.angle_to_rad(&b) < 1e-9);
        // Equal fractions are equal lengths along the circle (constant speed in s).
        let chord = |s0: f64, s1: f64| arc.pose_at(s0).distance_m(&arc.pose_at(s1));
        assert!((chord(0.0, 0.1) - chord(0.5, 0.6)).abs() < 1e-12);
    }

    #[test]
    fn the_path_goes_from_the_start_through_the_via_point_whatever_the_order_in_space() {
        // The via point on the far side: the long way round (three quarters of the circle).
        let arc = CircularArc::through(
            &pose(100.0, 0.0, 0.0, 0.0, 0.0, 0.0),
            &pose(-100.0, 0.0, 0.0, 0.0, 0.0, 0.0),
            &pose(0.0, -100.0, 0.0, 0.0, 0.0, 0.0),
        )
        .expect("a circle");
        assert!((arc.sweep_rad() - 1.5 * std::f64::consts::PI).abs() < 1e-12);
        assert!((arc.via_fraction() - 2.0 / 3.0).abs() < 1e-12);
    }

    #[test]
    fn collinear_or_coincident_points_define_no_circle() {
        let p = |x: f64| pose(x, 2.0 * x, 500.0, 0.0, 180.0, 0.0);
        assert!(matches!(
            CircularArc::through(&p(0.0), &p(100.0), &p(200.0)),
            Err(ArcError::Collinear { .. })
        ));
        // On the line but beyond the end: no circle either.
        assert!(matches!(
            CircularArc::through(&p(0.0), &p(300.0), &p(200.0)),
            Err(ArcError::Collinear { .. })
        ));
        assert!(matches!(
            CircularArc::through(&p(0.0), &p(0.0), &p(200.0)),
            Err(ArcError::Coincident { .. })
        ));
        assert!(matches!(
            CircularArc::through(&p(0.0), &p(100.0), &p(0.00001)),
            Err(ArcError::Coincident { .. })
        ));
    }
}
