//! Variable storage: scalars and sparse arrays of up to 3 dimensions whose elements exist once
//! assigned (reading one that was never assigned is E0102, like any undefined variable).

use std::collections::HashMap;
use std::hash::{BuildHasherDefault, Hasher};
use std::sync::Arc;

/// An AS string: bytes (ASCII on the controller; the network may deliver any byte), as a
/// shared buffer and a range of it, so that cutting a string (`$DECODE`, `$MID`, `$LEFT`,
/// `$RIGHT`) never copies it.
#[derive(Clone)]
pub(crate) struct Bytes {
    buf: Arc<[u8]>,
    start: u32,
    end: u32,
}

impl Bytes {
    /// The length in bytes (without slicing the buffer).
    #[inline]
    pub(crate) fn len(&self) -> usize {
        (self.end - self.start) as usize
    }

    /// The bytes `a..b` of this string (clamped).
    pub(crate) fn slice(&self, a: usize, b: usize) -> Bytes {
        let len = self.len();
        let b = b.min(len);
        let a = a.min(b);
        Bytes {
            buf: Arc::clone(&self.buf),
            start: self.start + a as u32,
            end: self.start + b as u32,
        }
    }
}

impl Bytes {
    /// The bytes before `cut` and from `cut` on (clamped), the second reusing this handle.
    pub(crate) fn split_off_head(self, cut: usize) -> (Bytes, Bytes) {
        let head = self.slice(0, cut);
        let cut = cut.min(self.len()) as u32;
        let rest = Bytes {
            start: self.start + cut,
            ..self
        };
        (head, rest)
    }
}

impl std::ops::Deref for Bytes {
    type Target = [u8];
    fn deref(&self) -> &[u8] {
        &self.buf[self.start as usize..self.end as usize]
    }
}

impl From<&[u8]> for Bytes {
    fn from(v: &[u8]) -> Bytes {
        Bytes {
            end: v.len() as u32,
            buf: Arc::from(v),
            start: 0,
        }
    }
}

impl From<Vec<u8>> for Bytes {
    fn from(v: Vec<u8>) -> Bytes {
        Bytes {
            end: v.len() as u32,
            buf: Arc::from(v),
            start: 0,
        }
    }
}

impl PartialEq for Bytes {
    fn eq(&self, other: &Bytes) -> bool {
        **self == **other
    }
}

impl std::fmt::Debug for Bytes {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{:?}", String::from_utf8_lossy(self))
    }
}

/// Largest array index in each dimension.
pub(crate) const MAX_INDEX: i32 = 9999;

/// Most array elements the whole interpreter holds (a runaway loop that fills arrays stops
/// with P1031 instead of exhausting memory).
pub(crate) const MAX_ELEMENTS: usize = 200_000;

/// A multiplicative hasher for packed array indices (fast, deterministic, good enough for
/// small integer keys).
#[derive(Default, Clone, Copy)]
pub(crate) struct IndexHasher(u64);

impl Hasher for IndexHasher {
    fn finish(&self) -> u64 {
        self.0
    }

    fn write(&mut self, bytes: &[u8]) {
        for &b in bytes {
            self.0 = (self.0.rotate_left(5) ^ u64::from(b)).wrapping_mul(0x9E37_79B9_7F4A_7C15);
        }
    }

    fn write_u64(&mut self, v: u64) {
        self.0 = (v ^ (v >> 29)).wrapping_mul(0x9E37_79B9_7F4A_7C15);
    }
}

type IndexMap<T> = HashMap<u64, T, BuildHasherDefault<IndexHasher>>;

/// Packs up to 3 indices (each 0..=9999) into one key.
pub(crate) fn pack(idx: &[i32]) -> u64 {
    let mut key = 0u64;
    for (k, &i) in idx.iter().enumerate() {
        key |= (i as u64 & 0xFFFF) << (16 * k);
    }
    key | ((idx.len() as u64) << 48)
}

/// The indices of a packed key.
pub(crate) fn unpack(key: u64) -> Vec<i32> {
    let n = ((key >> 48) & 0xF) as usize;
    (0..n.min(3))
        .map(|k| ((key >> (16 * k)) & 0xFFFF) as i32)
        .collect()
}

/// Dense storage for the common small indices: 1-D below this index…
const DENSE1: i32 = 1024;
/// …and 2-D with the first index below this and the second below [`DENSE2_COLS`].
const DENSE2_ROWS: i32 = 32;
const DENSE2_COLS: i32 = 256;

fn dense_slot(idx: &[i32]) -> Option<(bool, usize)> {
    match *idx {
        [i] if (0..DENSE1).contains(&i) => Some((false, i as usize)),
        [r, c] if (0..DENSE2_ROWS).contains(&r) && (0..DENSE2_COLS).contains(&c) => {
            Some((true, (r * DENSE2_COLS + c) as usize))
        }
        _ => None,
    }
}

/// One variable: its scalar value and its array elements (small 1-D and 2-D indices in dense
/// vectors, the others in a map).
#[derive(Debug, Clone)]
pub(crate) struct Var<T> {
    pub(crate) scalar: Option<T>,
    dense1: Vec<Option<T>>,
    dense2: Vec<Option<T>>,
    array: Option<Box<IndexMap<T>>>,
}

impl<T> Default for Var<T> {
    fn default() -> Self {
        Var {
            scalar: None,
            dense1: Vec::new(),
            dense2: Vec::new(),
            array: None,
        }
    }
}

impl<T> Var<T> {
    pub(crate) fn element_count(&self) -> usize {
        self.dense1.iter().filter(|v| v.is_some()).count()
            + self.dense2.iter().filter(|v| v.is_some()).count()
            + self.array.as_ref().map_or(0, |a| a.len())
    }
}

impl<T: Clone> Var<T> {
    pub(crate) fn get(&self, idx: &[i32]) -> Option<&T> {
        if idx.is_empty() {
            return self.scalar.as_ref();
        }
        match dense_slot(idx) {
            Some((false, k)) => self.dense1.get(k)?.as_ref(),
            Some((true, k)) => self.dense2.get(k)?.as_ref(),
            None => self.array.as_ref()?.get(&pack(idx)),
        }
    }

    /// Sets a value; `true` when a new array element was created.
    pub(crate) fn set(&mut self, idx: &[i32], v: T) -> bool {
        if idx.is_empty() {
            self.scalar = Some(v);
            return false;
        }
        let dense = match dense_slot(idx) {
            Some((false, k)) => Some((&mut self.dense1, k)),
            Some((true, k)) => Some((&mut self.dense2, k)),
            None => None,
        };
        match dense {
            Some((vec, k)) => {
                if vec.len() <= k {
                    vec.resize_with(k + 1, || None);
                }
                vec[k].replace(v).is_none()
            }
            None => self
                .array
                .get_or_insert_with(Default::default)
                .insert(pack(idx), v)
                .is_none(),
        }
    }

    /// Every element, sorted by index (for dumps).
    pub(crate) fn elements(&self) -> Vec<(Vec<i32>, T)> {
        let mut v: Vec<(u64, T)> = self
            .array
            .as_ref()
            .map(|a| a.iter().map(|(k, v)| (*k, v.clone())).collect())
            .unwrap_or_default();
        for (k, x) in self.dense1.iter().enumerate() {
            if let Some(x) = x {
                v.push((pack(&[k as i32]), x.clone()));
            }
        }
        for (k, x) in self.dense2.iter().enumerate() {
            if let Some(x) = x {
                let k = k as i32;
                v.push((pack(&[k / DENSE2_COLS, k % DENSE2_COLS]), x.clone()));
            }
        }
        v.sort_by_key(|(k, _)| {
            (
                ((k >> 48) & 0xF),
                k & 0xFFFF,
                (k >> 16) & 0xFFFF,
                (k >> 32) & 0xFFFF,
            )
        });
        v.into_iter().map(|(k, t)| (unpack(k), t)).collect()
    }
}

/// The variables of one scope (the globals, or one program's locals in one task), by type.
#[derive(Debug, Clone, Default)]
pub(crate) struct Store {
    pub(crate) reals: Vec<Var<f32>>,
    pub(crate) strs: Vec<Var<Bytes>>,
    pub(crate) joints: Vec<Var<[f32; 6]>>,
    pub(crate) trans: Vec<Var<[f32; 6]>>,
}

impl Store {
    pub(crate) fn with_sizes(sizes: [usize; 4]) -> Store {
        Store {
            reals: (0..sizes[0]).map(|_| Var::default()).collect(),
            strs: (0..sizes[1]).map(|_| Var::default()).collect(),
            joints: (0..sizes[2]).map(|_| Var::default()).collect(),
            trans: (0..sizes[3]).map(|_| Var::default()).collect(),
        }
    }

    /// Makes room for at least `sizes` variables of each type (variables a typed statement
    /// named first); the variables held are kept.
    pub(crate) fn grow_to(&mut self, sizes: [usize; 4]) {
        fn grow<T>(v: &mut Vec<Var<T>>, n: usize)
        where
            Var<T>: Default,
        {
            while v.len() < n {
                v.push(Var::default());
            }
        }
        grow(&mut self.reals, sizes[0]);
        grow(&mut self.strs, sizes[1]);
        grow(&mut self.joints, sizes[2]);
        grow(&mut self.trans, sizes[3]);
    }

    /// Array elements held (for the interpreter's memory limit).
    pub(crate) fn element_count(&self) -> usize {
        self.reals.iter().map(Var::element_count).sum::<usize>()
            + self.strs.iter().map(Var::element_count).sum::<usize>()
            + self.joints.iter().map(Var::element_count).sum::<usize>()
            + self.trans.iter().map(Var::element_count).sum::<usize>()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sparse_arrays() {
        let mut v: Var<f32> = Var::default();
        assert!(v.get(&[]).is_none());
        assert!(v.get(&[1]).is_none());
        assert!(v.set(&[1], 2.0));
        assert!(!v.set(&[1], 3.0));
        assert!(v.set(&[1, 0], 4.0));
        assert_eq!(v.get(&[1]), Some(&3.0));
        assert_eq!(v.get(&[1, 0]), Some(&4.0));
        assert!(v.get(&[0]).is_none());
        v.set(&[9999, 9999, 9999], 1.0);
        assert_eq!(v.elements().len(), 3);
        assert_eq!(unpack(pack(&[9999, 5, 7])), vec![9999, 5, 7]);
        assert_eq!(v.elements()[0].0, vec![1]);
    }
}
