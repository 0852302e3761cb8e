//! Service replies held until the requester's reply reader is matched, as rmw_fastrtps answers:
//! a ROS 2 client on Fast DDS names its reply reader in every request (the related sample
//! identity's writer GUID, under the "enhanced" service mapping), and a reply written before the
//! server has discovered that reader is lost — its reply topic is volatile. A client that calls
//! right after discovering the service would wait for that reply forever.
//!
//! | input | here |
//! |---|---|
//! | a reply to send, with the GUID the request named | [`ReplyGate::handle_reply`]: out at once when that GUID is no reader (the Cyclone mapping, or a client that names only its request writer) or a known one; else held |
//! | the readers discovered so far, on every poll | [`ReplyGate::poll_released`]: the held replies whose reader is known now, and those that waited [`ReplyGate::new`]'s `wait` (sent anyway: the reader may exist on a path discovery has not reported) |
//! | when to poll next | [`ReplyGate::poll_timeout`] |
//!
//! Generic over the reply `R`; the "known reader" test is a closure and time is passed in
//! (`Instant`), so that it is tested without DDS, on virtual time.

use std::time::Duration;

use tokio::time::Instant;

/// How long a reply waits for its reader by default before it is sent anyway.
pub const DEFAULT_READER_WAIT: Duration = Duration::from_secs(5);

/// A DDS GUID: a 12-byte participant prefix and a 4-byte entity id whose last byte is the
/// entity kind.
pub type Guid = [u8; 16];

/// `true` when the GUID names a DDS reader: the RTPS entity kinds of readers (user 0x04, 0x07;
/// built-in 0xC4, 0xC7) have bit 0x04, those of writers (0x02, 0x03, 0xC2, 0xC3) do not.
pub fn names_a_reader(guid: &Guid) -> bool {
    guid[15] & 0x04 != 0
}

/// Why a held reply went out.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Released {
    /// Its reader is matched now.
    ReaderMatched,
    /// It waited its time; the reader was not seen.
    WaitedOut,
}

#[derive(Debug)]
struct Held<R> {
    reader: Guid,
    reply: R,
    until: Instant,
}

/// The replies waiting for their readers; see the [module documentation](self).
#[derive(Debug)]
pub struct ReplyGate<R> {
    held: Vec<Held<R>>,
    wait: Duration,
}

impl<R> ReplyGate<R> {
    /// A gate holding a reply at most `wait` for its reader.
    pub fn new(wait: Duration) -> ReplyGate<R> {
        ReplyGate {
            held: Vec::new(),
            wait,
        }
    }

    /// A reply to a request that named `requester`: `Some` (send it now) when `requester` is no
    /// reader, or a reader `is_matched` says is matched; else it is held (`None`). Replies to
    /// one reader leave in the order they came.
    pub fn handle_reply(
        &mut self,
        requester: Guid,
        reply: R,
        is_matched: impl Fn(&Guid) -> bool,
        now: Instant,
    ) -> Option<R> {
        let queued_before = self.held.iter().any(|h| h.reader == requester);
        if !names_a_reader(&requester) || (!queued_before && is_matched(&requester)) {
            return Some(reply);
        }
        self.held.push(Held {
            reader: requester,
            reply,
            until: now + self.wait,
        });
        None
    }

    /// The held replies that may go now, in the order they came: their reader is matched, or
    /// their wait is over.
    pub fn poll_released(
        &mut self,
        is_matched: impl Fn(&Guid) -> bool,
        now: Instant,
    ) -> Vec<(R, Released)> {
        let mut out = Vec::new();
        let mut kept = Vec::new();
        for h in self.held.drain(..) {
            if is_matched(&h.reader) {
                out.push((h.reply, Released::ReaderMatched));
            } else if now >= h.until {
                out.push((h.reply, Released::WaitedOut));
            } else {
                kept.push(h);
            }
        }
        self.held = kept;
        out
    }

    /// `true` when no reply is held.
    pub fn is_empty(&self) -> bool {
        self.held.is_empty()
    }

    /// When the next held reply's wait ends.
    pub fn poll_timeout(&self) -> Option<Instant> {
        self.held.iter().map(|h| h.until).min()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn guid(kind: u8, n: u8) -> Guid {
        let mut g = [1u8; 16];
        g[14] = n;
        g[15] = kind;
        g
    }

    const READER: u8 = 0x04;
    const WRITER: u8 = 0x03;

    #[test]
    fn readers_and_writers_are_told_apart_by_the_entity_kind() {
        for kind in [0x04, 0x07, 0xC4, 0xC7] {
            assert!(names_a_reader(&guid(kind, 1)), "{kind:#x}");
        }
        for kind in [0x02, 0x03, 0xC2, 0xC3, 0x00] {
            assert!(!names_a_reader(&guid(kind, 1)), "{kind:#x}");
        }
    }

    #[test]
    fn a_reply_to_a_request_writer_or_a_matched_reader_goes_at_once() {
        let t0 = Instant::now();
        let mut gate = ReplyGate::new(Duration::from_secs(5));
        assert_eq!(
            gate.handle_reply(guid(WRITER, 1), "a", |_| false, t0),
            Some("a")
        );
        assert_eq!(
            gate.handle_reply(guid(READER, 1), "b", |_| true, t0),
            Some("b")
        );
        assert!(gate.is_empty());
        assert_eq!(gate.poll_timeout(), None);
    }

    #[test]
    fn a_reply_waits_for_its_reader_and_goes_when_it_is_matched() {
        let t0 = Instant::now();
        let reader = guid(READER, 1);
        let mut gate = ReplyGate::new(Duration::from_secs(5));
        assert_eq!(gate.handle_reply(reader, "a", |_| false, t0), None);
        assert_eq!(gate.poll_timeout(), Some(t0 + Duration::from_secs(5)));
        let one_s = t0 + Duration::from_secs(1);
        assert!(gate.poll_released(|_| false, one_s).is_empty());
        // Another reader is matched: not this one's.
        assert!(gate
            .poll_released(|g| *g == guid(READER, 2), one_s)
            .is_empty());
        assert_eq!(
            gate.poll_released(|g| *g == reader, one_s),
            vec![("a", Released::ReaderMatched)]
        );
        assert!(gate.is_empty());
    }

    #[test]
    fn a_reply_whose_reader_never_shows_goes_after_the_wait() {
        let t0 = Instant::now();
        let mut gate = ReplyGate::new(Duration::from_secs(5));
        assert_eq!(gate.handle_reply(guid(READER, 1), "a", |_| false, t0), None);
        assert!(gate
            .poll_released(|_| false, t0 + Duration::from_millis(4999))
            .is_empty());
        assert_eq!(
            gate.poll_released(|_| false, t0 + Duration::from_secs(5)),
            vec![("a", Released::WaitedOut)]
        );
    }

    #[test]
    fn replies_to_one_reader_keep_their_order_even_once_it_is_matched() {
        let t0 = Instant::now();
        let reader = guid(READER, 1);
        let mut gate = ReplyGate::new(Duration::from_secs(5));
        assert_eq!(gate.handle_reply(reader, 1, |_| false, t0), None);
        // Matched now, but an older reply is still held: this one queues behind it.
        assert_eq!(gate.handle_reply(reader, 2, |_| true, t0), None);
        assert_eq!(gate.handle_reply(guid(READER, 2), 3, |_| false, t0), None);
        let released = gate.poll_released(|g| *g == reader, t0);
        assert_eq!(
            released,
            vec![(1, Released::ReaderMatched), (2, Released::ReaderMatched)]
        );
        assert_eq!(gate.poll_timeout(), Some(t0 + Duration::from_secs(5)));
    }
}
