//! What the session core tells its driver: events, and what to write.

use std::time::Instant;

use fs020n_proto::ReplyFrame;

use super::request::WireRequest;
use crate::error::{ClientError, LinkError};

/// A complete reply to a request.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Reply {
    pub(crate) frame: ReplyFrame,
    /// When the request began.
    pub(crate) sent_at: Instant,
    /// When the reply was complete.
    pub(crate) received_at: Instant,
    /// Replies in this session before this one.
    pub(crate) seq: u64,
}

/// What the core tells its driver.
#[derive(Debug, Clone, PartialEq)]
pub(crate) enum Event {
    /// The request's reply is complete (the status is now the latest).
    ExchangeDone { request: WireRequest, reply: Reply },
    /// The request failed; [`Event::LinkEnded`] follows.
    ExchangeFailed {
        request: WireRequest,
        cause: LinkError,
    },
    /// Nothing was exchanged for a keep-alive period: send a poll.
    KeepAliveDue,
    /// After 255 the server did not close the connection as it should (the session ends all
    /// the same: [`Event::LinkEnded`] follows).
    CloseUnconfirmed(LinkError),
    /// The session is over: drop the connection.
    LinkEnded { at: Instant, cause: ClientError },
}

/// What [`SessionCore::poll_transmit`](super::SessionCore::poll_transmit) asks the driver to do.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Transmit<'a> {
    /// Write these bytes (what is left of the request), then report with
    /// [`SessionCore::handle_written`](super::SessionCore::handle_written).
    Bytes(&'a [u8]),
    /// Flush, then report with [`SessionCore::handle_flushed`](super::SessionCore::handle_flushed).
    Flush,
}
