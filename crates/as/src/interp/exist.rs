//! `EXISTREAL`, `EXISTCHAR`, `EXISTJOINT`, `EXISTTRANS`, `EXISTPROGRAM`: whether a global
//! variable (any element of it) or a program exists, by its name as a string.

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
}
