//! `LIST/R`, `LIST/INT`, `LIST/L`, `LIST/S` at the terminal (AS-E p.5-18): the global
//! variables and the values the programs hold now, one data-section line each — the form the
//! controller's saves carry (`x = 5`, `p[1] 100 0 600 0 180 0`, `#j 0 -30 …`, `$s "text"`).

use crate::compile::Ty;
use crate::value::Var;

use super::Interpreter;

/// Which variables `LIST` shows.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ListKind {
    /// `LIST/R`: real variables.
    Reals,
    /// `LIST/INT`: integer variables (`@name`).
    Integers,
    /// `LIST/L`: pose variables, transformations then joint points.
    Poses,
    /// `LIST/S`: string variables.
    Strings,
}

/// `name` or `name[1,2]`.
fn element(name: &str, idx: &[i32]) -> String {
    if idx.is_empty() {
        return name.to_owned();
    }
    let idx: Vec<String> = idx.iter().map(i32::to_string).collect();
    format!("{name}[{}]", idx.join(","))
}

/// Every value of a variable, the scalar first, then the elements by index.
fn values<T: Clone>(v: &Var<T>) -> Vec<(Vec<i32>, T)> {
    let mut out: Vec<(Vec<i32>, T)> = v.scalar.iter().map(|x| (Vec::new(), x.clone())).collect();
    out.extend(v.elements());
    out
}

fn six(v: &[f32; 6]) -> String {
    v.iter().map(f32::to_string).collect::<Vec<_>>().join(" ")
}

impl Interpreter {
    /// The lines `LIST/R` (…) shows for `kind`: every global variable holding a value, by
    /// name, or only those `names` gives (case ignored; an array shows all its elements).
    pub fn list_lines(&self, kind: ListKind, names: &[&str]) -> Vec<String> {
        let wanted = |name: &str| {
            names.is_empty()
                || names.iter().any(|n| {
                    let n = n.trim().to_ascii_lowercase();
                    let n = n.trim_start_matches(['#', '$']);
                    n == name
                })
        };
        let mut out = Vec::new();
        let each = |ty: Ty, f: &mut dyn FnMut(&str, usize)| {
            let mut slots: Vec<(usize, &String)> =
                self.code.globals[ty as usize].iter().enumerate().collect();
            slots.sort_by(|a, b| a.1.cmp(b.1));
            for (slot, name) in slots {
                if wanted(name) {
                    f(name, slot);
                }
            }
        };
        let g = &self.globals;
        match kind {
            ListKind::Reals | ListKind::Integers => each(Ty::Real, &mut |name, slot| {
                if name.starts_with('@') != (kind == ListKind::Integers) {
                    return;
                }
                for (idx, v) in g.reals.get(slot).map(values).unwrap_or_default() {
                    out.push(format!("{} = {v}", element(name, &idx)));
                }
            }),
            ListKind::Poses => {
                each(Ty::Trans, &mut |name, slot| {
                    for (idx, v) in g.trans.get(slot).map(values).unwrap_or_default() {
                        out.push(format!("{} {}", element(name, &idx), six(&v)));
                    }
                });
                each(Ty::Joint, &mut |name, slot| {
                    for (idx, v) in g.joints.get(slot).map(values).unwrap_or_default() {
                        out.push(format!("#{} {}", element(name, &idx), six(&v)));
                    }
                });
            }
            ListKind::Strings => each(Ty::Str, &mut |name, slot| {
                for (idx, v) in g.strs.get(slot).map(values).unwrap_or_default() {
                    let text = String::from_utf8_lossy(&v);
                    out.push(format!("${} \"{text}\"", element(name, &idx)));
                }
            }),
        }
        out
    }
}
