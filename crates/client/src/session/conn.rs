//! The connection and the session core that rules it: the I/O a request needs (write, flush,
//! read, each bounded by the core's next deadline), fed back to the core.

use std::time::Duration;

use fs020n_proto::ReplyFrame;
use tokio::io::{AsyncReadExt, AsyncWriteExt};
use tokio::time::{timeout_at, Instant};

use super::core::{Event, Kind, Reply, SessionCore, Timeouts, Transmit, WireRequest};
use crate::config::ClientConfig;
use crate::error::{ClientError, LinkError};
use crate::transport::BoxedStream;

/// The status poll: a mismatched version, so the server changes nothing.
pub(crate) const POLL: &str = "0 0 0";

/// One completed round trip.
#[derive(Debug, Clone)]
pub(crate) struct Exchange {
    pub(crate) frame: ReplyFrame,
    pub(crate) sent_at: Instant,
    pub(crate) received_at: Instant,
}

impl Exchange {
    pub(crate) fn rtt(&self) -> Duration {
        self.received_at.duration_since(self.sent_at)
    }

    /// The core's reply on tokio's clock.
    pub(super) fn from_reply(reply: Reply) -> Exchange {
        Exchange {
            frame: reply.frame,
            sent_at: Instant::from_std(reply.sent_at),
            received_at: Instant::from_std(reply.received_at),
        }
    }
}

/// The session core's timeouts from the client's configuration.
pub(super) fn timeouts(cfg: &ClientConfig) -> Timeouts {
    Timeouts {
        write: cfg.write_timeout,
        reply: cfg.reply_timeout,
        keepalive_period: cfg.keepalive_period,
        close: cfg.close_timeout,
    }
}

/// A time to wait for when the core has no deadline (never while a request is in flight).
pub(super) fn far_future() -> Instant {
    Instant::now() + Duration::from_secs(86_400 * 365)
}

/// The connection with the session core that rules it.
pub(super) struct Conn {
    pub(super) stream: BoxedStream,
    pub(super) buf: Vec<u8>,
    pub(super) core: SessionCore,
}

impl Conn {
    pub(super) fn new(stream: BoxedStream, timeouts: Timeouts) -> Conn {
        Conn {
            stream,
            buf: vec![0; 1024],
            core: SessionCore::new(timeouts),
        }
    }

    /// Writes and reads what the core asks for until the request in flight is over (its reply
    /// complete, or the link ended). Cancel-safe: the progress lives in the core, so calling it
    /// again goes on where it stopped.
    pub(super) async fn drive(&mut self) {
        while self.core.in_flight() {
            self.step().await;
        }
    }

    /// After 255: reads until the server closes the connection or the core's close deadline.
    pub(super) async fn await_close(&mut self) {
        while self.core.is_closing() {
            self.step().await;
        }
    }

    /// One I/O operation the core asks for — write, flush, or read — bounded by the core's next
    /// deadline; its outcome goes to the core.
    pub(super) async fn step(&mut self) {
        let deadline = self
            .core
            .poll_timeout()
            .map_or_else(far_future, Instant::from_std);
        match self.core.poll_transmit() {
            Some(Transmit::Bytes(bytes)) => {
                match timeout_at(deadline, self.stream.write(bytes)).await {
                    Ok(Ok(n)) if n > 0 => self.core.handle_written(n),
                    Ok(Ok(_)) => self.core.handle_closed(Instant::now().into_std()),
                    Ok(Err(e)) => self
                        .core
                        .handle_failure(Instant::now().into_std(), LinkError::io(&e)),
                    Err(_) => self.core.handle_timeout(Instant::now().into_std()),
                }
            }
            Some(Transmit::Flush) => {
                let r = timeout_at(deadline, self.stream.flush()).await;
                let now = Instant::now().into_std();
                match r {
                    Err(_) => self.core.handle_timeout(now),
                    Ok(Err(e)) => self.core.handle_failure(now, LinkError::io(&e)),
                    Ok(Ok(())) => self.core.handle_flushed(now),
                }
            }
            None => {
                let r = timeout_at(deadline, self.stream.read(&mut self.buf)).await;
                self.feed(r);
            }
        }
    }

    /// The outcome of a read (bounded by a deadline) to the core.
    pub(super) fn feed(&mut self, r: Result<std::io::Result<usize>, tokio::time::error::Elapsed>) {
        let now = Instant::now().into_std();
        match r {
            Err(_) => self.core.handle_timeout(now),
            Ok(r) => self.feed_read(now, r),
        }
    }

    pub(super) fn feed_read(&mut self, now: std::time::Instant, r: std::io::Result<usize>) {
        match r {
            Err(e) => self.core.handle_failure(now, LinkError::io(&e)),
            Ok(0) => self.core.handle_closed(now),
            Ok(n) => self.core.handle_input(now, &self.buf[..n]),
        }
    }

    /// The connect poll: the first exchange, whose reply timeout is cut to what is left of the
    /// connect timeout.
    pub(super) async fn first_poll(
        &mut self,
        reply_timeout: Duration,
    ) -> Result<Exchange, LinkError> {
        let request =
            WireRequest::new(Kind::Poll, POLL.into(), None).with_reply_timeout(reply_timeout);
        if let Err(refusal) = self
            .core
            .begin_request(Instant::now().into_std(), 0, request)
        {
            return Err(match refusal.into_error() {
                ClientError::LinkLost(e) => e,
                _ => LinkError::SessionEnded,
            });
        }
        self.drive().await;
        while let Some(event) = self.core.poll_event() {
            match event {
                Event::ExchangeDone { reply, .. } => return Ok(Exchange::from_reply(reply)),
                Event::ExchangeFailed { cause, .. } => return Err(cause),
                _ => {}
            }
        }
        Err(LinkError::SessionEnded)
    }
}
