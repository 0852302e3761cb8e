//! The session core's rules, one test each, on a fake clock: instants are data made from one
//! origin, no runtime and no sleep.
#![allow(clippy::unwrap_used, clippy::expect_used)] // test code: a failed expectation is a failed test

use super::*;
use crate::error::Cancellation;
use crate::safety::Blocker;

/// A reply of a controller whose motion program runs (motion allowed).
const RUNNING: &str =
    " 1040 0 -1 -1 0 -1 -1     0.200     0.000     0.000   -90.000     0.000   -90.000     0.000 ";
/// A reply of a controller on HOLD (motion blocked).
const HELD: &str =
    " 1040 0 0 -1 0 -1 -1     0.300     0.000     0.000   -90.000     0.000   -90.000     0.000 ";
const MOTION_TEXT: &str = "1040 6 9 0 0 0 10 0 -90 0 -90 0";

fn timeouts() -> Timeouts {
    Timeouts {
        write: Duration::from_millis(50),
        reply: Duration::from_millis(250),
        keepalive_period: Duration::from_millis(100),
        close: Duration::from_secs(2),
    }
}

fn ms(n: u64) -> Duration {
    Duration::from_millis(n)
}

/// The fake clock: every instant is `t(ms)` after one origin.
struct Clock(Instant);

impl Clock {
    fn new() -> Clock {
        Clock(Instant::now())
    }
    fn t(&self, millis: u64) -> Instant {
        self.0 + ms(millis)
    }
}

fn poll(kind: Kind) -> WireRequest {
    WireRequest::new(kind, "0 0 0".into(), None)
}

fn motion(epoch: u64) -> WireRequest {
    WireRequest::new(
        Kind::Motion,
        MOTION_TEXT.into(),
        Some(MotionTag { epoch, id: 1 }),
    )
}

/// Writes and flushes the request in flight at `now`, as a driver does; returns the bytes.
fn write_all(core: &mut SessionCore, now: Instant) -> Vec<u8> {
    let mut out = Vec::new();
    while let Some(t) = core.poll_transmit() {
        match t {
            Transmit::Bytes(b) => {
                out.extend_from_slice(b);
                let n = b.len();
                core.handle_written(n);
            }
            Transmit::Flush => core.handle_flushed(now),
        }
    }
    out
}

fn events(core: &mut SessionCore) -> Vec<Event> {
    std::iter::from_fn(|| core.poll_event()).collect()
}

/// The only event: a completed exchange; returns its reply.
fn done(core: &mut SessionCore) -> Reply {
    match events(core).as_slice() {
        [Event::ExchangeDone { reply, .. }] => reply.clone(),
        other => panic!("expected one completed exchange, got {other:?}"),
    }
}

/// A core after its connect poll, answered by `reply` at `t(0)`.
fn connected(clock: &Clock, reply: &str) -> SessionCore {
    let mut core = SessionCore::new(timeouts());
    core.begin_request(clock.t(0), 0, poll(Kind::Poll)).unwrap();
    write_all(&mut core, clock.t(0));
    core.handle_input(clock.t(0), reply.as_bytes());
    done(&mut core);
    core
}

fn link_lost(e: LinkError) -> ClientError {
    ClientError::LinkLost(e)
}

#[test]
fn a_request_is_written_flushed_and_done_when_its_reply_is_complete() {
    let clock = Clock::new();
    let mut core = connected(&clock, RUNNING);
    core.begin_request(clock.t(10), 0, poll(Kind::Poll))
        .unwrap();
    assert_eq!(core.poll_transmit(), Some(Transmit::Bytes(b"0 0 0")));
    core.handle_written(2);
    assert_eq!(
        core.poll_transmit(),
        Some(Transmit::Bytes(b"0 0")),
        "goes on where it stopped"
    );
    core.handle_written(3);
    assert_eq!(core.poll_transmit(), Some(Transmit::Flush));
    core.handle_flushed(clock.t(10));
    assert_eq!(core.poll_transmit(), None);
    core.handle_input(clock.t(13), RUNNING.as_bytes());
    let reply = done(&mut core);
    assert_eq!(reply.frame.text, RUNNING);
    assert_eq!(reply.received_at - reply.sent_at, ms(3), "the round trip");
    assert_eq!(reply.seq, 1, "one reply before it: the connect poll's");
    assert!(!core.in_flight());
}

#[test]
fn a_reply_split_across_reads_completes_at_its_final_blank() {
    let clock = Clock::new();
    let mut core = connected(&clock, RUNNING);
    core.begin_request(clock.t(10), 0, poll(Kind::Poll))
        .unwrap();
    write_all(&mut core, clock.t(10));
    let (a, b) = RUNNING.split_at(30);
    core.handle_input(clock.t(11), a.as_bytes());
    assert_eq!(core.poll_event(), None);
    core.handle_input(clock.t(12), b.as_bytes());
    assert_eq!(done(&mut core).received_at, clock.t(12));
}

#[test]
fn a_reply_missing_its_final_blank_completes_after_20_ms_of_quiet() {
    let clock = Clock::new();
    let mut core = connected(&clock, RUNNING);
    core.begin_request(clock.t(10), 0, poll(Kind::Poll))
        .unwrap();
    write_all(&mut core, clock.t(10));
    assert_eq!(
        core.poll_timeout(),
        Some(clock.t(260)),
        "the reply deadline"
    );
    core.handle_input(clock.t(12), RUNNING.trim_end().as_bytes());
    assert_eq!(core.poll_event(), None, "the final blank may still come");
    assert_eq!(core.poll_timeout(), Some(clock.t(32)), "20 ms of quiet");
    core.handle_timeout(clock.t(31));
    assert_eq!(core.poll_event(), None);
    core.handle_timeout(clock.t(32));
    let reply = done(&mut core);
    assert_eq!(reply.received_at, clock.t(32));
    assert_eq!(reply.frame.status.joints[2], -90.0);
    // The blank, late, is not unsolicited.
    core.handle_input(clock.t(40), b" ");
    assert_eq!(core.poll_event(), None);
    core.begin_request(clock.t(50), 0, poll(Kind::Poll))
        .unwrap();
}

#[test]
fn more_bytes_restart_the_quiet_wait_which_never_passes_the_reply_deadline() {
    let clock = Clock::new();
    let mut core = connected(&clock, RUNNING);
    core.begin_request(clock.t(0), 0, poll(Kind::Poll)).unwrap();
    write_all(&mut core, clock.t(0));
    let open = RUNNING.trim_end();
    core.handle_input(clock.t(235), &open.as_bytes()[..open.len() - 10]);
    assert_eq!(
        core.poll_timeout(),
        Some(clock.t(250)),
        "not an open reply yet"
    );
    core.handle_input(clock.t(240), &open.as_bytes()[open.len() - 10..]);
    assert_eq!(
        core.poll_timeout(),
        Some(clock.t(250)),
        "20 ms of quiet would end after the deadline"
    );
    core.handle_timeout(clock.t(250));
    assert!(matches!(
        events(&mut core).as_slice(),
        [
            Event::ExchangeFailed {
                cause: LinkError::ReplyTimeout { .. },
                ..
            },
            Event::LinkEnded { .. }
        ]
    ));
}

#[test]
fn a_reply_later_than_its_deadline_ends_the_link_with_a_reply_timeout() {
    let clock = Clock::new();
    let mut core = connected(&clock, RUNNING);
    core.begin_request(clock.t(100), 0, poll(Kind::Poll))
        .unwrap();
    write_all(&mut core, clock.t(100));
    assert_eq!(core.poll_timeout(), Some(clock.t(350)));
    core.handle_timeout(clock.t(349));
    assert_eq!(core.poll_event(), None, "not yet");
    core.handle_timeout(clock.t(350));
    let cause = LinkError::ReplyTimeout {
        request: "0 0 0".into(),
        deadline: ms(250),
    };
    assert_eq!(
        events(&mut core),
        vec![
            Event::ExchangeFailed {
                request: poll(Kind::Poll),
                cause: cause.clone(),
            },
            Event::LinkEnded {
                at: clock.t(350),
                cause: link_lost(cause),
            },
        ]
    );
    assert!(core.is_ended());
    assert_eq!(core.poll_timeout(), None);
}

#[test]
fn each_request_has_its_own_deadline_counted_from_its_start() {
    let clock = Clock::new();
    let mut core = SessionCore::new(timeouts());
    // The connect poll gets what is left of the connect timeout.
    core.begin_request(clock.t(0), 0, poll(Kind::Poll).with_reply_timeout(ms(40)))
        .unwrap();
    write_all(&mut core, clock.t(0));
    assert_eq!(core.poll_timeout(), Some(clock.t(40)));
    core.handle_input(clock.t(5), RUNNING.as_bytes());
    done(&mut core);
    core.begin_request(clock.t(70), 0, poll(Kind::Poll))
        .unwrap();
    assert_eq!(
        core.poll_timeout(),
        Some(clock.t(120)),
        "the write deadline first"
    );
    write_all(&mut core, clock.t(71));
    assert_eq!(
        core.poll_timeout(),
        Some(clock.t(320)),
        "the session's reply timeout"
    );
}

#[test]
fn a_request_not_flushed_within_the_write_timeout_ends_the_link() {
    let clock = Clock::new();
    let mut core = connected(&clock, RUNNING);
    core.begin_request(clock.t(10), 0, poll(Kind::Poll))
        .unwrap();
    core.handle_written(4);
    assert_eq!(core.poll_timeout(), Some(clock.t(60)));
    core.handle_timeout(clock.t(60));
    assert_eq!(
        events(&mut core)[0],
        Event::ExchangeFailed {
            request: poll(Kind::Poll),
            cause: LinkError::WriteTimeout {
                request: "0 0 0".into(),
                deadline: ms(50),
            },
        }
    );
    assert!(core.is_ended());
}

#[test]
fn a_second_request_is_refused_while_the_first_is_in_flight() {
    let clock = Clock::new();
    let mut core = connected(&clock, RUNNING);
    core.begin_request(clock.t(10), 0, poll(Kind::Poll))
        .unwrap();
    assert_eq!(
        core.begin_request(clock.t(11), 0, poll(Kind::Command)),
        Err(Refusal::InFlight)
    );
    write_all(&mut core, clock.t(11));
    assert_eq!(
        core.begin_request(clock.t(12), 0, poll(Kind::Command)),
        Err(Refusal::InFlight),
        "written, reply outstanding"
    );
    core.handle_input(clock.t(13), RUNNING.as_bytes());
    done(&mut core);
    assert_eq!(
        core.begin_request(clock.t(14), 0, poll(Kind::Command)),
        Ok(())
    );
}

#[test]
fn bytes_with_no_request_outstanding_end_the_link_as_unsolicited() {
    let clock = Clock::new();
    let mut core = connected(&clock, RUNNING);
    core.handle_input(clock.t(30), b" 1040 2");
    let cause = link_lost(LinkError::Unsolicited {
        excerpt: " 1040 2".into(),
    });
    assert_eq!(
        events(&mut core),
        vec![Event::LinkEnded {
            at: clock.t(30),
            cause: cause.clone(),
        }]
    );
    assert_eq!(
        core.begin_request(clock.t(31), 0, poll(Kind::Poll)),
        Err(Refusal::Ended(cause))
    );
}

#[test]
fn bytes_after_a_complete_reply_end_the_link_as_unsolicited() {
    let clock = Clock::new();
    let mut core = connected(&clock, RUNNING);
    core.begin_request(clock.t(10), 0, poll(Kind::Poll))
        .unwrap();
    write_all(&mut core, clock.t(10));
    core.handle_input(clock.t(11), format!("{RUNNING}1040").as_bytes());
    let ev = events(&mut core);
    assert!(
        matches!(
            ev.as_slice(),
            [Event::ExchangeFailed { cause: LinkError::Unsolicited { excerpt }, .. }, Event::LinkEnded { .. }]
                if excerpt == "1040"
        ),
        "{ev:?}"
    );
}

#[test]
fn a_reply_of_another_version_ends_the_link_as_not_a_controller() {
    let clock = Clock::new();
    let mut core = SessionCore::new(timeouts());
    core.begin_request(clock.t(0), 0, poll(Kind::Poll)).unwrap();
    write_all(&mut core, clock.t(0));
    core.handle_input(clock.t(1), RUNNING.replace("1040", "2000").as_bytes());
    assert!(matches!(
        events(&mut core).as_slice(),
        [
            Event::ExchangeFailed {
                cause: LinkError::NotAController { version: 2000 },
                ..
            },
            Event::LinkEnded { .. }
        ]
    ));
}

#[test]
fn bytes_that_cannot_be_a_reply_end_the_link_as_undecodable() {
    let clock = Clock::new();
    let mut core = connected(&clock, RUNNING);
    core.begin_request(clock.t(10), 0, poll(Kind::Poll))
        .unwrap();
    write_all(&mut core, clock.t(10));
    core.handle_input(clock.t(11), b"HTTP/1.1 400 Bad Request\r\n\r\n");
    assert!(matches!(
        events(&mut core).as_slice(),
        [
            Event::ExchangeFailed {
                cause: LinkError::Undecodable(_),
                ..
            },
            Event::LinkEnded { .. }
        ]
    ));
}

#[test]
fn the_peer_closing_mid_request_ends_the_link_as_closed() {
    let clock = Clock::new();
    let mut core = connected(&clock, RUNNING);
    core.begin_request(clock.t(10), 0, poll(Kind::Poll))
        .unwrap();
    write_all(&mut core, clock.t(10));
    core.handle_closed(clock.t(12));
    assert_eq!(
        events(&mut core)[1],
        Event::LinkEnded {
            at: clock.t(12),
            cause: link_lost(LinkError::Closed),
        }
    );
}

#[test]
fn a_motion_validated_before_a_cancel_is_refused_with_nothing_written() {
    let clock = Clock::new();
    let mut core = connected(&clock, RUNNING);
    assert_eq!(
        core.begin_request(clock.t(10), 1, motion(0)),
        Err(Refusal::StaleEpoch),
        "validated in epoch 0, a cancel made it 1"
    );
    assert_eq!(core.poll_transmit(), None, "nothing to write");
    assert!(Refusal::StaleEpoch.is_check());
    assert_eq!(
        Refusal::StaleEpoch.into_error(),
        ClientError::Cancelled(Cancellation::NotSent)
    );
    assert_eq!(core.begin_request(clock.t(11), 1, motion(1)), Ok(()));
    assert_eq!(
        write_all(&mut core, clock.t(11)),
        MOTION_TEXT.as_bytes(),
        "a motion of the current epoch goes out"
    );
}

#[test]
fn a_motion_is_refused_while_the_latest_status_blocks_motion() {
    let clock = Clock::new();
    let mut core = connected(&clock, HELD);
    assert_eq!(
        core.begin_request(clock.t(10), 0, motion(0)),
        Err(Refusal::Blocked(vec![Blocker::Hold]))
    );
    assert_eq!(core.poll_transmit(), None);
    // A poll is not a motion: it goes out, and its reply is the new latest status.
    core.begin_request(clock.t(20), 0, poll(Kind::Poll))
        .unwrap();
    write_all(&mut core, clock.t(20));
    core.handle_input(clock.t(21), RUNNING.as_bytes());
    done(&mut core);
    assert!(core.latest_status().is_some_and(|s| s.run));
    assert_eq!(core.begin_request(clock.t(22), 0, motion(0)), Ok(()));
}

#[test]
fn a_motion_before_any_status_is_refused() {
    let clock = Clock::new();
    let mut core = SessionCore::new(timeouts());
    assert!(matches!(
        core.begin_request(clock.t(0), 0, motion(0)),
        Err(Refusal::Ended(_))
    ));
}

#[test]
fn a_keep_alive_poll_is_due_one_period_after_the_last_reply() {
    let clock = Clock::new();
    let mut core = connected(&clock, RUNNING);
    assert_eq!(core.watch_idle_at(), Some(clock.t(50)), "half a period");
    assert_eq!(core.poll_timeout(), Some(clock.t(100)));
    core.handle_timeout(clock.t(99));
    assert_eq!(core.poll_event(), None);
    core.handle_timeout(clock.t(100));
    assert_eq!(events(&mut core), vec![Event::KeepAliveDue]);
    core.handle_timeout(clock.t(101));
    assert_eq!(core.poll_event(), None, "said once");
    core.begin_request(clock.t(101), 0, poll(Kind::KeepAlive))
        .unwrap();
    write_all(&mut core, clock.t(101));
    core.handle_input(clock.t(102), RUNNING.as_bytes());
    done(&mut core);
    assert_eq!(
        core.poll_timeout(),
        Some(clock.t(202)),
        "one period after that reply"
    );
    assert_eq!(core.watch_idle_at(), Some(clock.t(152)));
}

#[test]
fn requests_postpone_the_keep_alive() {
    let clock = Clock::new();
    let mut core = connected(&clock, RUNNING);
    for k in 1..=5u64 {
        core.begin_request(clock.t(40 * k), 0, poll(Kind::Command))
            .unwrap();
        write_all(&mut core, clock.t(40 * k));
        core.handle_input(clock.t(40 * k + 1), RUNNING.as_bytes());
        done(&mut core);
        core.handle_timeout(clock.t(40 * k + 1));
        assert_eq!(core.poll_event(), None, "no keep-alive while requests flow");
    }
    assert_eq!(core.poll_timeout(), Some(clock.t(301)));
}

#[test]
fn after_255_the_session_waits_for_the_close_and_ends_closed() {
    let clock = Clock::new();
    let mut core = connected(&clock, RUNNING);
    let close = WireRequest::new(Kind::Close, "1040 255 0".into(), None);
    core.begin_request(clock.t(10), 0, close).unwrap();
    write_all(&mut core, clock.t(10));
    core.handle_input(clock.t(11), RUNNING.as_bytes());
    done(&mut core);
    assert!(core.is_closing());
    assert_eq!(core.poll_timeout(), Some(clock.t(2011)));
    assert_eq!(
        core.begin_request(clock.t(12), 0, poll(Kind::Poll)),
        Err(Refusal::Closing)
    );
    core.handle_input(clock.t(13), b"whatever");
    assert_eq!(
        core.poll_event(),
        None,
        "bytes before the close are of no interest"
    );
    core.handle_closed(clock.t(14));
    assert_eq!(
        events(&mut core),
        vec![Event::LinkEnded {
            at: clock.t(14),
            cause: ClientError::Closed,
        }]
    );
}

#[test]
fn after_255_a_server_that_does_not_close_ends_the_session_at_the_close_timeout() {
    let clock = Clock::new();
    let mut core = connected(&clock, RUNNING);
    let close = WireRequest::new(Kind::Close, "1040 255 0".into(), None);
    core.begin_request(clock.t(10), 0, close).unwrap();
    write_all(&mut core, clock.t(10));
    core.handle_input(clock.t(11), RUNNING.as_bytes());
    done(&mut core);
    core.handle_timeout(clock.t(2010));
    assert_eq!(core.poll_event(), None);
    core.handle_timeout(clock.t(2011));
    assert_eq!(
        events(&mut core),
        vec![
            Event::CloseUnconfirmed(LinkError::ReplyTimeout {
                request: "end of stream after 255".into(),
                deadline: ms(2000),
            }),
            Event::LinkEnded {
                at: clock.t(2011),
                cause: ClientError::Closed,
            },
        ]
    );
}

#[test]
fn an_ended_session_refuses_every_request_with_its_first_cause() {
    let clock = Clock::new();
    let mut core = connected(&clock, RUNNING);
    core.handle_closed(clock.t(20));
    core.end(clock.t(21), ClientError::Closed);
    assert_eq!(events(&mut core).len(), 1, "ended once");
    for request in [poll(Kind::Poll), motion(0)] {
        assert_eq!(
            core.begin_request(clock.t(30), 0, request),
            Err(Refusal::Ended(link_lost(LinkError::Closed)))
        );
    }
    core.handle_input(clock.t(31), b"x");
    core.handle_timeout(clock.t(10_000));
    assert_eq!(core.poll_event(), None, "nothing happens after the end");
}

#[test]
fn the_driver_can_end_a_request_in_flight_without_a_reply() {
    let clock = Clock::new();
    let mut core = connected(&clock, RUNNING);
    core.begin_request(clock.t(10), 0, poll(Kind::Poll))
        .unwrap();
    core.end(clock.t(11), link_lost(LinkError::SessionEnded));
    assert_eq!(
        events(&mut core),
        vec![Event::LinkEnded {
            at: clock.t(11),
            cause: link_lost(LinkError::SessionEnded),
        }]
    );
    assert!(!core.in_flight());
}
