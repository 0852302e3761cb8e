//! The program's TCP stack as the emulator uses it: the controller's socket table
//! ([`fs020n_as::sockets::SocketTable`], shared with the interpreter's test system) with the
//! emulator's buffer sizes, the id a client of the controller is known by, and the mapping
//! from a reply fault to how the table delivers a reply.

use fs020n_as::sockets::{Delivery, SocketLimits, SocketTable};
use serde::Serialize;

pub use fs020n_as::sockets::ClientRead;

use crate::fault::ReplyFault;

/// Bytes a client's outgoing queue holds before the program's `TCP_SEND` waits (like a socket
/// send buffer: a client that stops reading makes the program's send time out).
pub const CLIENT_BUFFER: usize = 4096;

/// A client of the program's TCP stack (a connection to the controller; its socket id in
/// the table).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize)]
pub struct ClientId(pub i32);

/// An empty socket table with the emulator's buffers: a client's unread bytes up to
/// [`CLIENT_BUFFER`], a socket connected to the program's own listener up to 16 times that.
pub(crate) fn socket_table() -> SocketTable {
    SocketTable::new(SocketLimits {
        local_buffer: CLIENT_BUFFER * 16,
        client_buffer: CLIENT_BUFFER,
    })
}

/// How a reply reaches the client when `fault` is the next reply fault.
pub(crate) fn delivery_of(fault: Option<ReplyFault>) -> Delivery {
    match fault {
        None => Delivery::Now,
        Some(ReplyFault::Withhold) => Delivery::Withhold,
        Some(ReplyFault::Garbage(b)) => Delivery::Replace(b),
        Some(ReplyFault::Delay(d)) => Delivery::Delay(d),
        Some(ReplyFault::Split { parts, gap }) => Delivery::Split { parts, gap },
    }
}
