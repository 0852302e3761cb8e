//! The in-controller TCP stack an AS program's `TCP_…` instructions use: listeners with their
//! backlogs, and sockets whose peer is a client of the controller (the network layer, a test)
//! or another of the program's sockets.

use std::collections::{BTreeMap, VecDeque};
use std::time::Duration;

/// Bytes a client's outgoing queue holds before the program's `TCP_SEND` waits (like a socket
/// send buffer: a client that stops reading makes the program's send time out).
pub const CLIENT_BUFFER: usize = 4096;

/// A piece of what the program sent to a client, due at `at`.
#[derive(Debug, Clone)]
pub(crate) struct Chunk {
    pub(crate) at: Duration,
    pub(crate) bytes: Vec<u8>,
}

#[derive(Debug, Clone)]
pub(crate) enum Peer {
    /// A client of the controller ([`crate::ClientId`] = this socket's id).
    Client,
    /// Another of the program's sockets (`TCP_CONNECT` to its own listener).
    Socket(i32),
}

#[derive(Debug, Clone)]
pub(crate) struct Sock {
    /// What the program reads.
    pub(crate) inbox: VecDeque<u8>,
    /// What the program sent to a client, with when each piece is due.
    pub(crate) outbox: VecDeque<Chunk>,
    pub(crate) outbox_bytes: usize,
    /// The other end closed.
    pub(crate) peer_closed: bool,
    /// The program closed this socket (a client reads what is left, then the end).
    pub(crate) program_closed: bool,
    pub(crate) peer: Peer,
    /// The port it was accepted on (0 for TCP_CONNECT sockets).
    pub(crate) port: u16,
    pub(crate) ip: [u8; 4],
}

impl Sock {
    pub(crate) fn new(peer: Peer, port: u16, ip: [u8; 4]) -> Sock {
        Sock {
            inbox: VecDeque::new(),
            outbox: VecDeque::new(),
            outbox_bytes: 0,
            peer_closed: false,
            program_closed: false,
            peer,
            port,
            ip,
        }
    }
}

#[derive(Debug, Clone, Default)]
pub(crate) struct Net {
    pub(crate) listeners: BTreeMap<u16, VecDeque<i32>>,
    pub(crate) sockets: BTreeMap<i32, Sock>,
    pub(crate) next_id: i32,
    pub(crate) served_port: Option<u16>,
    /// Bumped on every change a client can see (listening, data, close).
    pub(crate) generation: u64,
}

/// The program closes socket `id`: a socket peer sees the connection closed; a client reads
/// what is left, then the end of the stream.
pub(crate) fn close_socket(net: &mut Net, id: i32) {
    let Some(s) = net.sockets.get_mut(&id) else {
        return;
    };
    s.program_closed = true;
    match s.peer.clone() {
        Peer::Socket(p) => {
            net.sockets.remove(&id);
            if let Some(peer) = net.sockets.get_mut(&p) {
                peer.peer_closed = true;
            }
        }
        Peer::Client => {
            if s.outbox.is_empty() && s.peer_closed {
                net.sockets.remove(&id);
            }
        }
    }
}
