//! Incremental reply decoder for a byte stream.
//!
//! There is no terminator in protocol 1040: a reply is complete when its 14 fields have arrived
//! and the last is followed by a blank (the controller's final blank). Feed the decoder whatever
//! the socket returns, split anywhere; it answers "need more" (`Ok(None)`) or yields one
//! complete reply — the same replies however the bytes were split. A reply missing its final
//! blank is taken with [`ReplyDecoder::take_open_reply`] once the peer has gone quiet. Garbage gives an error quoting the offending
//! bytes. The buffer is bounded by [`MAX_BUFFERED`]; the decoder never panics.
//!
//! ```
//! use fs020n_proto::ReplyDecoder;
//! let mut d = ReplyDecoder::new();
//! d.push(b" 1040 0 -1 -1 0 -1 -1    12.500     0.000").unwrap();
//! assert!(d.next_reply().unwrap().is_none());
//! d.push(b"    30.000     0.000     0.000     0.000     0.000 ").unwrap();
//! let reply = d.next_reply().unwrap().unwrap();
//! assert_eq!(reply.status.joints[1], 30.0);
//! assert!(d.is_empty());
//! ```

use crate::error::{excerpt, DecodeError};
use crate::number::{is_f10_3_field, parse_field, F10_OVERFLOW, F10_WIDTH};
use crate::reply::{decode_fixed_layout, is_blank, is_reply_byte, Status, REPLY_FIELDS};

/// Most bytes the decoder holds without a complete reply. A reply is about 100 bytes and the
/// server never sends anything unsolicited, so more than this is a fault of the peer.
pub const MAX_BUFFERED: usize = 1024;

/// One decoded reply and the exact text it was decoded from.
#[derive(Debug, Clone, PartialEq)]
pub struct ReplyFrame {
    /// The decoded status.
    pub status: Status,
    /// The reply's text as received (including its blanks).
    pub text: String,
}

/// Incremental decoder of replies from a byte stream.
#[derive(Debug, Default, Clone)]
pub struct ReplyDecoder {
    buf: Vec<u8>,
}

impl ReplyDecoder {
    /// An empty decoder.
    pub fn new() -> ReplyDecoder {
        ReplyDecoder {
            buf: Vec::with_capacity(256),
        }
    }

    /// Appends received bytes. Fails (and clears the buffer) when more than [`MAX_BUFFERED`]
    /// bytes would be held; call [`next_reply`](Self::next_reply) after every push.
    pub fn push(&mut self, bytes: &[u8]) -> Result<(), DecodeError> {
        let len = self.buf.len() + bytes.len();
        if len > MAX_BUFFERED {
            self.buf.clear();
            return Err(DecodeError::Overflow { len });
        }
        self.buf.extend_from_slice(bytes);
        Ok(())
    }

    /// Bytes held that do not yet form a complete reply.
    pub fn buffered(&self) -> &[u8] {
        &self.buf
    }

    /// `true` when nothing is buffered except blanks.
    pub fn is_empty(&self) -> bool {
        self.buf.iter().all(|&b| is_blank(b))
    }

    /// Drops everything buffered.
    pub fn clear(&mut self) {
        self.buf.clear();
    }

    /// Yields the next complete reply, `Ok(None)` when more bytes are needed, or an error when
    /// the bytes cannot be a reply. After an error the buffer is cleared: a text stream without
    /// terminators cannot be resynchronised reliably, so the connection should be dropped.
    ///
    /// A reply is complete when its last field is followed by a blank (the controller always
    /// sends the final blank in the same write), so the result never depends on how the bytes
    /// were split. A reply whose final blank is missing is recognised by
    /// [`take_open_reply`](Self::take_open_reply) once the peer has gone quiet.
    pub fn next_reply(&mut self) -> Result<Option<ReplyFrame>, DecodeError> {
        self.take(false)
    }

    /// `true` when the buffered bytes end with a whole `/F10.3` field (three decimals, or
    /// asterisks): they may be a complete reply in the controller's fixed layout whose final
    /// blank is missing. Cheap; call it after [`next_reply`](Self::next_reply) gave `Ok(None)`
    /// to decide whether to wait briefly for more bytes and then call
    /// [`take_open_reply`](Self::take_open_reply).
    pub fn may_be_open_reply(&self) -> bool {
        let b = &self.buf;
        b.len() >= F10_WIDTH && is_f10_3_field(&b[b.len() - F10_WIDTH..])
    }

    /// Like [`next_reply`](Self::next_reply), but also takes a reply in the controller's
    /// fixed layout that ends at the end of the buffer without its final blank (seven
    /// integers, then seven 10-character fields, the last a whole `/F10.3` field). Call it
    /// only when the peer has sent nothing more for a while: a number that goes on
    /// (`"     0.000"` then `"1"`) would otherwise be cut.
    ///
    /// ```
    /// use fs020n_proto::ReplyDecoder;
    /// let mut d = ReplyDecoder::new();
    /// d.push(b" 1040 0 -1 -1 0 -1 -1    12.500     0.000    30.000     0.000     0.000     0.000     0.000").unwrap();
    /// assert!(d.next_reply().unwrap().is_none(), "the final blank is missing");
    /// assert!(d.may_be_open_reply());
    /// let reply = d.take_open_reply().unwrap().unwrap();
    /// assert_eq!(reply.status.joints[1], 30.0);
    /// ```
    pub fn take_open_reply(&mut self) -> Result<Option<ReplyFrame>, DecodeError> {
        self.take(true)
    }

    fn take(&mut self, open_end: bool) -> Result<Option<ReplyFrame>, DecodeError> {
        let (end, decoded) = match find_reply(&self.buf, open_end) {
            Ok(Some(found)) => found,
            Ok(None) => return Ok(None),
            Err(e) => {
                self.buf.clear();
                return Err(e);
            }
        };
        match decoded {
            Ok(status) => {
                // Only reply bytes (ASCII) were accepted, so the text is exact.
                let text = std::str::from_utf8(&self.buf[..end])
                    .map(str::to_owned)
                    .unwrap_or_default();
                self.buf.drain(..end);
                Ok(Some(ReplyFrame { status, text }))
            }
            Err(e) => {
                self.buf.clear();
                Err(e)
            }
        }
    }
}

/// `true` when a decoding attempt found all 14 fields: either it succeeded or it failed only
/// on their values (asterisks in a joint, a non-integer in fields 1–7). Such a reply is
/// complete and must be reported (as an error), not waited on: more bytes cannot repair it.
fn structurally_complete(result: &Result<Status, DecodeError>) -> bool {
    matches!(
        result,
        Ok(_) | Err(DecodeError::JointOverflow { .. } | DecodeError::NotInteger { .. })
    )
}

/// Blank-separated tokens looked at: 14 fields and one more.
const MAX_TOKENS: usize = REPLY_FIELDS + 1;

/// Finds the first complete reply in `b`: where it ends (exclusive, including the one blank that
/// ends it) and its decoding; `None` if it is not complete yet.
///
/// A reply ends at the end of a field (a non-blank followed by a blank, or the end of the
/// buffer). The candidates are taken in order; the first that decodes — or holds 14 fields whose
/// values are invalid (asterisks in a joint, a non-integer in fields 1–7) — is the reply. A
/// candidate before the 14th blank-separated field can only be the controller's fixed layout
/// with touching fields, and only if it leaves room for seven integers and 70 characters, so the
/// usual reply is decoded once. An unterminated last field may go on (`"     0.000"`, then
/// `"1"`), and taking it early would decode differently from the same bytes received in one
/// read; so a candidate must be followed by a blank, except with `open_end` (the peer has gone
/// quiet): then the fixed layout ending at the end of the buffer counts too, when its last 10
/// characters are a whole `/F10.3` field (three decimals, or asterisks).
///
/// Errors are reported as soon as they are certain: a byte no reply contains, one of the six
/// leading fields (always blank-separated) that is not a number, or 14 blank-separated fields
/// that still do not form a reply.
#[allow(clippy::type_complexity)]
fn find_reply(
    b: &[u8],
    open_end: bool,
) -> Result<Option<(usize, Result<Status, DecodeError>)>, DecodeError> {
    if let Some(pos) = b.iter().position(|&c| !is_reply_byte(c)) {
        return Err(DecodeError::Garbage {
            reason: "unexpected byte",
            offset: pos,
            excerpt: excerpt(b, pos),
        });
    }
    // One pass over the tokens.
    let mut spans = [(0usize, 0usize); MAX_TOKENS];
    let mut n = 0;
    let mut i = 0;
    while i < b.len() && n < MAX_TOKENS {
        while i < b.len() && is_blank(b[i]) {
            i += 1;
        }
        if i == b.len() {
            break;
        }
        let start = i;
        while i < b.len() && !is_blank(b[i]) {
            i += 1;
        }
        spans[n] = (start, i);
        n += 1;
    }
    // Only reply bytes (ASCII) reach here, so every slice is valid text.
    let text = |from: usize, to: usize| std::str::from_utf8(&b[from..to]).unwrap_or_default();
    let terminated = |k: usize| spans[k].1 < b.len();
    let garbage = |at: usize, reason: &'static str| DecodeError::Garbage {
        reason,
        offset: at,
        excerpt: excerpt(b, at),
    };
    // Seven integers (the sixth ends at spans[5]) and 70 characters of fixed-width fields.
    let fixed_min_end = if n > 5 {
        spans[5].1 + 2 + 7 * F10_WIDTH
    } else {
        usize::MAX
    };
    for (k, &(_, end)) in spans.iter().enumerate().take(n.min(REPLY_FIELDS)).skip(6) {
        let decoded = if k == REPLY_FIELDS - 1 && terminated(k) {
            Status::decode(text(0, end))
        } else if end >= fixed_min_end
            && (terminated(k) || (open_end && is_f10_3_field(&b[end - F10_WIDTH..end])))
        {
            decode_fixed_layout(text(0, end))
        } else {
            continue;
        };
        if structurally_complete(&decoded) {
            let consumed = if terminated(k) { end + 1 } else { end };
            return Ok(Some((consumed, decoded)));
        }
    }
    // No reply yet. The six leading fields are always blank-separated: one that is complete but
    // not a number is garbage now. (A reply found above has valid ones.)
    for (k, &(start, end)) in spans.iter().enumerate().take(n.min(6)) {
        if terminated(k) && parse_field(text(start, end)).is_none() {
            return Err(garbage(start, "field is not a number"));
        }
    }
    if n >= REPLY_FIELDS && terminated(REPLY_FIELDS - 1) {
        let bad = spans[6..REPLY_FIELDS].iter().find(|(s, e)| {
            let t = text(*s, *e);
            t != F10_OVERFLOW && parse_field(t).is_none()
        });
        return Err(match bad {
            Some((at, _)) => garbage(*at, "field is not a number"),
            None => garbage(0, "14 fields that do not form a reply"),
        });
    }
    Ok(None)
}

#[cfg(test)]
mod tests {
    use super::*;

    const EXACT: &str =
        " 1040 0 -1 -1 0 -1 -1    12.500     0.000    30.000     0.000     0.000     0.000     0.000 ";

    #[test]
    fn byte_by_byte() {
        let mut d = ReplyDecoder::new();
        let mut got = None;
        for (k, b) in EXACT.bytes().enumerate() {
            d.push(&[b]).unwrap();
            if let Some(f) = d.next_reply().unwrap() {
                got = Some((k, f));
            }
        }
        let (k, f) = got.expect("a reply");
        // Complete at the final blank: until then the last number might go on.
        assert_eq!(k, EXACT.len() - 1);
        assert_eq!(f.status.timer.seconds(), Some(12.5));
        assert!(d.is_empty());
    }

    #[test]
    fn two_replies_in_one_read() {
        let mut d = ReplyDecoder::new();
        d.push(format!("{EXACT}{EXACT}").as_bytes()).unwrap();
        assert!(d.next_reply().unwrap().is_some());
        assert!(d.next_reply().unwrap().is_some());
        assert!(d.next_reply().unwrap().is_none());
    }

    #[test]
    fn garbage_is_quoted() {
        let mut d = ReplyDecoder::new();
        d.push(b" 1040 0 -1 oops").unwrap();
        match d.next_reply() {
            Err(DecodeError::Garbage {
                offset, excerpt, ..
            }) => {
                assert_eq!(offset, 11);
                assert_eq!(excerpt, "oops");
            }
            other => panic!("{other:?}"),
        }
        assert!(d.buffered().is_empty());
    }

    #[test]
    fn bounded_buffer() {
        let mut d = ReplyDecoder::new();
        let blanks = vec![b' '; MAX_BUFFERED];
        d.push(&blanks).unwrap();
        assert!(matches!(d.push(b" "), Err(DecodeError::Overflow { .. })));
    }

    /// Found by the mutation fuzz test: a blank inserted before the last field (which touched
    /// its neighbour) made its 10-character window `"      0.00"` at a chunk boundary. Taken
    /// there, it decoded as 0.00 while the same bytes in one read decode as 0.001.
    #[test]
    fn a_padded_short_last_field_waits_for_more() {
        let text = "1040 0 0 0 0 0 0     0.000     0.000     0.000     0.000 99999.999     0.000      0.001  ";
        let whole = Status::decode(text).unwrap();
        assert_eq!(whole.joints[5], 0.001);
        for cut in 0..=text.len() {
            let mut d = ReplyDecoder::new();
            let mut got = Vec::new();
            for chunk in [&text[..cut], &text[cut..]] {
                d.push(chunk.as_bytes()).unwrap();
                while let Some(f) = d.next_reply().unwrap() {
                    got.push(f.status);
                }
            }
            assert_eq!(got, vec![whole.clone()], "cut at {cut}");
            assert!(d.is_empty());
        }
    }

    /// Found by the mutation fuzz test: a whole `/F10.3` field followed by one more digit. Cut
    /// after the 10th character it looked complete (-0.000); it is -0.0001.
    #[test]
    fn a_number_that_goes_on_after_ten_characters() {
        let text = " 100000 -100000000 0 -1 0 -1 -1     0.000     0.000     0.000     0.000     0.000     0.000    -0.0001 ";
        let cut = text.len() - 2;
        let mut d = ReplyDecoder::new();
        d.push(&text.as_bytes()[..cut]).unwrap();
        assert!(d.next_reply().unwrap().is_none());
        d.push(&text.as_bytes()[cut..]).unwrap();
        let f = d.next_reply().unwrap().unwrap();
        assert_eq!(f.status, Status::decode(text).unwrap());
        assert_eq!(f.status.joints[5], -0.0001);
    }

    #[test]
    fn touching_fields_and_short_format() {
        let mut d = ReplyDecoder::new();
        d.push(b"1040 0 -1 -1 0 -1 -1 100000.000-12345.678     0.000     0.000     0.000     0.000     0.000").unwrap();
        assert!(d.next_reply().unwrap().is_none(), "no final blank yet");
        assert!(d.may_be_open_reply());
        let f = d.take_open_reply().unwrap().unwrap();
        assert_eq!(f.status.timer.seconds(), Some(100000.0));
        assert_eq!(f.status.joints[0], -12345.678);
        d.push(b"1040 0 0 0 0 0 0 1 2 3 4 5 6 7").unwrap();
        assert!(
            d.next_reply().unwrap().is_none(),
            "the last field may go on"
        );
        assert!(!d.may_be_open_reply());
        assert!(
            d.take_open_reply().unwrap().is_none(),
            "not the fixed layout"
        );
        d.push(b" ").unwrap();
        assert_eq!(d.next_reply().unwrap().unwrap().status.joints[5], 7.0);
    }
}
