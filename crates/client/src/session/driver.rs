//! The driver of the session core for one request: begin it, drive the connection, consume
//! the core's events (publish, count, record, end); the completion of a request whose caller's
//! future was dropped.

use std::borrow::Cow;
use std::future::Future;
use std::sync::atomic::Ordering;
use std::sync::Arc;
use std::task::Poll;

use tokio::sync::OwnedMutexGuard;
use tokio::time::Instant;

use super::conn::Exchange;
use super::core::{Event, Kind, MotionTag, WireRequest};
use super::shared::{lock, Common, Io, SessionShared, StatusSnapshot};
use crate::error::{ClientError, LinkError};
use crate::record::Dir;

/// What the driver learned from the core's events.
#[derive(Default)]
pub(super) struct Drained {
    /// The outcome of the request that was in flight, if it ended.
    pub(super) exchange: Option<Result<Exchange, ClientError>>,
    /// A keep-alive poll is due.
    pub(super) keepalive_due: bool,
}

impl SessionShared {
    /// Takes the connection; if the keeper task holds it while watching the idle connection,
    /// asks it to let go (after queueing, so the mutex's FIFO order hands it to this caller).
    pub(super) async fn lock_io(&self) -> OwnedMutexGuard<Io> {
        let acquire = self.io.clone().lock_owned();
        tokio::pin!(acquire);
        let first = std::future::poll_fn(|cx| Poll::Ready(acquire.as_mut().poll(cx))).await;
        match first {
            Poll::Ready(io) => io,
            Poll::Pending => {
                self.wanted.notify_one();
                acquire.await
            }
        }
    }

    pub(super) fn idle_watch_at(&self) -> Instant {
        *lock(&self.idle_watch_at)
    }

    /// Asks the core to begin `request` at `now`. A refusal is returned as the caller's error
    /// (the checks of a motion are counted as refused before sending).
    pub(super) fn begin(
        &self,
        io: &mut Io,
        now: Instant,
        request: WireRequest,
    ) -> Result<(), ClientError> {
        let Some(conn) = io.conn.as_mut() else {
            return Err(self.death());
        };
        let kind = request.kind;
        match conn
            .core
            .begin_request(now.into_std(), self.current_epoch(), request)
        {
            Ok(()) => {
                if self.common.recorder.is_some() {
                    if let Some(text) = conn.core.request_in_flight().map(|r| &r.text) {
                        self.common
                            .record(now, self.id, Dir::Tx, kind.as_str(), None, text);
                    }
                }
                Ok(())
            }
            Err(refusal) => {
                if refusal.is_check() {
                    self.common.refused();
                }
                let e = refusal.into_error();
                // Unsolicited bytes found before the request end the link.
                self.drain(io);
                Err(e)
            }
        }
    }

    /// Consumes the core's events: a reply is published and counted, a failed request counted,
    /// an ended link closed.
    pub(super) fn drain(&self, io: &mut Io) -> Drained {
        let mut drained = Drained::default();
        while let Some(conn) = io.conn.as_mut() {
            let Some(event) = conn.core.poll_event() else {
                break;
            };
            match event {
                Event::ExchangeDone { request, reply } => {
                    let seq = reply.seq;
                    let ex = Exchange::from_reply(reply);
                    if let Some(at) = conn.core.watch_idle_at() {
                        *lock(&self.idle_watch_at) = Instant::from_std(at);
                    }
                    self.completed(io, &request.text, request.kind, &ex, seq);
                    if let Some(tag) = request.motion {
                        self.last_motion.store(tag.id, Ordering::Relaxed);
                    }
                    drained.exchange = Some(Ok(ex));
                }
                Event::ExchangeFailed { request, cause } => {
                    tracing::debug!(session = self.id, kind = request.kind.as_str(), request = ?request.text, error = %cause, "exchange failed");
                    lock(&self.common.stats).stats.requests += 1;
                    drained.exchange = Some(Err(ClientError::LinkLost(cause)));
                }
                Event::KeepAliveDue => drained.keepalive_due = true,
                Event::CloseUnconfirmed(e) => {
                    tracing::warn!(error = %e, "the controller did not close the connection after 255");
                }
                Event::LinkEnded { at, cause } => self.ended(io, Instant::from_std(at), cause),
            }
        }
        drained
    }

    /// Statistics, clock, recording, log and status of a completed round trip.
    pub(super) fn completed(&self, io: &mut Io, text: &str, kind: Kind, ex: &Exchange, seq: u64) {
        let common = &self.common;
        let cfg = &common.config;
        let id = self.id;
        let rtt = ex.rtt();
        common.record(
            ex.received_at,
            id,
            Dir::Rx,
            kind.as_str(),
            Some(rtt),
            &ex.frame.text,
        );
        {
            let mut st = lock(&common.stats);
            st.stats.requests += 1;
            if kind == Kind::KeepAlive {
                st.stats.keepalive_polls += 1;
            }
            st.record_rtt(rtt, rtt > cfg.late_reply_after);
            st.record_timer(ex.frame.status.timer);
        }
        if let Some(t) = ex.frame.status.timer.seconds() {
            lock(&self.clock).add(ex.sent_at, ex.received_at, t);
        }
        if kind == Kind::KeepAlive {
            tracing::trace!(
                session = id,
                kind = kind.as_str(),
                request = ?text,
                reply = ?ex.frame.text,
                rtt_us = u64::try_from(rtt.as_micros()).unwrap_or(u64::MAX),
                "exchange"
            );
        } else {
            tracing::debug!(
                session = id,
                kind = kind.as_str(),
                request = ?text,
                reply = ?ex.frame.text,
                rtt_us = u64::try_from(rtt.as_micros()).unwrap_or(u64::MAX),
                "exchange"
            );
        }
        if let Some(status_tx) = &io.status_tx {
            status_tx.send_replace(StatusSnapshot {
                status: ex.frame.status.clone(),
                received_at: ex.received_at,
                rtt,
                seq,
            });
        }
    }

    /// Ends the session for a reason of the driver's (the first cause wins).
    pub(super) fn end(&self, io: &mut Io, end: ClientError) {
        if let Some(conn) = io.conn.as_mut() {
            conn.core.end(Instant::now().into_std(), end);
        }
        self.drain(io);
    }

    /// The core ended the session: the cause is stored for every caller, the connection
    /// closed, the status subscribers see the end.
    pub(super) fn ended(&self, io: &mut Io, at: Instant, end: ClientError) {
        if io.conn.is_none() {
            return;
        }
        let common = &self.common;
        if end != ClientError::Closed {
            lock(&common.stats).stats.links_lost += 1;
            // The cause is returned to every caller; this is only a trace for the logs.
            tracing::info!(session = self.id, error = %end, "link lost");
        } else {
            tracing::info!(session = self.id, "session closed");
        }
        common.record(at, self.id, Dir::Event, "end", None, &end.to_string());
        // Record the cause before anyone sees the connection gone.
        self.set_dead(end);
        io.conn = None;
        io.status_tx = None;
        // The keeper may be watching the connection: let it see the end.
        self.wanted.notify_one();
    }
}

/// Carries a request's exchange; if dropped before the reply is in (the caller's future was
/// dropped), a spawned task completes it so the connection stays in lock-step.
pub(super) struct InFlight {
    shared: Arc<SessionShared>,
    io: Option<OwnedMutexGuard<Io>>,
    /// This is already the spawned completion: if it is dropped too (the runtime shuts down),
    /// the session ends.
    fallback: bool,
}

impl InFlight {
    /// Completes the exchange (in the caller's task or the fallback).
    pub(super) async fn run(&mut self) -> Result<Exchange, ClientError> {
        let Some(io) = self.io.as_mut() else {
            return Err(self.shared.death());
        };
        let Some(conn) = io.conn.as_mut() else {
            return Err(self.shared.death());
        };
        conn.drive().await;
        // From here on nothing awaits: the exchange is complete whether or not the caller
        // is still there.
        match self.shared.drain(io).exchange {
            Some(r) => r,
            None => Err(self.shared.death()),
        }
    }
}

impl Drop for InFlight {
    fn drop(&mut self) {
        let Some(io) = self.io.take() else { return };
        if io.conn.as_ref().is_none_or(|c| !c.core.in_flight()) {
            return;
        }
        let mut rest = InFlight {
            shared: self.shared.clone(),
            io: Some(io),
            fallback: true,
        };
        match tokio::runtime::Handle::try_current() {
            Ok(rt) if !self.fallback => {
                rt.spawn(async move {
                    // Completed (or the session ended): dropping `rest` releases the connection.
                    let _ = rest.run().await;
                });
            }
            // No runtime to finish it on: the connection cannot stay in lock-step.
            _ => {
                if let Some(io) = rest.io.as_mut() {
                    rest.shared
                        .end(io, ClientError::LinkLost(LinkError::SessionEnded));
                }
            }
        }
    }
}

/// Counts a motion as refused before sending if its caller's future is dropped while this lives.
pub(super) struct CallerGone<'a>(&'a Common);

impl Drop for CallerGone<'_> {
    fn drop(&mut self) {
        self.0.refused();
        tracing::debug!("motion not sent: its caller is gone");
    }
}

/// One exchange on the connection held by `io`.
pub(super) async fn exchange_locked(
    shared: &Arc<SessionShared>,
    mut io: OwnedMutexGuard<Io>,
    text: Cow<'static, str>,
    kind: Kind,
    motion: Option<MotionTag>,
    second_poll: bool,
) -> Result<Exchange, ClientError> {
    if io.conn.is_none() {
        return Err(shared.death());
    }
    if motion.is_some() && second_poll {
        let gone = CallerGone(&shared.common);
        tokio::task::yield_now().await;
        std::mem::forget(gone);
    }
    shared.begin(
        &mut io,
        Instant::now(),
        WireRequest::new(kind, text, motion),
    )?;
    let mut flight = InFlight {
        shared: shared.clone(),
        io: Some(io),
        fallback: false,
    };
    let r = flight.run().await;
    let Some(mut io) = flight.io.take() else {
        return Err(shared.death());
    };
    let ex = r?;
    if kind == Kind::Close {
        if let Some(conn) = io.conn.as_mut() {
            conn.await_close().await;
        }
        shared.drain(&mut io);
        shared.end(&mut io, ClientError::Closed);
    }
    Ok(ex)
}
