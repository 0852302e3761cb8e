//! Typed errors of encoding requests and decoding replies.

use thiserror::Error;

/// A request that must not be sent.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum EncodeError {
    /// A value is NaN or infinite.
    #[error("{field} is {value}, not a finite number; refusing to send it")]
    NonFinite {
        /// Which value.
        field: &'static str,
        /// The offending value.
        value: f64,
    },
    /// A value is too large to be written as a fixed-point AS real.
    #[error("{field} = {value} is beyond ±{limit}; the controller cannot represent it")]
    OutOfRange {
        /// Which value.
        field: &'static str,
        /// The offending value.
        value: f64,
        /// The allowed magnitude.
        limit: f64,
    },
    /// `Command::Other` with a number that the controller reads as a real command (1–7 or
    /// 255): it would act as that command while the client treats it as harmless.
    #[error("command number {number} is a real command; use its Command variant instead of Command::Other")]
    KnownCommandAsOther {
        /// The number as it would be written.
        number: String,
    },
    /// The encoded request would exceed the 255 bytes the controller reads; it would silently
    /// cut the rest.
    #[error("the request is {len} bytes; the controller reads only the first {max} and would silently drop the rest")]
    TooLong {
        /// Encoded length in bytes.
        len: usize,
        /// The limit (255).
        max: usize,
    },
}

/// A reply that cannot be decoded.
#[derive(Debug, Clone, PartialEq, Eq, Error)]
pub enum DecodeError {
    /// Bytes that can never be part of a reply, or a field that is not a number.
    #[error("not a protocol-1040 reply: {reason} at byte {offset}: {excerpt:?}")]
    Garbage {
        /// What is wrong.
        reason: &'static str,
        /// Offset of the offending byte in the input (or in the decoder's buffer).
        offset: usize,
        /// The offending bytes, lossily as text (at most 40 bytes).
        excerpt: String,
    },
    /// The text ended before all 14 fields.
    #[error("incomplete reply: {found} of 14 fields")]
    Incomplete {
        /// Number of fields found.
        found: usize,
    },
    /// More than 14 fields.
    #[error("too many fields: {found} (a reply has 14)")]
    TooManyFields {
        /// Number of fields found.
        found: usize,
    },
    /// A joint field holds asterisks: the angle did not fit the `/F10.3` format.
    #[error("JT{joint} is shown as asterisks (the value does not fit /F10.3)")]
    JointOverflow {
        /// 1-based joint number.
        joint: usize,
    },
    /// A field that must be an integer (fields 1–7) is not.
    #[error("field {field} must be an integer, got {text:?}")]
    NotInteger {
        /// 1-based field number.
        field: usize,
        /// The field's text.
        text: String,
    },
    /// The decoder's buffer holds more bytes than any reply could.
    #[error("{len} bytes received without a complete reply (a reply is about 100 bytes)")]
    Overflow {
        /// Bytes buffered.
        len: usize,
    },
}

/// Quotes at most 40 bytes of `bytes` starting at `offset`, lossily as text.
pub(crate) fn excerpt(bytes: &[u8], offset: usize) -> String {
    let start = offset.min(bytes.len());
    let end = (start + 40).min(bytes.len());
    String::from_utf8_lossy(&bytes[start..end]).into_owned()
}
