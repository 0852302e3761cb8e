//! Poses (position in metres + orientation) and the AS transformation representation
//! X, Y, Z (mm), O, A, T (degrees, Z-Y-Z Euler angles).

use nalgebra::{Isometry3, Matrix3, Rotation3, Translation3, UnitQuaternion, Vector3};

/// Below this `sin(A)` the O/T split is undefined; see [`Pose::to_xyzoat`].
const EULER_SINGULAR_EPS: f64 = 1e-10;

/// A rigid transformation: position in **metres**, orientation as a rotation.
///
/// Used for the flange pose in the base frame, for a tool offset relative to the flange, and for
/// a tool-point pose. Composition: `a * b` is `b` expressed in the frame `a`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Pose(pub Isometry3<f64>);

/// The AS language transformation representation: position in millimetres, orientation as
/// Z-Y-Z Euler angles O, A, T in degrees: `R = Rz(O) · Ry(A) · Rz(T)`.
///
/// The tool pointing straight down gives `A = 180`. Serializes as the six named fields.
#[derive(Debug, Clone, Copy, PartialEq, Default, serde::Serialize, serde::Deserialize)]
pub struct Xyzoat {
    /// X, millimetres.
    pub x_mm: f64,
    /// Y, millimetres.
    pub y_mm: f64,
    /// Z, millimetres.
    pub z_mm: f64,
    /// O (first rotation about Z), degrees.
    pub o_deg: f64,
    /// A (rotation about the new Y), degrees.
    pub a_deg: f64,
    /// T (last rotation about the new Z), degrees.
    pub t_deg: f64,
}

impl Xyzoat {
    /// Builds the six values (mm, mm, mm, deg, deg, deg).
    pub const fn new(x_mm: f64, y_mm: f64, z_mm: f64, o_deg: f64, a_deg: f64, t_deg: f64) -> Self {
        Self {
            x_mm,
            y_mm,
            z_mm,
            o_deg,
            a_deg,
            t_deg,
        }
    }

    /// The six values as an array `[X, Y, Z, O, A, T]`.
    pub const fn to_array(&self) -> [f64; 6] {
        [
            self.x_mm, self.y_mm, self.z_mm, self.o_deg, self.a_deg, self.t_deg,
        ]
    }

    /// `true` when all six values are finite.
    pub fn is_finite(&self) -> bool {
        self.to_array().iter().all(|v| v.is_finite())
    }
}

impl std::fmt::Display for Xyzoat {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "X={:.3} Y={:.3} Z={:.3} mm, O={:.3} A={:.3} T={:.3} deg",
            self.x_mm, self.y_mm, self.z_mm, self.o_deg, self.a_deg, self.t_deg
        )
    }
}

impl Default for Pose {
    fn default() -> Self {
        Self::IDENTITY
    }
}

impl Pose {
    /// No translation, no rotation.
    pub const IDENTITY: Pose = Pose(Isometry3 {
        translation: Translation3 {
            vector: Vector3::new(0.0, 0.0, 0.0),
        },
        rotation: UnitQuaternion::new_unchecked(nalgebra::Quaternion::new(1.0, 0.0, 0.0, 0.0)),
    });

    /// A pose from a position (metres) and a rotation.
    pub fn new(position_m: Vector3<f64>, rotation: UnitQuaternion<f64>) -> Self {
        Self(Isometry3::from_parts(position_m.into(), rotation))
    }

    /// A pure translation (metres), no rotation — e.g. a tool point straight out of the flange:
    /// `Pose::from_translation_m(0.0, 0.0, 0.2)`.
    pub fn from_translation_m(x: f64, y: f64, z: f64) -> Self {
        Self(Isometry3::translation(x, y, z))
    }

    /// A pose from a position (metres) and a rotation matrix (re-orthonormalized).
    pub fn from_parts_matrix(position_m: Vector3<f64>, rotation: &Matrix3<f64>) -> Self {
        let r = Rotation3::from_matrix_unchecked(*rotation);
        Self::new(position_m, UnitQuaternion::from_rotation_matrix(&r))
    }

    /// Wraps an isometry.
    pub const fn from_isometry(iso: Isometry3<f64>) -> Self {
        Self(iso)
    }

    /// The underlying isometry.
    pub const fn isometry(&self) -> &Isometry3<f64> {
        &self.0
    }

    /// Position, metres.
    pub fn position_m(&self) -> Vector3<f64> {
        self.0.translation.vector
    }

    /// Orientation.
    pub fn rotation(&self) -> UnitQuaternion<f64> {
        self.0.rotation
    }

    /// Orientation as a 3×3 rotation matrix (columns = the frame's X, Y, Z axes in the parent).
    pub fn rotation_matrix(&self) -> Matrix3<f64> {
        self.0.rotation.to_rotation_matrix().into_inner()
    }

    /// The frame's Z axis (approach direction of a tool) in the parent frame.
    pub fn z_axis(&self) -> Vector3<f64> {
        self.0.rotation * Vector3::z()
    }

    /// The pose turned about its own origin by the smallest rotation that makes its Z axis
    /// parallel to the nearest axis (±X, ±Y, ±Z) of the parent frame (the AS `ALIGN`).
    pub fn aligned(&self) -> Pose {
        let z = self.z_axis();
        let axes = [
            Vector3::x(),
            -Vector3::x(),
            Vector3::y(),
            -Vector3::y(),
            Vector3::z(),
            -Vector3::z(),
        ];
        let mut nearest = axes[0];
        for a in &axes[1..] {
            if a.dot(&z) > nearest.dot(&z) {
                nearest = *a;
            }
        }
        // Never antiparallel (the nearest axis is within 55° of Z), so the rotation is defined.
        let turn =
            UnitQuaternion::rotation_between(&z, &nearest).unwrap_or_else(UnitQuaternion::identity);
        Pose::new(self.position_m(), turn * self.rotation())
    }

    /// Distance between the two positions, metres (orientation ignored).
    pub fn distance_m(&self, other: &Pose) -> f64 {
        (self.position_m() - other.position_m()).norm()
    }

    /// Angle of the rotation between the two orientations, radians in [0, π].
    pub fn angle_to_rad(&self, other: &Pose) -> f64 {
        self.0.rotation.angle_to(&other.0.rotation)
    }

    /// The inverse transformation.
    pub fn inverse(&self) -> Pose {
        Pose(self.0.inverse())
    }

    /// `true` when every component is finite.
    pub fn is_finite(&self) -> bool {
        self.0.translation.vector.iter().all(|v| v.is_finite())
            && self.0.rotation.coords.iter().all(|v| v.is_finite())
    }

    /// From the AS representation (mm and degrees).
    pub fn from_xyzoat(v: Xyzoat) -> Pose {
        let rot = UnitQuaternion::from_axis_angle(&Vector3::z_axis(), v.o_deg.to_radians())
            * UnitQuaternion::from_axis_angle(&Vector3::y_axis(), v.a_deg.to_radians())
            * UnitQuaternion::from_axis_angle(&Vector3::z_axis(), v.t_deg.to_radians());
        Pose::new(Vector3::new(v.x_mm, v.y_mm, v.z_mm) / 1000.0, rot)
    }

    /// To the AS representation (mm and degrees). `A` is in [0, 180], `O` and `T` in
    /// (−180, 180]. When `A` is 0 or 180 (tool Z parallel to base Z) only `O ± T` is defined;
    /// then `O = 0` and `T` carries the whole rotation about Z.
    pub fn to_xyzoat(&self) -> Xyzoat {
        let r = self.rotation_matrix();
        let p = self.position_m() * 1000.0;
        let sin_a = r[(0, 2)].hypot(r[(1, 2)]);
        let a = sin_a.atan2(r[(2, 2)]);
        let (o, t) = if sin_a > EULER_SINGULAR_EPS {
            (r[(1, 2)].atan2(r[(0, 2)]), r[(2, 1)].atan2(-r[(2, 0)]))
        } else if r[(2, 2)] > 0.0 {
            // R = Rz(O + T)
            (0.0, r[(1, 0)].atan2(r[(0, 0)]))
        } else {
            // R = Ry(pi) Rz(T - O)
            (0.0, r[(1, 0)].atan2(r[(1, 1)]))
        };
        Xyzoat {
            x_mm: p.x,
            y_mm: p.y,
            z_mm: p.z,
            o_deg: normalize_deg(o.to_degrees()),
            a_deg: a.to_degrees(),
            t_deg: normalize_deg(t.to_degrees()),
        }
    }
}

/// Maps an angle in degrees to (−180, 180].
fn normalize_deg(v: f64) -> f64 {
    if v <= -180.0 {
        v + 360.0
    } else if v > 180.0 {
        v - 360.0
    } else {
        v
    }
}

impl std::ops::Mul for Pose {
    type Output = Pose;
    fn mul(self, rhs: Pose) -> Pose {
        Pose(self.0 * rhs.0)
    }
}

impl std::ops::Mul<&Pose> for &Pose {
    type Output = Pose;
    fn mul(self, rhs: &Pose) -> Pose {
        Pose(self.0 * rhs.0)
    }
}

impl From<Isometry3<f64>> for Pose {
    fn from(iso: Isometry3<f64>) -> Self {
        Pose(iso)
    }
}

impl From<Pose> for Isometry3<f64> {
    fn from(p: Pose) -> Self {
        p.0
    }
}

impl From<Xyzoat> for Pose {
    fn from(v: Xyzoat) -> Self {
        Pose::from_xyzoat(v)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn aligned_turns_the_z_axis_onto_the_nearest_base_axis_and_keeps_the_position() {
        let p = Pose::from_xyzoat(Xyzoat {
            x_mm: 900.0,
            y_mm: 100.0,
            z_mm: 600.0,
            o_deg: 30.0,
            a_deg: 160.0,
            t_deg: 10.0,
        });
        let a = p.aligned();
        assert!(
            (a.z_axis() - (-Vector3::z())).norm() < 1e-12,
            "{}",
            a.z_axis()
        );
        assert!((a.position_m() - p.position_m()).norm() < 1e-15);
        // The smallest rotation: by the angle between the Z axes (20°).
        assert!((p.angle_to_rad(&a).to_degrees() - 20.0).abs() < 1e-9);
        let side = Pose::from_xyzoat(Xyzoat {
            a_deg: 80.0,
            ..Xyzoat::default()
        });
        assert!((side.aligned().z_axis() - Vector3::x()).norm() < 1e-12);
    }

    #[test]
    fn xyzoat_round_trip_generic() {
        let v = Xyzoat::new(100.0, -250.5, 1200.0, 30.0, 75.0, -120.0);
        let back = Pose::from_xyzoat(v).to_xyzoat();
        for (a, b) in v.to_array().iter().zip(back.to_array()) {
            assert!((a - b).abs() < 1e-9, "{v} vs {back}");
        }
    }

    #[test]
    fn tool_down_is_a_180() {
        let p = Pose::from_xyzoat(Xyzoat::new(0.0, 0.0, 0.0, 0.0, 180.0, 0.0));
        assert!((p.z_axis() - Vector3::new(0.0, 0.0, -1.0)).norm() < 1e-12);
        let back = p.to_xyzoat();
        assert!((back.a_deg - 180.0).abs() < 1e-9);
        // singular: O = 0, T carries O - T... here 0
        assert_eq!(back.o_deg, 0.0);
        assert!(back.t_deg.abs() < 1e-9);
        // A = 180 with O = 30, T = 50 -> same rotation as O = 0, T = 20
        let q = Pose::from_xyzoat(Xyzoat::new(0.0, 0.0, 0.0, 30.0, 180.0, 50.0)).to_xyzoat();
        assert_eq!(q.o_deg, 0.0);
        assert!((q.t_deg - 20.0).abs() < 1e-9, "{q}");
        // A = 0: O + T
        let z = Pose::from_xyzoat(Xyzoat::new(0.0, 0.0, 0.0, 30.0, 0.0, 50.0)).to_xyzoat();
        assert!(z.a_deg.abs() < 1e-9);
        assert!((z.t_deg - 80.0).abs() < 1e-9, "{z}");
    }

    #[test]
    fn distance_and_units() {
        let a = Pose::from_xyzoat(Xyzoat::new(1000.0, 0.0, 0.0, 0.0, 0.0, 0.0));
        let b = Pose::from_translation_m(1.0, 0.003, 0.004);
        assert!((a.distance_m(&b) - 0.005).abs() < 1e-15);
        assert!((a.position_m().x - 1.0).abs() < 1e-15);
        assert_eq!(Pose::default(), Pose::IDENTITY);
        assert!(a.angle_to_rad(&b) < 1e-12);
    }

    #[test]
    fn normalize() {
        assert_eq!(normalize_deg(-180.0), 180.0);
        assert_eq!(normalize_deg(270.0), -90.0);
        assert_eq!(normalize_deg(45.0), 45.0);
    }
}
