//! The session's keeper task: keep-alive polls, the stops queued by `Drop` impls, the polite
//! close, and the watch of the idle connection.

use std::borrow::Cow;
use std::ops::ControlFlow;
use std::sync::Arc;

use tokio::io::AsyncReadExt;
use tokio::sync::{mpsc, OwnedMutexGuard};
use tokio::time::{sleep_until, Instant};

use super::conn::{far_future, Exchange, POLL};
use super::core::{Kind, WireRequest};
use super::shared::{Io, SessionShared};
use crate::error::ClientError;

/// A request queued for the keeper task (a stop that nobody awaits).
pub(super) struct Op {
    pub(super) text: Cow<'static, str>,
    pub(super) kind: Kind,
}

/// The session's keeper task: keep-alive polls when the core says one is due, queued stops,
/// the polite close when every handle is gone, and — from when the core says the connection is
/// idle — watching it for its close or for bytes nobody asked for.
pub(super) async fn keeper(shared: Arc<SessionShared>, mut rx: mpsc::Receiver<Op>) {
    loop {
        if shared.is_dead() {
            break;
        }
        let idle_at = shared.idle_watch_at();
        tokio::select! {
            biased;
            op = rx.recv() => {
                let mut io = shared.lock_io().await;
                if serve(&shared, &mut io, op).await.is_break() {
                    break;
                }
                continue;
            }
            () = sleep_until(idle_at) => {}
        }
        let mut io = shared.io.clone().lock_owned().await;
        let Some(conn) = io.conn.as_ref() else {
            break;
        };
        if conn
            .core
            .watch_idle_at()
            .is_some_and(|at| Instant::now() < Instant::from_std(at))
        {
            continue;
        }
        // Idle: hold the connection and watch it until a caller wants it.
        loop {
            let Some(conn) = io.conn.as_mut() else {
                return;
            };
            let due = conn
                .core
                .poll_timeout()
                .map_or_else(far_future, Instant::from_std);
            let wake = tokio::select! {
                biased;
                r = conn.stream.read(&mut conn.buf) => Wake::Read(r),
                () = shared.wanted.notified() => Wake::Wanted,
                op = rx.recv() => Wake::Op(op),
                () = sleep_until(due) => Wake::Timeout,
            };
            let step = match wake {
                Wake::Read(r) => {
                    conn.feed_read(Instant::now().into_std(), r);
                    shared.drain(&mut io);
                    if io.conn.is_none() {
                        ControlFlow::Break(())
                    } else {
                        ControlFlow::Continue(())
                    }
                }
                Wake::Wanted => break,
                Wake::Op(op) => serve(&shared, &mut io, op).await,
                Wake::Timeout => {
                    conn.core.handle_timeout(Instant::now().into_std());
                    if shared.drain(&mut io).keepalive_due {
                        let r = exchange_in(&shared, &mut io, POLL.into(), Kind::KeepAlive).await;
                        if r.is_err() {
                            ControlFlow::Break(())
                        } else {
                            ControlFlow::Continue(())
                        }
                    } else if io.conn.is_none() {
                        ControlFlow::Break(())
                    } else {
                        ControlFlow::Continue(())
                    }
                }
            };
            if step.is_break() {
                return;
            }
        }
        drop(io);
    }
    // The session ended elsewhere: fail what is still queued.
    rx.close();
    while rx.try_recv().is_ok() {}
}

/// What woke the keeper task while it watched the idle connection.
pub(super) enum Wake {
    Read(std::io::Result<usize>),
    Wanted,
    Op(Option<Op>),
    Timeout,
}

/// Serves one queued request (`None`: every handle is gone, end the session politely).
pub(super) async fn serve(
    shared: &Arc<SessionShared>,
    io: &mut OwnedMutexGuard<Io>,
    op: Option<Op>,
) -> ControlFlow<()> {
    if io.conn.is_none() {
        return ControlFlow::Break(());
    }
    match op {
        None => {
            let _ = exchange_in(shared, io, "1040 255 0".into(), Kind::Close).await;
            shared.end(io, ClientError::Closed);
            ControlFlow::Break(())
        }
        Some(op) => match exchange_in(shared, io, op.text, op.kind).await {
            Ok(_) => ControlFlow::Continue(()),
            Err(_) => ControlFlow::Break(()),
        },
    }
}

/// An exchange of the keeper task on the connection it holds (not cancelled: the keeper is
/// never dropped mid-exchange except with the runtime).
pub(super) async fn exchange_in(
    shared: &Arc<SessionShared>,
    io: &mut OwnedMutexGuard<Io>,
    text: Cow<'static, str>,
    kind: Kind,
) -> Result<Exchange, ClientError> {
    shared.begin(io, Instant::now(), WireRequest::new(kind, text, None))?;
    if let Some(conn) = io.conn.as_mut() {
        conn.drive().await;
    }
    match shared.drain(io).exchange {
        Some(r) => r,
        None => Err(shared.death()),
    }
}
