//! # fs020n-proto
//!
//! The sans-IO core of protocol 1040, the TCP text protocol spoken by the AS server program on a
//! Kawasaki FS020N controller. No sockets, no clocks: only types, exact encoders and tolerant
//! decoders.
#![forbid(unsafe_code)]
#![warn(missing_docs)]

pub mod joints;

pub use joints::{JointsDeg, JointsRad, JOINT_COUNT};
