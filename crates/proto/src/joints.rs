//! Joint vectors with an explicit unit.
//!
//! The protocol carries joint angles in **degrees**. Internally (kinematics) radians are
//! handy, so both exist as distinct types and the only way between them is an explicit
//! conversion ([`JointsDeg::to_rad`], [`JointsRad::to_deg`]).

/// Number of joints of the FS020N.
pub const JOINT_COUNT: usize = 6;

macro_rules! joint_vector {
    ($(#[$meta:meta])* $name:ident, $unit:literal) => {
        $(#[$meta])*
        #[derive(Debug, Clone, Copy, PartialEq, Default)]
        #[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
        #[cfg_attr(feature = "serde", serde(transparent))]
        pub struct $name(pub [f64; JOINT_COUNT]);

        impl $name {
            /// All six joints at zero.
            pub const ZERO: Self = Self([0.0; JOINT_COUNT]);

            #[doc = concat!("Builds a joint vector from six values in ", $unit, ".")]
            pub const fn new(values: [f64; JOINT_COUNT]) -> Self {
                Self(values)
            }

            #[doc = concat!("The six values in ", $unit, ".")]
            pub const fn values(&self) -> [f64; JOINT_COUNT] {
                self.0
            }

            /// Iterates over the six values.
            pub fn iter(&self) -> impl Iterator<Item = f64> + '_ {
                self.0.iter().copied()
            }

            /// `true` when every value is finite (no NaN, no infinity).
            pub fn is_finite(&self) -> bool {
                self.0.iter().all(|v| v.is_finite())
            }

            /// The largest absolute per-joint difference to `other`, in the same unit.
            pub fn max_abs_diff(&self, other: &Self) -> f64 {
                self.0
                    .iter()
                    .zip(other.0.iter())
                    .map(|(a, b)| (a - b).abs())
                    .fold(0.0, f64::max)
            }

            /// Applies `f` to each joint value.
            pub fn map(&self, mut f: impl FnMut(f64) -> f64) -> Self {
                Self(self.0.map(|v| f(v)))
            }

            /// Combines two joint vectors element by element.
            pub fn zip_with(&self, other: &Self, mut f: impl FnMut(f64, f64) -> f64) -> Self {
                let mut out = [0.0; JOINT_COUNT];
                for (i, o) in out.iter_mut().enumerate() {
                    *o = f(self.0[i], other.0[i]);
                }
                Self(out)
            }
        }

        impl From<[f64; JOINT_COUNT]> for $name {
            fn from(values: [f64; JOINT_COUNT]) -> Self {
                Self(values)
            }
        }

        impl std::ops::Index<usize> for $name {
            type Output = f64;
            fn index(&self, index: usize) -> &f64 {
                &self.0[index]
            }
        }

        impl std::ops::IndexMut<usize> for $name {
            fn index_mut(&mut self, index: usize) -> &mut f64 {
                &mut self.0[index]
            }
        }
    };
}

joint_vector!(
    /// Six joint angles (JT1..JT6) in **degrees** — the unit of the wire protocol and the pendant.
    ///
    /// ```
    /// use fs020n_proto::JointsDeg;
    /// let home = JointsDeg::new([0.0, 0.0, -90.0, 0.0, -90.0, 0.0]);
    /// assert!((home.to_rad()[2] + std::f64::consts::FRAC_PI_2).abs() < 1e-12);
    /// ```
    JointsDeg,
    "degrees"
);

joint_vector!(
    /// Six joint angles (JT1..JT6) in **radians**, for kinematics.
    JointsRad,
    "radians"
);

impl JointsDeg {
    /// Converts to radians.
    pub fn to_rad(&self) -> JointsRad {
        JointsRad(self.0.map(f64::to_radians))
    }
}

impl JointsRad {
    /// Converts to degrees.
    pub fn to_deg(&self) -> JointsDeg {
        JointsDeg(self.0.map(f64::to_degrees))
    }
}

impl std::fmt::Display for JointsDeg {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "[")?;
        for (i, v) in self.0.iter().enumerate() {
            if i > 0 {
                write!(f, ", ")?;
            }
            write!(f, "{v:.3}")?;
        }
        write!(f, "] deg")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn conversions_round_trip() {
        let d = JointsDeg::new([10.0, -20.0, 30.5, 180.0, -90.0, 360.0]);
        let back = d.to_rad().to_deg();
        assert!(d.max_abs_diff(&back) < 1e-12);
        assert!((d.to_rad()[3] - std::f64::consts::PI).abs() < 1e-15);
    }

    #[test]
    fn finiteness_and_diff() {
        let mut d = JointsDeg::ZERO;
        assert!(d.is_finite());
        d[4] = f64::NAN;
        assert!(!d.is_finite());
        let a = JointsDeg::new([1.0, 2.0, 3.0, 4.0, 5.0, 6.0]);
        let b = JointsDeg::new([1.0, 2.5, 3.0, 1.0, 5.0, 6.0]);
        assert_eq!(a.max_abs_diff(&b), 3.0);
        assert_eq!(
            format!("{}", JointsDeg::ZERO),
            "[0.000, 0.000, 0.000, 0.000, 0.000, 0.000] deg"
        );
    }
}
