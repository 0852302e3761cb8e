//! Service replies held until the requester's reply reader is matched, as rmw_fastrtps answers —
//! and only under the service mapping whose requests name such a reader.
//!
//! What a request's identity is depends on the mapping ([`ServiceMapping`]), never on the
//! bits of the identity itself:
//!
//! | mapping | the identity a request carries | here |
//! |---|---|---|
//! | `Enhanced` (rmw_fastrtps, ROS 2's default) | an RTPS GUID in the sample's related-sample-identity: the client's **reply reader** (or, from a client that sets none, its request writer) | a reply to a reader is held until that reader is known ([`ReplyGate::handle_reply`]), at most the gate's wait |
//! | `Cyclone` (rmw_cyclonedds_cpp) | a 64-bit client id in the payload (the request writer's instance handle, a random number) after the upper half of the request writer's GUID: **no reader** | out at once, whatever the id |
//! | `Basic` (DDS-RPC) | the request writer's sample identity: no reader | out at once |
//!
//! Under `Enhanced` a reply written before the server has discovered the client's reply reader
//! is lost (the reply topic is volatile), and a client that calls right after discovering the
//! service would wait for it forever: that is why it is held. Under the other mappings there is
//! no reader to wait for: holding would only delay the reply.
//!
//! | input | here |
//! |---|---|
//! | a reply to send, with the GUID the request named | [`ReplyGate::handle_reply`]: out at once unless [`reply_reader`] names an unknown reader; else held |
//! | the readers discovered so far, on every poll | [`ReplyGate::poll_released`]: the held replies whose reader is known now, and those that waited the gate's wait (sent anyway: the reader may exist on a path discovery has not reported) |
//! | when to poll next | [`ReplyGate::poll_timeout`] |
//!
//! Generic over the reply `R`; the "known reader" test is a closure and time is passed in
//! (`Instant`), so that it is tested without DDS, on virtual time.

use std::time::Duration;

use tokio::time::Instant;

use crate::config::ServiceMapping;

/// A request's identity as ros2-client hands it over (`RmwRequestId::writer_gid`, 16 bytes):
/// under `Enhanced` an RTPS GUID (a 12-byte participant prefix and a 4-byte entity id whose
/// last byte is the entity kind); under `Cyclone` the upper half of the request writer's GUID
/// and the client's 64-bit id; under `Basic` the request writer's GUID.
pub type Guid = [u8; 16];

/// The RTPS entity kinds of user-defined readers (no key, with key): RTPS 2.x, 9.3.1.2.
const USER_READER_KINDS: [u8; 2] = [0x04, 0x07];

/// The reply reader a request names, if its mapping names one: only under `Enhanced`, where the
/// identity is a real RTPS GUID and its entity kind says whether it is the client's reply reader
/// (rmw_fastrtps) or its request writer (a client that sets no related-sample-identity).
/// `None` under `Cyclone` and `Basic`, whatever the bytes: those identities name no reader.
pub fn reply_reader(mapping: ServiceMapping, requester: &Guid) -> Option<Guid> {
    match mapping {
        ServiceMapping::Enhanced if USER_READER_KINDS.contains(&requester[15]) => Some(*requester),
        ServiceMapping::Enhanced | ServiceMapping::Cyclone | ServiceMapping::Basic => None,
    }
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
    mapping: ServiceMapping,
    held: Vec<Held<R>>,
    wait: Duration,
}

impl<R> ReplyGate<R> {
    /// A gate for a service on `mapping`, holding a reply at most `wait` for its reader.
    pub fn new(mapping: ServiceMapping, wait: Duration) -> ReplyGate<R> {
        ReplyGate {
            mapping,
            held: Vec::new(),
            wait,
        }
    }

    /// A reply to a request that named `requester`: `Some` (send it now) unless the mapping
    /// says `requester` is a reply reader ([`reply_reader`]) that `is_matched` does not know
    /// yet; then it is held (`None`). Replies to one reader leave in the order they came.
    pub fn handle_reply(
        &mut self,
        requester: Guid,
        reply: R,
        is_matched: impl Fn(&Guid) -> bool,
        now: Instant,
    ) -> Option<R> {
        let Some(reader) = reply_reader(self.mapping, &requester) else {
            return Some(reply);
        };
        let queued_before = self.held.iter().any(|h| h.reader == reader);
        if !queued_before && is_matched(&reader) {
            return Some(reply);
        }
        self.held.push(Held {
            reader,
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

    /// The longest a reply is held.
    pub fn wait(&self) -> Duration {
        self.wait
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
    use crate::config::DEFAULT_READER_WAIT;
    use proptest::prelude::*;

    /// A request identity under the Cyclone mapping exactly as ros2-client reassembles it from
    /// an rmw_cyclonedds_cpp request: the upper 8 bytes of the request writer's GUID, then the
    /// client id the payload header carries — rmw_cyclonedds's request writer instance handle,
    /// an arbitrary 64-bit number, in the CDR byte order of the sample (little endian here).
    fn cyclone_request(writer_prefix: [u8; 8], client_id: u64) -> Guid {
        let mut g = [0u8; 16];
        g[..8].copy_from_slice(&writer_prefix);
        g[8..].copy_from_slice(&client_id.to_le_bytes());
        g
    }

    /// A Cyclone DDS participant's GUID prefix (vendor 01.10), upper half.
    const CYCLONE_PREFIX: [u8; 8] = [0x01, 0x10, 0x5e, 0x3c, 0x7a, 0x91, 0x00, 0x2f];

    /// GUIDs as Fast DDS 2.x makes them (vendor 01.0f, host, process and participant ids; a
    /// user entity counter, then the entity kind): the reply reader and the request writer of
    /// one client, as the Fast DDS test peer reports them.
    const FASTDDS_REPLY_READER: Guid = [
        0x01, 0x0f, 0x45, 0xd1, 0xa3, 0x2b, 0x00, 0x00, 0x01, 0x00, 0x00, 0x00, 0x00, 0x00, 0x12,
        0x04,
    ];
    const FASTDDS_REQUEST_WRITER: Guid = [
        0x01, 0x0f, 0x45, 0xd1, 0xa3, 0x2b, 0x00, 0x00, 0x01, 0x00, 0x00, 0x00, 0x00, 0x00, 0x13,
        0x03,
    ];

    /// A short period of the node's polls (every 5 ms) in virtual time.
    const POLL: Duration = Duration::from_millis(5);
    /// How soon every reply that needs no reader must leave.
    const AT_ONCE: Duration = Duration::from_millis(100);

    /// Sends `reply` through `gate` at `t0` with no reader ever known, polling every 5 ms of
    /// virtual time: when it left, or `None` when it did not within `within`.
    fn time_to_reply(
        gate: &mut ReplyGate<u64>,
        requester: Guid,
        reply: u64,
        t0: Instant,
        within: Duration,
    ) -> Option<Duration> {
        if gate.handle_reply(requester, reply, |_| false, t0).is_some() {
            return Some(Duration::ZERO);
        }
        let mut now = t0;
        while now <= t0 + within {
            now += POLL;
            if gate
                .poll_released(|_| false, now)
                .iter()
                .any(|(r, _)| *r == reply)
            {
                return Some(now - t0);
            }
        }
        None
    }

    /// A small deterministic generator (xorshift64*) standing in for the random instance
    /// handles of many client processes.
    fn instance_ids(n: usize) -> Vec<u64> {
        let mut x: u64 = 0x9e37_79b9_7f4a_7c15;
        (0..n)
            .map(|_| {
                x ^= x >> 12;
                x ^= x << 25;
                x ^= x >> 27;
                x.wrapping_mul(0x2545_f491_4f6c_dd1d)
            })
            .collect()
    }

    #[test]
    fn every_cyclone_client_is_answered_at_once_whatever_its_id() {
        let t0 = Instant::now();
        let mut gate = ReplyGate::new(ServiceMapping::Cyclone, DEFAULT_READER_WAIT);
        let ids = instance_ids(10_000);
        // The ids of the defect: half of them have the bit a reader's entity kind has.
        assert!(ids.iter().filter(|id| (**id >> 56) & 0x04 != 0).count() > 4_000);
        let mut ids_with_reader_kinds = vec![0x04 << 56, 0x07 << 56, 0xC4 << 56, 0xC7 << 56];
        ids_with_reader_kinds.extend(ids);
        for (n, id) in ids_with_reader_kinds.into_iter().enumerate() {
            let requester = cyclone_request(CYCLONE_PREFIX, id);
            let took = time_to_reply(&mut gate, requester, n as u64, t0, AT_ONCE);
            assert_eq!(took, Some(Duration::ZERO), "client id {id:#018x}");
        }
        assert!(gate.is_empty());
        assert_eq!(gate.poll_timeout(), None);
    }

    #[test]
    fn a_basic_mapping_request_names_no_reader_and_is_answered_at_once() {
        let t0 = Instant::now();
        let mut gate = ReplyGate::new(ServiceMapping::Basic, DEFAULT_READER_WAIT);
        for (n, requester) in [FASTDDS_REPLY_READER, FASTDDS_REQUEST_WRITER]
            .into_iter()
            .enumerate()
        {
            assert_eq!(
                time_to_reply(&mut gate, requester, n as u64, t0, AT_ONCE),
                Some(Duration::ZERO)
            );
        }
    }

    #[test]
    fn the_mapping_decides_which_identities_name_a_reader() {
        assert_eq!(
            reply_reader(ServiceMapping::Enhanced, &FASTDDS_REPLY_READER),
            Some(FASTDDS_REPLY_READER)
        );
        let mut with_key = FASTDDS_REPLY_READER;
        with_key[15] = 0x07;
        assert_eq!(
            reply_reader(ServiceMapping::Enhanced, &with_key),
            Some(with_key)
        );
        assert_eq!(
            reply_reader(ServiceMapping::Enhanced, &FASTDDS_REQUEST_WRITER),
            None
        );
        for mapping in [ServiceMapping::Cyclone, ServiceMapping::Basic] {
            assert_eq!(reply_reader(mapping, &FASTDDS_REPLY_READER), None);
        }
    }

    #[test]
    fn a_fastdds_reply_waits_for_its_reader_and_goes_at_the_poll_that_knows_it() {
        let t0 = Instant::now();
        let reader = FASTDDS_REPLY_READER;
        let mut gate = ReplyGate::new(ServiceMapping::Enhanced, Duration::from_secs(5));
        assert_eq!(gate.handle_reply(reader, "a", |_| false, t0), None);
        assert_eq!(gate.poll_timeout(), Some(t0 + Duration::from_secs(5)));
        let one_s = t0 + Duration::from_secs(1);
        assert!(gate.poll_released(|_| false, one_s).is_empty());
        // Another reader is matched: not this one's.
        let mut other = reader;
        other[14] = 0x20;
        assert!(gate.poll_released(|g| *g == other, one_s).is_empty());
        // Its reader is discovered at 1 s: the reply leaves at the next poll, 5 ms later.
        assert_eq!(
            gate.poll_released(|g| *g == reader, one_s + POLL),
            vec![("a", Released::ReaderMatched)]
        );
        assert!(gate.is_empty());
    }

    #[test]
    fn a_fastdds_reply_to_a_known_reader_or_a_request_writer_goes_at_once() {
        let t0 = Instant::now();
        let mut gate = ReplyGate::new(ServiceMapping::Enhanced, Duration::from_secs(5));
        assert_eq!(
            gate.handle_reply(FASTDDS_REQUEST_WRITER, "a", |_| false, t0),
            Some("a")
        );
        assert_eq!(
            gate.handle_reply(
                FASTDDS_REPLY_READER,
                "b",
                |g| *g == FASTDDS_REPLY_READER,
                t0
            ),
            Some("b")
        );
        assert!(gate.is_empty());
        assert_eq!(gate.poll_timeout(), None);
    }

    #[test]
    fn a_fastdds_reply_whose_reader_never_shows_goes_after_the_wait() {
        let t0 = Instant::now();
        let mut gate = ReplyGate::new(ServiceMapping::Enhanced, Duration::from_secs(5));
        assert_eq!(
            gate.handle_reply(FASTDDS_REPLY_READER, "a", |_| false, t0),
            None
        );
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
        let reader = FASTDDS_REPLY_READER;
        let mut other = reader;
        other[14] = 0x20;
        let mut gate = ReplyGate::new(ServiceMapping::Enhanced, Duration::from_secs(5));
        assert_eq!(gate.handle_reply(reader, 1, |_| false, t0), None);
        // Matched now, but an older reply is still held: this one queues behind it.
        assert_eq!(gate.handle_reply(reader, 2, |_| true, t0), None);
        assert_eq!(gate.handle_reply(other, 3, |_| false, t0), None);
        let released = gate.poll_released(|g| *g == reader, t0);
        assert_eq!(
            released,
            vec![(1, Released::ReaderMatched), (2, Released::ReaderMatched)]
        );
        assert_eq!(gate.poll_timeout(), Some(t0 + Duration::from_secs(5)));
    }

    proptest! {
        #[test]
        fn any_cyclone_client_id_is_answered_at_once(
            client_id in any::<u64>(),
            writer_prefix in any::<[u8; 8]>(),
            seq in any::<u64>(),
        ) {
            let t0 = Instant::now();
            let mut gate = ReplyGate::new(ServiceMapping::Cyclone, DEFAULT_READER_WAIT);
            let requester = cyclone_request(writer_prefix, client_id);
            prop_assert_eq!(
                time_to_reply(&mut gate, requester, seq, t0, AT_ONCE),
                Some(Duration::ZERO)
            );
            prop_assert!(gate.is_empty());
        }

        #[test]
        fn any_identity_under_the_enhanced_mapping_is_answered_by_the_time_its_reader_is_known(
            requester in any::<[u8; 16]>(),
            known_after_polls in 0u32..20,
        ) {
            let t0 = Instant::now();
            let mut gate = ReplyGate::new(ServiceMapping::Enhanced, DEFAULT_READER_WAIT);
            let known_at = t0 + POLL * known_after_polls;
            let sent_at = if gate.handle_reply(requester, 1u8, |_| t0 >= known_at, t0).is_some() {
                Some(t0)
            } else {
                (1..=20u32).map(|k| t0 + POLL * k).find(|now| {
                    !gate.poll_released(|_| *now >= known_at, *now).is_empty()
                })
            };
            let sent_at = sent_at.expect("the reply leaves once its reader is known");
            prop_assert!(sent_at <= known_at);
        }
    }
}
