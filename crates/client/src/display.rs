//! Formatting shared by the messages of the crate (a leaf module).

use std::time::Duration;

/// A duration for messages, rounded: `"250 ms"`, `"10.0 s"`.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Rounded(pub(crate) Duration);

impl std::fmt::Display for Rounded {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let s = self.0.as_secs_f64();
        if s < 1.0 {
            write!(f, "{:.0} ms", s * 1e3)
        } else {
            write!(f, "{s:.1} s")
        }
    }
}
