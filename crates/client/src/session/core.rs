//! The session's rules as a state machine without I/O and without a clock (sans-IO, in the
//! shape of quinn-proto's `Connection`).
//!
//! [`SessionCore`] knows what may be sent, when a reply is complete, when a deadline has passed
//! and when the link is over; it never reads, writes or looks at a clock. Its driver (the tokio
//! code around it: `conn.rs` moves the bytes, `driver.rs` and `keeper.rs` consume the events)
//! passes the time in as data (`std::time::Instant` values, so tests use a fake clock), and the
//! session's motion epoch with each request:
//!
//! | to the core                                   | from the core                              |
//! |-----------------------------------------------|--------------------------------------------|
//! | [`begin_request`](SessionCore::begin_request) | its [`Refusal`], or a request in flight   |
//! | [`handle_written`](SessionCore::handle_written), [`handle_flushed`](SessionCore::handle_flushed) | [`poll_transmit`](SessionCore::poll_transmit): what to write |
//! | [`handle_input`](SessionCore::handle_input), [`handle_closed`](SessionCore::handle_closed), [`handle_failure`](SessionCore::handle_failure) | [`poll_event`](SessionCore::poll_event): [`Event`]s |
//! | [`handle_timeout`](SessionCore::handle_timeout) | [`poll_timeout`](SessionCore::poll_timeout): the next deadline |
//! | [`end`](SessionCore::end) (the driver's own reasons) | [`watch_idle_at`](SessionCore::watch_idle_at), [`in_flight`](SessionCore::in_flight), [`is_closing`](SessionCore::is_closing) |
//!
//! The rules, one place each:
//!
//! * **strict lock-step**: one request at a time; a second one is refused while the first is in
//!   flight or while the session waits for its close;
//! * **deadlines per request**: the request must be written and flushed within the write
//!   timeout, its reply complete within the reply timeout, both counted from
//!   [`begin_request`](SessionCore::begin_request);
//! * **a reply is complete at its final blank**; bytes that would be a complete reply but for
//!   it are taken once the peer has been quiet for [`OPEN_REPLY_QUIET`];
//! * **every reply says 1040**, and nothing follows it before the next request;
//! * **no unsolicited bytes**: bytes that arrive while no request is outstanding end the link
//!   (blanks excepted: a late final blank);
//! * **the motion-epoch check**: a motion validated in an older epoch, or while the latest
//!   status blocks motion, is refused before anything is written;
//! * **keep-alive**: once nothing was exchanged for a keep-alive period, a poll is due; the idle
//!   connection is worth watching after half a period;
//! * **after 255**, the server must close the connection within the close timeout;
//! * **the first failure ends the session**: the cause is kept and every later request is
//!   refused with it.

use std::collections::VecDeque;
use std::time::{Duration, Instant};

use fs020n_proto::{ReplyDecoder, ReplyFrame, Status, PROTOCOL_VERSION};

use crate::error::{ClientError, LinkError};
use crate::safety::blockers;

mod event;
mod request;
#[cfg(test)]
mod tests;

pub(crate) use self::event::{Event, Reply, Transmit};
pub(crate) use self::request::{Kind, MotionTag, Refusal, Timeouts, WireRequest};

/// How long bytes that form a complete reply but for the final blank wait for more before they
/// are taken as the reply (the controller sends the blank in the same write: this is only for a
/// peer that omits it).
pub(crate) const OPEN_REPLY_QUIET: Duration = Duration::from_millis(20);

/// A request being written or awaiting its reply.
#[derive(Debug)]
struct Flight {
    request: WireRequest,
    written: usize,
    flushed: bool,
    sent_at: Instant,
    write_deadline: Instant,
    write_timeout: Duration,
    deadline: Instant,
    reply_timeout: Duration,
    /// When bytes that may be a reply without its final blank are taken as the reply.
    quiet_at: Option<Instant>,
}

#[derive(Debug)]
enum State {
    /// No request outstanding.
    Idle,
    Flight(Flight),
    /// 255 answered: waiting for the server's close until `deadline`.
    Closing {
        deadline: Instant,
    },
    Ended,
}

/// The session's rules (see the module documentation for its API and rules).
#[derive(Debug)]
pub(crate) struct SessionCore {
    timeouts: Timeouts,
    decoder: ReplyDecoder,
    state: State,
    /// The first cause of the end, kept for every later request.
    ended: Option<ClientError>,
    events: VecDeque<Event>,
    latest: Option<Status>,
    replies: u64,
    last_exchange: Option<Instant>,
    keepalive_signalled: bool,
}

impl SessionCore {
    pub(crate) fn new(timeouts: Timeouts) -> SessionCore {
        SessionCore {
            timeouts,
            decoder: ReplyDecoder::new(),
            state: State::Idle,
            ended: None,
            events: VecDeque::new(),
            latest: None,
            replies: 0,
            last_exchange: None,
            keepalive_signalled: false,
        }
    }

    /// Puts `request` in flight at `now`, or refuses it. `epoch` is the session's motion epoch
    /// now: a motion validated in another one is refused, as is a motion while the latest
    /// status blocks motion (or before any status). Bytes buffered from the peer at this point
    /// were unsolicited: the link ends ([`Refusal::Ended`]).
    pub(crate) fn begin_request(
        &mut self,
        now: Instant,
        epoch: u64,
        request: WireRequest,
    ) -> Result<(), Refusal> {
        match &self.state {
            State::Idle => {}
            State::Flight(_) => return Err(Refusal::InFlight),
            State::Closing { .. } => return Err(Refusal::Closing),
            State::Ended => return Err(Refusal::Ended(self.cause())),
        }
        if let Some(tag) = request.motion {
            if tag.epoch != epoch {
                return Err(Refusal::StaleEpoch);
            }
            let Some(status) = &self.latest else {
                return Err(Refusal::Ended(self.cause()));
            };
            let b = blockers(status, true);
            if !b.is_empty() {
                return Err(Refusal::Blocked(b));
            }
        }
        if let Some(e) = self.unsolicited() {
            let cause = ClientError::LinkLost(e);
            self.end(now, cause.clone());
            return Err(Refusal::Ended(cause));
        }
        let write_timeout = self.timeouts.write;
        let reply_timeout = request.reply_timeout.unwrap_or(self.timeouts.reply);
        self.keepalive_signalled = false;
        self.state = State::Flight(Flight {
            request,
            written: 0,
            flushed: false,
            sent_at: now,
            write_deadline: now + write_timeout,
            write_timeout,
            deadline: now + reply_timeout,
            reply_timeout,
            quiet_at: None,
        });
        Ok(())
    }

    /// What the driver should write next, if anything.
    pub(crate) fn poll_transmit(&self) -> Option<Transmit<'_>> {
        match &self.state {
            State::Flight(f) if f.written < f.request.text.len() => {
                Some(Transmit::Bytes(&f.request.text.as_bytes()[f.written..]))
            }
            State::Flight(f) if !f.flushed => Some(Transmit::Flush),
            _ => None,
        }
    }

    /// `n` more bytes of the request were written.
    pub(crate) fn handle_written(&mut self, n: usize) {
        if let State::Flight(f) = &mut self.state {
            f.written = (f.written + n).min(f.request.text.len());
        }
    }

    /// The request was flushed: from now on its reply is awaited.
    pub(crate) fn handle_flushed(&mut self, now: Instant) {
        if let State::Flight(f) = &mut self.state {
            if f.written == f.request.text.len() {
                f.flushed = true;
                self.decode(now, false);
            }
        }
    }

    /// Bytes from the peer, read at `now`.
    pub(crate) fn handle_input(&mut self, now: Instant, bytes: &[u8]) {
        match &self.state {
            State::Ended => {}
            // Whatever the server sends before its close is of no interest.
            State::Closing { .. } => {}
            State::Idle => {
                let r = self
                    .decoder
                    .push(bytes)
                    .map_err(LinkError::Undecodable)
                    .and_then(|()| self.unsolicited().map_or(Ok(()), Err));
                if let Err(e) = r {
                    self.end(now, ClientError::LinkLost(e));
                }
            }
            State::Flight(_) => match self.decoder.push(bytes) {
                Err(e) => self.fail(now, LinkError::Undecodable(e)),
                Ok(()) => self.decode(now, false),
            },
        }
    }

    /// The peer closed the connection (a read of 0 bytes, or a write of 0).
    pub(crate) fn handle_closed(&mut self, now: Instant) {
        match &self.state {
            State::Ended => {}
            State::Closing { .. } => self.end(now, ClientError::Closed),
            State::Idle => self.end(now, ClientError::LinkLost(LinkError::Closed)),
            State::Flight(_) => self.fail(now, LinkError::Closed),
        }
    }

    /// Reading or writing failed.
    pub(crate) fn handle_failure(&mut self, now: Instant, cause: LinkError) {
        match &self.state {
            State::Ended => {}
            State::Closing { .. } => {
                self.events.push_back(Event::CloseUnconfirmed(cause));
                self.end(now, ClientError::Closed);
            }
            State::Idle => self.end(now, ClientError::LinkLost(cause)),
            State::Flight(_) => self.fail(now, cause),
        }
    }

    /// The next instant at which [`handle_timeout`](Self::handle_timeout) has something to do:
    /// the write deadline, the end of the quiet wait, the reply deadline, the close deadline or
    /// when a keep-alive poll is due.
    pub(crate) fn poll_timeout(&self) -> Option<Instant> {
        match &self.state {
            State::Flight(f) if !f.flushed => Some(f.write_deadline),
            State::Flight(f) => Some(f.quiet_at.unwrap_or(f.deadline)),
            State::Closing { deadline } => Some(*deadline),
            State::Idle => self
                .last_exchange
                .map(|at| at + self.timeouts.keepalive_period),
            State::Ended => None,
        }
    }

    /// Time has come to `now`: deadlines that have passed take effect.
    pub(crate) fn handle_timeout(&mut self, now: Instant) {
        match &mut self.state {
            State::Ended => {}
            State::Idle => {
                let due = self
                    .last_exchange
                    .map(|at| at + self.timeouts.keepalive_period);
                if due.is_some_and(|due| now >= due) && !self.keepalive_signalled {
                    self.keepalive_signalled = true;
                    self.events.push_back(Event::KeepAliveDue);
                }
            }
            State::Closing { deadline } => {
                if now >= *deadline {
                    let cause = LinkError::ReplyTimeout {
                        request: "end of stream after 255".into(),
                        deadline: self.timeouts.close,
                    };
                    self.events.push_back(Event::CloseUnconfirmed(cause));
                    self.end(now, ClientError::Closed);
                }
            }
            State::Flight(f) if !f.flushed => {
                if now >= f.write_deadline {
                    let cause = LinkError::WriteTimeout {
                        request: f.request.text.clone().into_owned(),
                        deadline: f.write_timeout,
                    };
                    self.fail(now, cause);
                }
            }
            State::Flight(f) => {
                if f.quiet_at.is_some_and(|at| now >= at) {
                    f.quiet_at = None;
                    self.decode(now, true);
                } else if now >= f.deadline {
                    let cause = LinkError::ReplyTimeout {
                        request: f.request.text.clone().into_owned(),
                        deadline: f.reply_timeout,
                    };
                    self.fail(now, cause);
                }
            }
        }
    }

    /// The next event, in the order they happened.
    pub(crate) fn poll_event(&mut self) -> Option<Event> {
        self.events.pop_front()
    }

    /// Ends the session for a reason of the driver's (a polite close done, no runtime left to
    /// complete a request on): nothing more is sent. The first cause wins.
    pub(crate) fn end(&mut self, at: Instant, cause: ClientError) {
        if self.ended.is_some() {
            return;
        }
        self.ended = Some(cause.clone());
        self.state = State::Ended;
        self.events.push_back(Event::LinkEnded { at, cause });
    }

    /// The request being written or awaiting its reply.
    pub(crate) fn request_in_flight(&self) -> Option<&WireRequest> {
        match &self.state {
            State::Flight(f) => Some(&f.request),
            _ => None,
        }
    }

    /// `true` while a request is being written or awaits its reply.
    pub(crate) fn in_flight(&self) -> bool {
        matches!(self.state, State::Flight(_))
    }

    /// `true` while the session waits for the server to close after 255.
    pub(crate) fn is_closing(&self) -> bool {
        matches!(self.state, State::Closing { .. })
    }

    /// `true` once the session has ended.
    #[cfg(test)]
    pub(crate) fn is_ended(&self) -> bool {
        matches!(self.state, State::Ended)
    }

    /// The status of the latest reply (the one the motion checks use).
    #[cfg(test)]
    pub(crate) fn latest_status(&self) -> Option<&Status> {
        self.latest.as_ref()
    }

    /// From when the idle connection is worth watching (for its close or unsolicited bytes):
    /// half a keep-alive period after the last reply. `None` before the first reply.
    pub(crate) fn watch_idle_at(&self) -> Option<Instant> {
        self.last_exchange
            .map(|at| at + self.timeouts.keepalive_period / 2)
    }

    fn cause(&self) -> ClientError {
        self.ended
            .clone()
            .unwrap_or(ClientError::LinkLost(LinkError::SessionEnded))
    }

    fn unsolicited(&self) -> Option<LinkError> {
        (!self.decoder.is_empty()).then(|| LinkError::Unsolicited {
            excerpt: String::from_utf8_lossy(
                &self.decoder.buffered()[..self.decoder.buffered().len().min(40)],
            )
            .into_owned(),
        })
    }

    /// Looks for the reply in the bytes received (`quiet`: the peer has been quiet long
    /// enough to take a reply without its final blank).
    fn decode(&mut self, now: Instant, quiet: bool) {
        let deadline = match &self.state {
            State::Flight(f) if f.flushed => f.deadline,
            _ => return,
        };
        let next = if quiet {
            self.decoder.take_open_reply()
        } else {
            self.decoder.next_reply()
        };
        match next {
            Err(e) => self.fail(now, LinkError::Undecodable(e)),
            Ok(Some(frame)) => self.complete(now, frame),
            // A quiet wait that found nothing: look again as after new bytes.
            Ok(None) if quiet => self.decode(now, false),
            Ok(None) => {
                // The controller sends its final blank with the reply. Bytes that would be a
                // complete reply but for it are taken once the peer has been quiet a moment.
                let quiet_at = if self.decoder.may_be_open_reply() {
                    Some(now + OPEN_REPLY_QUIET).filter(|&at| at < deadline)
                } else {
                    None
                };
                if let State::Flight(f) = &mut self.state {
                    f.quiet_at = quiet_at;
                }
            }
        }
    }

    /// A reply is complete: nothing may follow it, and it must say 1040.
    fn complete(&mut self, now: Instant, frame: ReplyFrame) {
        if let Some(e) = self.unsolicited() {
            return self.fail(now, e);
        }
        if frame.status.version != PROTOCOL_VERSION {
            return self.fail(
                now,
                LinkError::NotAController {
                    version: frame.status.version,
                },
            );
        }
        let State::Flight(f) = std::mem::replace(&mut self.state, State::Idle) else {
            return;
        };
        let Flight {
            request, sent_at, ..
        } = f;
        if request.kind == Kind::Close {
            self.state = State::Closing {
                deadline: now + self.timeouts.close,
            };
        }
        let seq = self.replies;
        self.replies += 1;
        self.latest = Some(frame.status.clone());
        self.last_exchange = Some(now);
        self.events.push_back(Event::ExchangeDone {
            request,
            reply: Reply {
                frame,
                sent_at,
                received_at: now,
                seq,
            },
        });
    }

    /// The request in flight failed: the session ends with its cause.
    fn fail(&mut self, now: Instant, cause: LinkError) {
        let State::Flight(f) = std::mem::replace(&mut self.state, State::Idle) else {
            return;
        };
        self.events.push_back(Event::ExchangeFailed {
            request: f.request,
            cause: cause.clone(),
        });
        self.end(now, ClientError::LinkLost(cause));
    }
}
