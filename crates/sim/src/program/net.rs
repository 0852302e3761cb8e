//! The in-controller TCP stack an AS program's `TCP_…` instructions use: listeners with their
//! backlogs, and sockets whose peer is a client of the controller (the network layer, a test)
//! or another of the program's sockets.

use std::collections::{BTreeMap, VecDeque};
use std::time::Duration;

use serde::Serialize;

/// Bytes a client's outgoing queue holds before the program's `TCP_SEND` waits (like a socket
/// send buffer: a client that stops reading makes the program's send time out).
pub const CLIENT_BUFFER: usize = 4096;

/// A client of the program's TCP stack (a connection to the controller).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize)]
pub struct ClientId(pub i32);

/// What a client reads ([`crate::Controller::program_recv`]).
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct ClientRead {
    /// The bytes due now.
    pub bytes: Vec<u8>,
    /// The program closed the connection (and everything it sent has been read), or it is
    /// gone: the client sees the end of the stream.
    pub closed: bool,
    /// When more bytes become due (a delayed or split reply).
    pub next_at: Option<Duration>,
}

/// A piece of what the program sent to a client, due at `at`.
#[derive(Debug, Clone)]
pub(crate) struct Chunk {
    pub(crate) at: Duration,
    pub(crate) bytes: Vec<u8>,
}

#[derive(Debug, Clone)]
pub(crate) enum Peer {
    /// A client of the controller ([`ClientId`] = this socket's id).
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

impl Net {
    /// A stack with no listener and no socket (socket ids start at 1).
    pub(crate) fn new() -> Net {
        Net {
            next_id: 1,
            ..Net::default()
        }
    }

    /// The port served at the robot's address (the first the program listened on).
    pub(crate) fn served_port(&self) -> Option<u16> {
        self.served_port
    }

    /// Counts every change a client can see.
    pub(crate) fn generation(&self) -> u64 {
        self.generation
    }

    /// `true` while the program listens on `port` (`None`: the served port).
    pub(crate) fn listening(&self, port: Option<u16>) -> bool {
        port.or(self.served_port)
            .is_some_and(|p| self.listeners.contains_key(&p))
    }

    /// An accepted client of the served port (not one still waiting in a backlog).
    pub(crate) fn served_client(&self) -> Option<i32> {
        let waiting = |id: &i32| self.listeners.values().any(|b| b.contains(id));
        self.sockets
            .iter()
            .find(|(id, s)| {
                matches!(s.peer, Peer::Client)
                    && Some(s.port) == self.served_port
                    && !s.program_closed
                    && !waiting(id)
            })
            .map(|(id, _)| *id)
    }

    /// Breaks every client connection (the program sees it broken on its next receive or
    /// send).
    pub(crate) fn close_clients(&mut self) {
        for s in self.sockets.values_mut() {
            if matches!(s.peer, Peer::Client) {
                s.peer_closed = true;
                s.program_closed = true;
                s.outbox.clear();
                s.outbox_bytes = 0;
            }
        }
        self.generation += 1;
    }

    /// A client connects to `port` (`None`: the served port) from `ip`; `None` while the
    /// program does not listen there.
    pub(crate) fn connect_client(&mut self, port: Option<u16>, ip: [u8; 4]) -> Option<ClientId> {
        let port = port.or(self.served_port)?;
        let backlog = self.listeners.get_mut(&port)?;
        let id = self.next_id;
        self.next_id += 1;
        backlog.push_back(id);
        self.sockets.insert(id, Sock::new(Peer::Client, port, ip));
        self.generation += 1;
        Some(ClientId(id))
    }

    /// A client sends bytes; `false` when its connection is gone (closed by the program).
    pub(crate) fn client_send(&mut self, client: ClientId, bytes: &[u8]) -> bool {
        match self.sockets.get_mut(&client.0) {
            Some(s) if !s.program_closed => {
                s.inbox.extend(bytes);
                self.generation += 1;
                true
            }
            _ => false,
        }
    }

    /// What a client reads at `now`: the bytes due, whether the program closed the connection,
    /// and when more bytes become due.
    pub(crate) fn client_recv(&mut self, now: Duration, client: ClientId) -> ClientRead {
        let Some(s) = self.sockets.get_mut(&client.0) else {
            return ClientRead {
                closed: true,
                ..ClientRead::default()
            };
        };
        let mut out = ClientRead::default();
        while let Some(c) = s.outbox.front() {
            if c.at > now {
                out.next_at = Some(c.at);
                break;
            }
            if let Some(c) = s.outbox.pop_front() {
                s.outbox_bytes -= c.bytes.len();
                out.bytes.extend_from_slice(&c.bytes);
            }
        }
        if !out.bytes.is_empty() {
            self.generation += 1;
        }
        out.closed = s.program_closed && s.outbox.is_empty();
        out
    }

    /// The client closes its connection (the program's next receive reports it broken).
    pub(crate) fn client_close(&mut self, client: ClientId) {
        if let Some(s) = self.sockets.get_mut(&client.0) {
            s.peer_closed = true;
            if s.program_closed {
                self.sockets.remove(&client.0);
            }
            self.generation += 1;
        }
    }
}

impl Net {
    /// A controller restart: every socket and listener is gone (clients see their connection
    /// closed), the served port is chosen anew; socket ids keep counting so that an old
    /// client never meets a new socket.
    pub(crate) fn restart(&mut self) {
        *self = Net {
            next_id: self.next_id,
            generation: self.generation + 1,
            ..Net::new()
        };
    }
}
