//! `EXISTREAL`, `EXISTINTEGER`, `EXISTCHAR`, `EXISTJOINT`, `EXISTTRANS`, `EXISTPROGRAM`:
//! whether a global variable (any element of it) or a program exists, by its name as a
//! string; `MAXINDEX`/`MININDEX`: the indices an array uses.

use crate::compile::{Exist, Ty};

use super::arith::as_bool;
use super::Interpreter;

impl Interpreter {
    /// −1 when `name` (case ignored; a leading `$` or `#` and blanks around it allowed) names
    /// a global of that type holding a value or any element, or a loaded program; else 0.
    pub(super) fn exists(&self, kind: Exist, name: &[u8]) -> f32 {
        let name = String::from_utf8_lossy(name).trim().to_ascii_lowercase();
        let ty = match kind {
            Exist::Program => return as_bool(self.code.defined(&name).is_some()),
            Exist::Real => Ty::Real,
            // `@name`: the integer variable, a real of that name here.
            Exist::Integer if name.starts_with('@') => Ty::Real,
            Exist::Integer => return 0.0,
            Exist::Char => Ty::Str,
            Exist::Joint => Ty::Joint,
            Exist::Trans => Ty::Trans,
        };
        let bare = match ty {
            Ty::Str => name.strip_prefix('$').unwrap_or(&name),
            Ty::Joint => name.strip_prefix('#').unwrap_or(&name),
            _ => &name,
        };
        let Some(s) = self.global_slot(ty, bare) else {
            return 0.0;
        };
        let g = &self.globals;
        as_bool(match ty {
            Ty::Real => g
                .reals
                .get(s)
                .is_some_and(|v| v.scalar.is_some() || v.element_count() > 0),
            Ty::Str => g
                .strs
                .get(s)
                .is_some_and(|v| v.scalar.is_some() || v.element_count() > 0),
            Ty::Joint => g
                .joints
                .get(s)
                .is_some_and(|v| v.scalar.is_some() || v.element_count() > 0),
            Ty::Trans => g
                .trans
                .get(s)
                .is_some_and(|v| v.scalar.is_some() || v.element_count() > 0),
        })
    }

    /// `MAXINDEX($name, dim)` (`max`) / `MININDEX` (AS-E p.9-16): the largest / smallest
    /// index in dimension `dim` (1–3) of the global array `name` (`#p` joints, `$s` strings,
    /// `@i` integers, else reals, then transformations); −1 when the variable is no array
    /// (no element has that dimension), −2 when it is not defined.
    pub(super) fn array_index(&self, max: bool, name: &[u8], dim: usize) -> f32 {
        let name = String::from_utf8_lossy(name).trim().to_ascii_lowercase();
        let kinds: &[(Ty, &str)] = if let Some(n) = name.strip_prefix('#') {
            &[(Ty::Joint, n)]
        } else if let Some(n) = name.strip_prefix('$') {
            &[(Ty::Str, n)]
        } else {
            &[(Ty::Real, name.as_str()), (Ty::Trans, name.as_str())]
        };
        let g = &self.globals;
        for &(ty, bare) in kinds {
            let Some(s) = self.global_slot(ty, bare) else {
                continue;
            };
            let (scalar, indices): (bool, Vec<Vec<i32>>) = match ty {
                Ty::Real => g
                    .reals
                    .get(s)
                    .map(|v| (v.scalar.is_some(), keys(v.elements()))),
                Ty::Str => g
                    .strs
                    .get(s)
                    .map(|v| (v.scalar.is_some(), keys(v.elements()))),
                Ty::Joint => g
                    .joints
                    .get(s)
                    .map(|v| (v.scalar.is_some(), keys(v.elements()))),
                Ty::Trans => g
                    .trans
                    .get(s)
                    .map(|v| (v.scalar.is_some(), keys(v.elements()))),
            }
            .unwrap_or_default();
            if !scalar && indices.is_empty() {
                continue;
            }
            let used = indices.iter().filter_map(|k| k.get(dim - 1).copied());
            let found = if max { used.max() } else { used.min() };
            return found.map_or(-1.0, |k| k as f32);
        }
        -2.0
    }
}

/// The indices of a variable's elements.
fn keys<T>(elements: Vec<(Vec<i32>, T)>) -> Vec<Vec<i32>> {
    elements.into_iter().map(|(k, _)| k).collect()
}
