//! Service replies held until the requester's reply reader is known, as the ROS 2 middlewares
//! answer (rmw_fastrtps waits for the reader its request names, rmw_cyclonedds for a reader of
//! the reply topic in the client's participant) — under every service mapping.
//!
//! The reply topic is volatile: a reply written before the server has discovered the client's
//! reply reader is lost, and a client that calls right after discovering the service (its own
//! reader matched, the server not yet aware of it — discovery is not symmetric in time) waits
//! for it forever. So every reply waits for a reader; which one depends on the mapping
//! ([`ServiceMapping`]), never on the bits of the identity alone ([`Awaited::for_request`]):
//!
//! | mapping | the identity a request carries | the reply waits for |
//! |---|---|---|
//! | `Enhanced` (rmw_fastrtps, ROS 2's default) | an RTPS GUID in the sample's related-sample-identity: the client's **reply reader** | that reader ([`Awaited::Reader`]) |
//! | `Enhanced`, a client that sets no related-sample-identity | its request writer's GUID | a reader of the reply topic in the writer's participant (its 12-byte GUID prefix) |
//! | `Cyclone` (rmw_cyclonedds_cpp) | the upper half of the request writer's GUID, then a 64-bit client id (a random number) | a reader of the reply topic in a participant whose GUID begins with that upper half |
//! | `Basic` (DDS-RPC) | the request writer's sample identity | a reader of the reply topic in the writer's participant |
//!
//! | input | here |
//! |---|---|
//! | a reply to send, with what it waits for | [`ReplyGate::handle_reply`]: out at once when that reader is known (and no older reply to it is held); else held |
//! | the readers discovered so far, on every poll | [`ReplyGate::poll_released`]: the held replies whose reader is known now, and those that waited the gate's wait (sent anyway: the reader may exist on a path discovery has not reported) |
//! | when to poll next | [`ReplyGate::poll_timeout`] |
//!
//! Generic over the reply `R`; the readers known are passed in as data ([`KnownReader`]) and
//! time as an `Instant`, so that the gate is tested without DDS, on virtual time.

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

/// The length of an RTPS GUID prefix: the participant's part of every GUID.
const PARTICIPANT_PREFIX: usize = 12;

/// How much of the request writer's GUID a Cyclone-mapping identity carries (its upper half).
const CYCLONE_UPPER_HALF: usize = 8;

/// A reader the node's participant has discovered on the domain.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct KnownReader {
    /// Its GUID.
    pub guid: Guid,
    /// The DDS topic it reads (`rr/…Reply` for a service's replies).
    pub topic: String,
}

/// The reader a reply waits for.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Awaited {
    /// The reply reader the request named (rmw_fastrtps's related-sample-identity).
    Reader(Guid),
    /// Any reader of `reply_topic` whose GUID begins with `prefix`: the requester's participant
    /// (12 bytes) or, under the Cyclone mapping, the upper half of its GUID (8 bytes).
    InParticipant {
        /// The first bytes of the requester's GUID.
        prefix: Vec<u8>,
        /// The service's reply topic.
        reply_topic: String,
    },
}

impl Awaited {
    /// What the reply to a request with identity `requester`, on a service whose replies go on
    /// `reply_topic`, waits for under `mapping`: the reply reader an `Enhanced` request names;
    /// otherwise a reader of the reply topic in the requester's participant.
    pub fn for_request(mapping: ServiceMapping, requester: &Guid, reply_topic: &str) -> Awaited {
        let prefix = match mapping {
            ServiceMapping::Enhanced if USER_READER_KINDS.contains(&requester[15]) => {
                return Awaited::Reader(*requester);
            }
            ServiceMapping::Enhanced | ServiceMapping::Basic => PARTICIPANT_PREFIX,
            ServiceMapping::Cyclone => CYCLONE_UPPER_HALF,
        };
        Awaited::InParticipant {
            prefix: requester[..prefix].to_vec(),
            reply_topic: reply_topic.to_owned(),
        }
    }

    /// `true` when a reader among `known` is the one awaited.
    pub fn is_among(&self, known: &[KnownReader]) -> bool {
        match self {
            Awaited::Reader(guid) => known.iter().any(|r| r.guid == *guid),
            Awaited::InParticipant {
                prefix,
                reply_topic,
            } => known
                .iter()
                .any(|r| r.guid.starts_with(prefix) && r.topic == *reply_topic),
        }
    }
}

/// Why a held reply went out.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Released {
    /// Its reader is known now.
    ReaderMatched,
    /// It waited its time; the reader was not seen.
    WaitedOut,
}

#[derive(Debug)]
struct Held<R> {
    awaited: Awaited,
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

    /// A reply that waits for `awaited`: `Some` (send it now) when that reader is among
    /// `known` (or the gate never waits) and no older reply to it is held; else it is held
    /// (`None`). Replies to one
    /// reader leave in the order they came.
    pub fn handle_reply(
        &mut self,
        awaited: Awaited,
        reply: R,
        known: &[KnownReader],
        now: Instant,
    ) -> Option<R> {
        let queued_before = self.held.iter().any(|h| h.awaited == awaited);
        if !queued_before && (self.wait.is_zero() || awaited.is_among(known)) {
            return Some(reply);
        }
        self.held.push(Held {
            awaited,
            reply,
            until: now + self.wait,
        });
        None
    }

    /// The held replies that may go now, in the order they came: their reader is among
    /// `known`, or their wait is over.
    pub fn poll_released(&mut self, known: &[KnownReader], now: Instant) -> Vec<(R, Released)> {
        let mut out = Vec::new();
        let mut kept = Vec::new();
        for h in self.held.drain(..) {
            if h.awaited.is_among(known) {
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

    /// The reply topic of the node's `~/start` service.
    const START_REPLY: &str = "rr/fs020n/startReply";

    /// A request identity under the Cyclone mapping exactly as ros2-client reassembles it from
    /// an rmw_cyclonedds_cpp request: the upper 8 bytes of the request writer's GUID, then the
    /// client id the payload header carries — rmw_cyclonedds's request writer instance handle,
    /// an arbitrary 64-bit number, in the CDR byte order of the sample (little endian here).
    fn cyclone_request(writer_upper_half: [u8; 8], client_id: u64) -> Guid {
        let mut g = [0u8; 16];
        g[..8].copy_from_slice(&writer_upper_half);
        g[8..].copy_from_slice(&client_id.to_le_bytes());
        g
    }

    /// A Cyclone DDS participant's GUID prefix (vendor 01.10), upper half.
    const CYCLONE_PREFIX: [u8; 8] = [0x01, 0x10, 0x5e, 0x3c, 0x7a, 0x91, 0x00, 0x2f];

    /// A reader of `topic` in the Cyclone participant whose GUID begins with `upper_half`.
    fn cyclone_reader(upper_half: [u8; 8], topic: &str) -> KnownReader {
        let mut guid = [0u8; 16];
        guid[..8].copy_from_slice(&upper_half);
        guid[8..].copy_from_slice(&[0x00, 0x00, 0x00, 0x01, 0x00, 0x00, 0x11, 0x04]);
        KnownReader {
            guid,
            topic: topic.to_owned(),
        }
    }

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

    fn known(guid: Guid, topic: &str) -> KnownReader {
        KnownReader {
            guid,
            topic: topic.to_owned(),
        }
    }

    /// A short period of the node's polls (every 5 ms) in virtual time.
    const POLL: Duration = Duration::from_millis(5);

    /// Sends `reply` through `gate` at `t0`, waiting for `awaited`; the readers known at time
    /// `t` are `readers_at(t)`, polled every 5 ms of virtual time: when it left and why, or
    /// `None` when it did not within `within`.
    fn time_to_reply(
        gate: &mut ReplyGate<u64>,
        awaited: Awaited,
        reply: u64,
        t0: Instant,
        readers_at: impl Fn(Instant) -> Vec<KnownReader>,
        within: Duration,
    ) -> Option<(Duration, Released)> {
        if gate
            .handle_reply(awaited, reply, &readers_at(t0), t0)
            .is_some()
        {
            return Some((Duration::ZERO, Released::ReaderMatched));
        }
        let mut now = t0;
        while now <= t0 + within {
            now += POLL;
            if let Some((_, why)) = gate
                .poll_released(&readers_at(now), now)
                .into_iter()
                .find(|(r, _)| *r == reply)
            {
                return Some((now - t0, why));
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
    fn the_mapping_decides_which_reader_a_reply_waits_for() {
        assert_eq!(
            Awaited::for_request(ServiceMapping::Enhanced, &FASTDDS_REPLY_READER, START_REPLY),
            Awaited::Reader(FASTDDS_REPLY_READER)
        );
        let mut with_key = FASTDDS_REPLY_READER;
        with_key[15] = 0x07;
        assert_eq!(
            Awaited::for_request(ServiceMapping::Enhanced, &with_key, START_REPLY),
            Awaited::Reader(with_key)
        );
        // A request writer (no related-sample-identity), and every Basic identity: a reader
        // of the reply topic in the writer's participant, the 12-byte GUID prefix.
        for (mapping, requester) in [
            (ServiceMapping::Enhanced, FASTDDS_REQUEST_WRITER),
            (ServiceMapping::Basic, FASTDDS_REQUEST_WRITER),
            (ServiceMapping::Basic, FASTDDS_REPLY_READER),
        ] {
            assert_eq!(
                Awaited::for_request(mapping, &requester, START_REPLY),
                Awaited::InParticipant {
                    prefix: requester[..12].to_vec(),
                    reply_topic: START_REPLY.to_owned()
                }
            );
        }
        // Cyclone: the upper half, whatever the client id's bits look like.
        let requester = cyclone_request(CYCLONE_PREFIX, 0x04 << 56);
        assert_eq!(
            Awaited::for_request(ServiceMapping::Cyclone, &requester, START_REPLY),
            Awaited::InParticipant {
                prefix: CYCLONE_PREFIX.to_vec(),
                reply_topic: START_REPLY.to_owned()
            }
        );
    }

    #[test]
    fn every_cyclone_client_is_answered_once_its_participants_reply_reader_is_known() {
        let t0 = Instant::now();
        let mut gate = ReplyGate::new(DEFAULT_READER_WAIT);
        let ids = instance_ids(2_000);
        // Half of the ids have the bit a reader's entity kind has: they must not matter.
        assert!(ids.iter().filter(|id| (**id >> 56) & 0x04 != 0).count() > 800);
        let mut other = CYCLONE_PREFIX;
        other[7] ^= 0xff;
        let reader = cyclone_reader(CYCLONE_PREFIX, START_REPLY);
        let seen_at = t0 + Duration::from_millis(40);
        let readers_at = |t: Instant| {
            // From the start: another participant's reply reader and this participant's
            // reader of another topic; this participant's reply reader from 40 ms.
            let mut r = vec![
                cyclone_reader(other, START_REPLY),
                cyclone_reader(CYCLONE_PREFIX, "rt/joint_states"),
            ];
            if t >= seen_at {
                r.push(reader.clone());
            }
            r
        };
        for (n, id) in ids.into_iter().enumerate() {
            let awaited = Awaited::for_request(
                ServiceMapping::Cyclone,
                &cyclone_request(CYCLONE_PREFIX, id),
                START_REPLY,
            );
            let mut one = ReplyGate::new(DEFAULT_READER_WAIT);
            let took = time_to_reply(
                &mut one,
                awaited.clone(),
                n as u64,
                t0,
                readers_at,
                POLL * 20,
            );
            assert_eq!(
                took,
                Some((Duration::from_millis(40), Released::ReaderMatched)),
                "client id {id:#018x}"
            );
            // Once the reader is known, at once.
            assert_eq!(
                gate.handle_reply(awaited, n as u64, &readers_at(seen_at), seen_at),
                Some(n as u64)
            );
        }
        assert!(gate.is_empty());
        assert_eq!(gate.poll_timeout(), None);
    }

    #[test]
    fn a_client_that_names_only_its_request_writer_is_answered_once_its_reply_reader_is_known() {
        // The defect: a client whose own reader matched the node's reply writer called at once,
        // before the node had discovered that reader; the reply went out to nobody.
        let t0 = Instant::now();
        let mut reply_reader = FASTDDS_REQUEST_WRITER;
        reply_reader[14] = 0x14;
        reply_reader[15] = 0x04;
        let seen_at = t0 + Duration::from_millis(15);
        for mapping in [ServiceMapping::Enhanced, ServiceMapping::Basic] {
            let mut gate = ReplyGate::new(Duration::from_secs(5));
            let awaited = Awaited::for_request(mapping, &FASTDDS_REQUEST_WRITER, START_REPLY);
            let readers_at = |t: Instant| {
                let mut r = vec![known(reply_reader, "rr/fs020n/stopReply")];
                if t >= seen_at {
                    r.push(known(reply_reader, START_REPLY));
                }
                r
            };
            assert_eq!(
                time_to_reply(&mut gate, awaited, 1, t0, readers_at, POLL * 10),
                Some((Duration::from_millis(15), Released::ReaderMatched)),
                "{mapping:?}"
            );
        }
    }

    #[test]
    fn a_fastdds_reply_waits_for_its_reader_and_goes_at_the_poll_that_knows_it() {
        let t0 = Instant::now();
        let reader = known(FASTDDS_REPLY_READER, START_REPLY);
        let awaited = Awaited::Reader(FASTDDS_REPLY_READER);
        let mut gate = ReplyGate::new(Duration::from_secs(5));
        assert_eq!(gate.handle_reply(awaited, "a", &[], t0), None);
        assert_eq!(gate.poll_timeout(), Some(t0 + Duration::from_secs(5)));
        let one_s = t0 + Duration::from_secs(1);
        assert!(gate.poll_released(&[], one_s).is_empty());
        // Another reader of the same participant and topic: not this one.
        let mut other = reader.clone();
        other.guid[14] = 0x20;
        assert!(gate.poll_released(&[other], one_s).is_empty());
        // Its reader is discovered at 1 s: the reply leaves at the next poll, 5 ms later.
        assert_eq!(
            gate.poll_released(&[reader], one_s + POLL),
            vec![("a", Released::ReaderMatched)]
        );
        assert!(gate.is_empty());
    }

    #[test]
    fn a_reply_whose_reader_is_known_goes_at_once() {
        let t0 = Instant::now();
        let mut gate = ReplyGate::new(Duration::from_secs(5));
        let reader = known(FASTDDS_REPLY_READER, START_REPLY);
        assert_eq!(
            gate.handle_reply(
                Awaited::Reader(FASTDDS_REPLY_READER),
                "b",
                std::slice::from_ref(&reader),
                t0
            ),
            Some("b")
        );
        let awaited = Awaited::for_request(
            ServiceMapping::Enhanced,
            &FASTDDS_REQUEST_WRITER,
            START_REPLY,
        );
        assert_eq!(gate.handle_reply(awaited, "c", &[reader], t0), Some("c"));
        assert!(gate.is_empty());
        assert_eq!(gate.poll_timeout(), None);
    }

    #[test]
    fn a_reply_whose_reader_never_shows_goes_after_the_wait() {
        let t0 = Instant::now();
        let mut gate = ReplyGate::new(Duration::from_secs(5));
        let awaited = Awaited::Reader(FASTDDS_REPLY_READER);
        assert_eq!(gate.handle_reply(awaited, "a", &[], t0), None);
        assert!(gate
            .poll_released(&[], t0 + Duration::from_millis(4999))
            .is_empty());
        assert_eq!(
            gate.poll_released(&[], t0 + Duration::from_secs(5)),
            vec![("a", Released::WaitedOut)]
        );
    }

    #[test]
    fn a_gate_that_never_waits_sends_every_reply_at_once() {
        let t0 = Instant::now();
        let mut gate = ReplyGate::new(Duration::ZERO);
        let awaited = Awaited::Reader(FASTDDS_REPLY_READER);
        assert_eq!(gate.handle_reply(awaited.clone(), "a", &[], t0), Some("a"));
        assert_eq!(gate.handle_reply(awaited, "b", &[], t0), Some("b"));
        assert!(gate.is_empty());
    }

    #[test]
    fn replies_to_one_reader_keep_their_order_even_once_it_is_matched() {
        let t0 = Instant::now();
        let reader = known(FASTDDS_REPLY_READER, START_REPLY);
        let mut other = FASTDDS_REPLY_READER;
        other[14] = 0x20;
        let mut gate = ReplyGate::new(Duration::from_secs(5));
        let to_reader = Awaited::Reader(FASTDDS_REPLY_READER);
        assert_eq!(gate.handle_reply(to_reader.clone(), 1, &[], t0), None);
        // Known now, but an older reply is still held: this one queues behind it.
        let now_known = std::slice::from_ref(&reader);
        assert_eq!(gate.handle_reply(to_reader, 2, now_known, t0), None);
        assert_eq!(gate.handle_reply(Awaited::Reader(other), 3, &[], t0), None);
        let released = gate.poll_released(now_known, t0);
        assert_eq!(
            released,
            vec![(1, Released::ReaderMatched), (2, Released::ReaderMatched)]
        );
        assert_eq!(gate.poll_timeout(), Some(t0 + Duration::from_secs(5)));
    }

    proptest! {
        #[test]
        fn any_request_is_answered_by_the_poll_after_its_reader_is_known_and_never_later_than_the_wait(
            requester in any::<[u8; 16]>(),
            mapping in prop_oneof![
                Just(ServiceMapping::Enhanced),
                Just(ServiceMapping::Cyclone),
                Just(ServiceMapping::Basic),
            ],
            known_after_polls in proptest::option::of(0u32..20),
        ) {
            let t0 = Instant::now();
            let mut gate = ReplyGate::new(DEFAULT_READER_WAIT);
            let awaited = Awaited::for_request(mapping, &requester, START_REPLY);
            // The reader it waits for, as discovery would report it.
            let mut guid = requester;
            if !matches!(awaited, Awaited::Reader(_)) {
                guid[12..].copy_from_slice(&[0x00, 0x00, 0x21, 0x04]);
            }
            let reader = known(guid, START_REPLY);
            let known_at = known_after_polls.map(|k| t0 + POLL * k);
            let readers_at = |t: Instant| match known_at {
                Some(at) if t >= at => vec![reader.clone()],
                _ => Vec::new(),
            };
            let within = DEFAULT_READER_WAIT + POLL;
            let (took, why) = time_to_reply(&mut gate, awaited, 1, t0, readers_at, within)
                .expect("every reply leaves");
            match known_at {
                Some(at) => prop_assert_eq!((t0 + took, why), (at, Released::ReaderMatched)),
                None => prop_assert_eq!((took, why), (DEFAULT_READER_WAIT, Released::WaitedOut)),
            }
            prop_assert!(gate.is_empty());
        }
    }
}
