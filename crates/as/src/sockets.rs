//! The controller's socket stack: one table of listening ports and sockets, with the AS result
//! codes, that every [`System`](crate::System) delegates its `tcp_*` calls to.
//!
//! A socket has a **program end** (what the AS program reads with `TCP_RECV` and writes with
//! `TCP_SEND`) and a **peer**, one of:
//!
//! - another socket of the table: `TCP_CONNECT` to the program's own listener, or an
//!   in-process test client ([`SocketTable::connect_local`]). Bytes sent go straight into the
//!   other socket's inbox, up to [`SocketLimits::local_buffer`] bytes waiting.
//! - an **outside client** ([`SocketTable::client_connect`]): a real TCP client of the
//!   emulator, later the controller's terminal. What the program sends waits in the socket's
//!   outbox as chunks, each due at a time (a [`Delivery`] can delay, split, replace or
//!   withhold a reply: fault injection), until the client reads it
//!   ([`SocketTable::client_read`]); `TCP_SEND` waits while [`SocketLimits::client_buffer`]
//!   bytes are unread.
//!
//! The table is sans-IO: no clock and no runtime. Times are passed in; a driver watches
//! [`SocketTable::generation`] (bumped on every change an outside client can see) to know
//! when to read again.
//!
//! **UDP** (`UDP_SENDTO`, `UDP_RECVFROM`) has no connection: each instruction opens its own
//! socket and closes it when it ends. While a `UDP_RECVFROM` waits, its port is open in the
//! table ([`SocketTable::udp_open`]) and datagrams delivered to it ([`SocketTable::udp_deliver`],
//! from a test or the emulator's real UDP socket) queue there; a datagram for a port no
//! `UDP_RECVFROM` waits on is lost, as on a network. What `UDP_SENDTO` sends waits in an
//! outbox ([`SocketTable::udp_take_sent`]) for the driver to deliver.
//!
//! **Outgoing connections** (`TCP_CONNECT` to another host, [`SocketTable::connect_remote`])
//! have an outside peer too: the table records the wish as a [`Dial`] for the driver to make
//! ([`SocketTable::take_dials`]), the driver reports how it went ([`SocketTable::dial_done`]),
//! and the program's next poll takes the connected socket (or the error). From then on the
//! socket is like an outside client's: the driver moves its bytes with
//! [`SocketTable::client_send`] and [`SocketTable::client_read`]. A connection the program
//! gave up on ([`SocketTable::abandon_connect`], its timeout passed) is closed.
//!
//! Socket ids start at 1 and are never reused. A local connection takes two ids (the
//! connecting end, then the accepted end); an outside client takes one (the accepted end; the
//! client names its connection by the same id).

use std::collections::{BTreeMap, VecDeque};
use std::time::Duration;

use crate::system::{Datagram, SockPoll, SocketStatus};

/// The AS result codes of the TCP instructions (AS error `E40nn` is code `−340nn`): what a
/// `ret` variable holds when an instruction fails. See docs/AS.md, "TCP sockets".
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum TcpCode {
    /// E4019: the socket cannot be opened (too many sockets or a bad parameter).
    OpenFailed,
    /// E4020: the socket cannot be closed.
    CloseFailed,
    /// E4021: a line or peer problem during `TCP_SEND`/`TCP_RECV`.
    Communication,
    /// E4022: `TCP_SEND` data over the limit ([`crate::MAX_TRANSFER`] bytes).
    TooLong,
    /// E4023: `TCP_CONNECT` cannot reach the host.
    Unreachable,
    /// E4024: the instruction's timeout passed (the usual "nothing yet, retry").
    Timeout,
    /// E4025: the connection failed or is broken (the peer closed it).
    Broken,
    /// E4055: the socket cannot be created (the port already listens).
    PortInUse,
    /// E4056: the port is not listening (`TCP_ACCEPT`/`TCP_END_LISTEN` without `TCP_LISTEN`).
    NotListening,
    /// E4057: no such socket (closed, or never opened).
    UnknownSocket,
}

impl TcpCode {
    /// Every code, in numeric order (E4019 first).
    pub const ALL: [TcpCode; 10] = [
        TcpCode::OpenFailed,
        TcpCode::CloseFailed,
        TcpCode::Communication,
        TcpCode::TooLong,
        TcpCode::Unreachable,
        TcpCode::Timeout,
        TcpCode::Broken,
        TcpCode::PortInUse,
        TcpCode::NotListening,
        TcpCode::UnknownSocket,
    ];

    /// The value a `ret` variable holds: −34019 … −34057.
    pub const fn code(self) -> i32 {
        match self {
            TcpCode::OpenFailed => -34019,
            TcpCode::CloseFailed => -34020,
            TcpCode::Communication => -34021,
            TcpCode::TooLong => -34022,
            TcpCode::Unreachable => -34023,
            TcpCode::Timeout => -34024,
            TcpCode::Broken => -34025,
            TcpCode::PortInUse => -34055,
            TcpCode::NotListening => -34056,
            TcpCode::UnknownSocket => -34057,
        }
    }

    /// The code of a `ret` value, `None` for any other number.
    pub fn from_code(code: i32) -> Option<TcpCode> {
        TcpCode::ALL.into_iter().find(|c| c.code() == code)
    }

    /// The controller's message for it (`$ERROR(code)`).
    pub const fn message(self) -> &'static str {
        match self {
            TcpCode::OpenFailed => "Socket open error",
            TcpCode::CloseFailed => "Socket close error",
            TcpCode::Communication => "Communication error",
            TcpCode::TooLong => "Message too long",
            TcpCode::Unreachable => "Cannot reach host",
            TcpCode::Timeout => "Communication timeout",
            TcpCode::Broken => "Connection failed or broken",
            TcpCode::PortInUse => "Cannot create socket (port in use)",
            TcpCode::NotListening => "Port not in LISTEN",
            TcpCode::UnknownSocket => "Illegal socket id",
        }
    }
}

/// How many unread bytes a socket holds before `TCP_SEND` to it waits.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct SocketLimits {
    /// A local peer's inbox (another socket of the table): the send waits while the inbox and
    /// the data together exceed this.
    pub local_buffer: usize,
    /// An outside client's unread outbox: the send waits while bytes are unread and they and
    /// the data together exceed this (one send larger than it goes into an empty outbox).
    pub client_buffer: usize,
}

/// How a reply to an outside client is delivered (the emulator's reply faults; [`Delivery::Now`]
/// when no fault is armed).
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Delivery {
    /// Due at once.
    Now,
    /// Due after this delay.
    Delay(Duration),
    /// Never delivered.
    Withhold,
    /// These bytes are delivered at once instead.
    Replace(Vec<u8>),
    /// In this many pieces (at least one), `gap` apart, the first at once.
    Split {
        /// Number of pieces.
        parts: usize,
        /// Pause between pieces.
        gap: Duration,
    },
}

/// What an outside client reads ([`SocketTable::client_read`]).
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

#[derive(Debug, Clone)]
struct Chunk {
    at: Duration,
    bytes: Vec<u8>,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Peer {
    /// An outside client (its connection is named by this socket's id).
    Client,
    /// Another socket of the table.
    Local(i32),
}

#[derive(Debug, Clone)]
struct Socket {
    /// What the program reads.
    inbox: VecDeque<u8>,
    /// What the program sent to an outside client, with when each piece is due.
    outbox: VecDeque<Chunk>,
    outbox_bytes: usize,
    /// The other end closed.
    peer_closed: bool,
    /// The program closed this socket (an outside client reads what is left, then the end).
    program_closed: bool,
    peer: Peer,
    /// The port it was accepted on (0 for the connecting end of a local connection).
    port: u16,
    /// The peer's address (`TCP_ACCEPT`'s `ip`).
    ip: [u8; 4],
}

impl Socket {
    fn new(peer: Peer, port: u16, ip: [u8; 4]) -> Socket {
        Socket {
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

/// The address of a local peer.
const LOOPBACK: [u8; 4] = [127, 0, 0, 1];

/// An outgoing connection the program asked for (`TCP_CONNECT` to another host), for the
/// driver to make ([`SocketTable::take_dials`]); `id` is the socket it becomes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Dial {
    /// The socket id (the driver names the connection by it, as an outside client's).
    pub id: i32,
    /// The address the program connects to.
    pub ip: [u8; 4],
    /// The port it connects to.
    pub port: u16,
}

/// Where an outgoing connection stands until the program takes it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum DialState {
    /// The driver is connecting.
    Dialing,
    /// Connected: the program's next poll takes the socket.
    Connected,
    /// Failed with this code: the program's next poll gets it.
    Failed(i32),
}

/// The controller's listening ports and sockets (see the module documentation).
///
/// ```
/// use fs020n_as::sockets::{SocketLimits, SocketTable, TcpCode};
/// use fs020n_as::SockPoll;
///
/// let mut net = SocketTable::new(SocketLimits { local_buffer: 1024, client_buffer: 1024 });
/// assert_eq!(net.listen(10050), 0);
/// assert_eq!(net.listen(10050), TcpCode::PortInUse.code());
/// let client = net.connect_local(10050).expect("it listens");
/// let SockPoll::Ready(Ok((sock, _ip))) = net.accept(10050) else { panic!("a connection waits") };
/// assert!(net.peer_send(client, b"hello"));
/// assert_eq!(net.recv(sock, 255), SockPoll::Ready(Ok(b"hello".to_vec())));
/// assert_eq!(net.close(sock), 0);
/// assert!(net.peer_closed(client));
/// ```
#[derive(Debug, Clone)]
pub struct SocketTable {
    listeners: BTreeMap<u16, VecDeque<i32>>,
    sockets: BTreeMap<i32, Socket>,
    next_id: i32,
    served_port: Option<u16>,
    generation: u64,
    limits: SocketLimits,
    /// Ports a `UDP_RECVFROM` has open, with the datagrams that reached each.
    udp_ports: BTreeMap<u16, VecDeque<Datagram>>,
    /// Datagrams `UDP_SENDTO` sent, not yet taken by the driver.
    udp_sent: VecDeque<Datagram>,
    /// Outgoing connections the program has not taken yet, by socket id.
    outgoing: BTreeMap<i32, (Dial, DialState)>,
    /// Outgoing connections not yet handed to the driver.
    dials: VecDeque<Dial>,
}

impl SocketTable {
    /// An empty table: nothing listens; the first socket id is 1.
    pub fn new(limits: SocketLimits) -> SocketTable {
        SocketTable {
            listeners: BTreeMap::new(),
            sockets: BTreeMap::new(),
            next_id: 1,
            served_port: None,
            generation: 0,
            limits,
            udp_ports: BTreeMap::new(),
            udp_sent: VecDeque::new(),
            outgoing: BTreeMap::new(),
            dials: VecDeque::new(),
        }
    }

    /// A controller restart: every socket and listener is gone (clients see their connection
    /// closed), the served port is chosen anew; socket ids keep counting, so that an old
    /// client never meets a new socket, and the generation moves on.
    pub fn restart(&mut self) {
        *self = SocketTable {
            next_id: self.next_id,
            generation: self.generation + 1,
            ..SocketTable::new(self.limits)
        };
    }

    /// The buffer limits.
    pub fn limits(&self) -> SocketLimits {
        self.limits
    }

    /// Changes the buffer limits (from the next send on).
    pub fn set_limits(&mut self, limits: SocketLimits) {
        self.limits = limits;
    }

    // ------------------------------------------------------------------ observers

    /// Counts every change an outside client can see (listening, data, a close): a driver
    /// reads again when it changes.
    pub fn generation(&self) -> u64 {
        self.generation
    }

    /// The first port the program listened on (the port a controller serves at its address).
    pub fn served_port(&self) -> Option<u16> {
        self.served_port
    }

    /// `true` while `port` listens.
    pub fn listening(&self, port: u16) -> bool {
        self.listeners.contains_key(&port)
    }

    /// The ports listening now, in order.
    pub fn listening_ports(&self) -> Vec<u16> {
        self.listeners.keys().copied().collect()
    }

    /// `true` when `sock` is a socket the program holds open whose peer is an outside client.
    pub fn is_client(&self, sock: i32) -> bool {
        self.open(sock).is_some_and(|s| s.peer == Peer::Client)
    }

    /// The port `sock` was accepted on (0 for the connecting end of a local connection),
    /// `None` for an unknown socket.
    pub fn port_of(&self, sock: i32) -> Option<u16> {
        self.sockets.get(&sock).map(|s| s.port)
    }

    /// The first (lowest id) outside client the program accepted on `port` and still holds
    /// open (a connection still waiting in a backlog is not accepted yet).
    pub fn accepted_client_on(&self, port: u16) -> Option<i32> {
        let waiting = |id: &i32| self.listeners.values().any(|b| b.contains(id));
        self.sockets
            .iter()
            .find(|(id, s)| {
                s.peer == Peer::Client && s.port == port && !s.program_closed && !waiting(id)
            })
            .map(|(id, _)| *id)
    }

    /// The sockets the program holds open (accepted or connected, in id order) for
    /// `TCP_STATUS`; connections still waiting to be accepted are not among them.
    pub fn status(&self) -> Vec<SocketStatus> {
        let waiting = |id: &i32| {
            self.outgoing.contains_key(id) || self.listeners.values().any(|b| b.contains(id))
        };
        self.sockets
            .iter()
            .filter(|(id, s)| !s.program_closed && !waiting(id))
            .map(|(id, s)| SocketStatus {
                sock: *id,
                port: s.port,
                ip: s.ip,
                error: if s.peer_closed {
                    TcpCode::Broken.code()
                } else {
                    0
                },
            })
            .collect()
    }

    /// A socket the program may use (known, not closed by the program).
    fn open(&self, sock: i32) -> Option<&Socket> {
        self.sockets.get(&sock).filter(|s| !s.program_closed)
    }

    fn open_mut(&mut self, sock: i32) -> Option<&mut Socket> {
        self.sockets.get_mut(&sock).filter(|s| !s.program_closed)
    }

    // ------------------------------------------------------------------ the program's end

    /// `TCP_LISTEN`: 0, or [`TcpCode::PortInUse`].
    pub fn listen(&mut self, port: u16) -> i32 {
        if self.listeners.contains_key(&port) {
            return TcpCode::PortInUse.code();
        }
        self.listeners.insert(port, VecDeque::new());
        self.served_port.get_or_insert(port);
        self.generation += 1;
        0
    }

    /// `TCP_END_LISTEN`: 0 (connections never accepted are reset), or
    /// [`TcpCode::NotListening`].
    pub fn end_listen(&mut self, port: u16) -> i32 {
        match self.listeners.remove(&port) {
            Some(backlog) => {
                for id in backlog {
                    self.close_socket(id);
                }
                self.generation += 1;
                0
            }
            None => TcpCode::NotListening.code(),
        }
    }

    /// `TCP_ACCEPT`: the oldest waiting connection (its socket id and the peer's address),
    /// [`TcpCode::NotListening`], or `Pending` while none waits.
    pub fn accept(&mut self, port: u16) -> SockPoll<(i32, [u8; 4])> {
        let Some(backlog) = self.listeners.get_mut(&port) else {
            return SockPoll::Ready(Err(TcpCode::NotListening.code()));
        };
        match backlog.pop_front() {
            Some(id) => {
                let ip = self.sockets.get(&id).map_or([0; 4], |s| s.ip);
                SockPoll::Ready(Ok((id, ip)))
            }
            None => SockPoll::Pending,
        }
    }

    /// A local connection to the program's own listener on `port` (`TCP_CONNECT`, or an
    /// in-process test client): the connecting end's socket id; the other end waits for
    /// `TCP_ACCEPT`. `None` when `port` does not listen.
    pub fn connect_local(&mut self, port: u16) -> Option<i32> {
        let backlog = self.listeners.get_mut(&port)?;
        let a = self.next_id;
        let b = a + 1;
        self.next_id += 2;
        backlog.push_back(b);
        self.sockets
            .insert(a, Socket::new(Peer::Local(b), 0, LOOPBACK));
        self.sockets
            .insert(b, Socket::new(Peer::Local(a), port, LOOPBACK));
        Some(a)
    }

    /// `TCP_CONNECT` to another host (`ip:port`, not the program's own listeners): the socket
    /// id once the driver connected ([`Self::dial_done`]), the driver's error code if it
    /// failed, `Pending` meanwhile. The first call records a [`Dial`] for the driver; later
    /// calls for the same address poll it (a second connection to the same address is dialed
    /// once the first is taken).
    pub fn connect_remote(&mut self, ip: [u8; 4], port: u16) -> SockPoll<i32> {
        let found = self
            .outgoing
            .iter()
            .find(|(_, (d, _))| d.ip == ip && d.port == port)
            .map(|(id, (_, state))| (*id, *state));
        match found {
            Some((_, DialState::Dialing)) => SockPoll::Pending,
            Some((id, DialState::Connected)) => {
                self.outgoing.remove(&id);
                self.generation += 1;
                SockPoll::Ready(Ok(id))
            }
            Some((id, DialState::Failed(code))) => {
                self.outgoing.remove(&id);
                self.sockets.remove(&id);
                self.generation += 1;
                SockPoll::Ready(Err(code))
            }
            None => {
                let id = self.next_id;
                self.next_id += 1;
                let dial = Dial { id, ip, port };
                self.sockets.insert(id, Socket::new(Peer::Client, 0, ip));
                self.outgoing.insert(id, (dial, DialState::Dialing));
                self.dials.push_back(dial);
                self.generation += 1;
                SockPoll::Pending
            }
        }
    }

    /// Takes the outgoing connections to make, oldest first (the driver connects each and
    /// reports with [`Self::dial_done`]).
    pub fn take_dials(&mut self) -> Vec<Dial> {
        self.dials.drain(..).collect()
    }

    /// The driver's outcome of dial `id`: connected, or the AS code the program gets
    /// (e.g. [`TcpCode::Broken`] when refused). `false` when the program no longer waits for
    /// it (it gave up, or the controller restarted): the driver closes the connection.
    pub fn dial_done(&mut self, id: i32, result: Result<(), i32>) -> bool {
        match self.outgoing.get_mut(&id) {
            Some((_, state @ DialState::Dialing)) => {
                *state = match result {
                    Ok(()) => DialState::Connected,
                    Err(code) => DialState::Failed(code),
                };
                self.generation += 1;
                true
            }
            _ => false,
        }
    }

    /// The program gave up its `TCP_CONNECT` to `ip:port` (its timeout passed): the outgoing
    /// connection is dropped (closed if the driver had made it).
    pub fn abandon_connect(&mut self, ip: [u8; 4], port: u16) {
        let gone: Vec<i32> = (self.outgoing.iter())
            .filter(|(_, (d, _))| d.ip == ip && d.port == port)
            .map(|(id, _)| *id)
            .collect();
        for id in gone {
            self.outgoing.remove(&id);
            self.dials.retain(|d| d.id != id);
            self.sockets.remove(&id);
            self.generation += 1;
        }
    }

    /// `TCP_RECV`: the bytes waiting now (at most `max`), `Pending` when none;
    /// [`TcpCode::Broken`] when the peer closed and everything was read;
    /// [`TcpCode::UnknownSocket`].
    pub fn recv(&mut self, sock: i32, max: usize) -> SockPoll<Vec<u8>> {
        let Some(s) = self.open_mut(sock) else {
            return SockPoll::Ready(Err(TcpCode::UnknownSocket.code()));
        };
        if s.inbox.is_empty() {
            return if s.peer_closed {
                SockPoll::Ready(Err(TcpCode::Broken.code()))
            } else {
                SockPoll::Pending
            };
        }
        let n = s.inbox.len().min(max);
        // Copied slice by slice (the ring's two halves), not byte by byte.
        let mut out = Vec::with_capacity(n);
        let (a, b) = s.inbox.as_slices();
        let from_a = a.len().min(n);
        out.extend_from_slice(&a[..from_a]);
        out.extend_from_slice(&b[..(n - from_a).min(b.len())]);
        s.inbox.drain(..n);
        SockPoll::Ready(Ok(out))
    }

    /// `TCP_SEND` at time `now`: `Pending` while the peer's buffer is full
    /// ([`SocketLimits`]), [`TcpCode::Broken`] when the peer closed,
    /// [`TcpCode::UnknownSocket`]. For an outside client, `delivery` is asked (once, only
    /// when the send is taken) how the bytes reach it.
    pub fn send(
        &mut self,
        sock: i32,
        data: &[u8],
        now: Duration,
        delivery: impl FnOnce() -> Delivery,
    ) -> SockPoll<()> {
        let limits = self.limits;
        let Some(s) = self.open_mut(sock) else {
            return SockPoll::Ready(Err(TcpCode::UnknownSocket.code()));
        };
        if s.peer_closed {
            return SockPoll::Ready(Err(TcpCode::Broken.code()));
        }
        match s.peer {
            Peer::Local(p) => match self.sockets.get_mut(&p) {
                Some(peer) if peer.inbox.len() + data.len() <= limits.local_buffer => {
                    peer.inbox.extend(data);
                    SockPoll::Ready(Ok(()))
                }
                Some(_) => SockPoll::Pending,
                None => SockPoll::Ready(Err(TcpCode::Broken.code())),
            },
            Peer::Client => {
                if s.outbox_bytes > 0 && s.outbox_bytes + data.len() > limits.client_buffer {
                    return SockPoll::Pending;
                }
                let mut push = |at: Duration, bytes: Vec<u8>| {
                    s.outbox_bytes += bytes.len();
                    s.outbox.push_back(Chunk { at, bytes });
                };
                match delivery() {
                    Delivery::Now => push(now, data.to_vec()),
                    Delivery::Withhold => {}
                    Delivery::Replace(b) => push(now, b),
                    Delivery::Delay(d) => push(now + d, data.to_vec()),
                    Delivery::Split { parts, gap } => {
                        let size = data.len().div_ceil(parts.max(1)).max(1);
                        for (k, piece) in data.chunks(size).enumerate() {
                            push(now + gap * k as u32, piece.to_vec());
                        }
                    }
                }
                self.generation += 1;
                SockPoll::Ready(Ok(()))
            }
        }
    }

    /// `TCP_CLOSE`: 0, or [`TcpCode::UnknownSocket`] (a second close).
    pub fn close(&mut self, sock: i32) -> i32 {
        if self.open(sock).is_none() {
            return TcpCode::UnknownSocket.code();
        }
        self.close_socket(sock);
        self.generation += 1;
        0
    }

    /// The program closes socket `id`: a local peer sees the connection closed; an outside
    /// client reads what is left, then the end of the stream.
    fn close_socket(&mut self, id: i32) {
        let Some(s) = self.sockets.get_mut(&id) else {
            return;
        };
        s.program_closed = true;
        match s.peer {
            Peer::Local(p) => {
                self.sockets.remove(&id);
                if let Some(peer) = self.sockets.get_mut(&p) {
                    peer.peer_closed = true;
                }
            }
            Peer::Client => {
                if s.outbox.is_empty() && s.peer_closed {
                    self.sockets.remove(&id);
                }
            }
        }
    }

    // ------------------------------------------------------------------ local peers

    /// A local peer (the connecting end `id` of [`Self::connect_local`]) sends bytes to the
    /// other end, whatever its buffer holds; `false` when the other end is gone.
    pub fn peer_send(&mut self, id: i32, bytes: &[u8]) -> bool {
        let Some(Peer::Local(other)) = self.sockets.get(&id).map(|s| s.peer) else {
            return false;
        };
        match self.sockets.get_mut(&other) {
            Some(p) => {
                p.inbox.extend(bytes);
                true
            }
            None => false,
        }
    }

    /// Takes everything waiting in socket `id`'s inbox (a local peer reads).
    pub fn take_inbox(&mut self, id: i32) -> Vec<u8> {
        self.sockets
            .get_mut(&id)
            .map(|s| s.inbox.drain(..).collect())
            .unwrap_or_default()
    }

    /// `true` when the other end of socket `id` closed (or `id` is gone).
    pub fn peer_closed(&self, id: i32) -> bool {
        self.sockets.get(&id).is_none_or(|s| s.peer_closed)
    }

    // ------------------------------------------------------------------ outside clients

    /// An outside client connects to `port` from `ip`: its connection's id (the socket the
    /// program will accept), `None` while `port` does not listen.
    pub fn client_connect(&mut self, port: u16, ip: [u8; 4]) -> Option<i32> {
        let backlog = self.listeners.get_mut(&port)?;
        let id = self.next_id;
        self.next_id += 1;
        backlog.push_back(id);
        self.sockets.insert(id, Socket::new(Peer::Client, port, ip));
        self.generation += 1;
        Some(id)
    }

    /// An outside client sends bytes; `false` when its connection is gone (closed by the
    /// program).
    pub fn client_send(&mut self, id: i32, bytes: &[u8]) -> bool {
        match self.open_mut(id) {
            Some(s) => {
                s.inbox.extend(bytes);
                self.generation += 1;
                true
            }
            None => false,
        }
    }

    /// What an outside client reads at `now`: the bytes due, whether the program closed the
    /// connection, and when more bytes become due.
    pub fn client_read(&mut self, id: i32, now: Duration) -> ClientRead {
        let Some(s) = self.sockets.get_mut(&id) else {
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
        out.closed = s.program_closed && s.outbox.is_empty();
        if !out.bytes.is_empty() {
            self.generation += 1;
        }
        out
    }

    /// An outside client closes its connection (the program's next receive reports it
    /// broken).
    pub fn client_close(&mut self, id: i32) {
        if let Some(s) = self.sockets.get_mut(&id) {
            s.peer_closed = true;
            if s.program_closed {
                self.sockets.remove(&id);
            }
            self.generation += 1;
        }
    }

    /// Breaks every outside client's connection at once (fault injection: the program sees
    /// the connection broken on its next receive or send; the clients see the end).
    pub fn break_clients(&mut self) {
        for s in self.sockets.values_mut() {
            if s.peer == Peer::Client {
                s.peer_closed = true;
                s.program_closed = true;
                s.outbox.clear();
                s.outbox_bytes = 0;
            }
        }
        self.generation += 1;
    }

    // ------------------------------------------------------------------ UDP

    /// `UDP_RECVFROM` begins: opens its socket on `port` (datagrams delivered from now on
    /// queue there); 0, or [`TcpCode::PortInUse`] while another `UDP_RECVFROM` has it open.
    pub fn udp_open(&mut self, port: u16) -> i32 {
        if self.udp_ports.contains_key(&port) {
            return TcpCode::PortInUse.code();
        }
        self.udp_ports.insert(port, VecDeque::new());
        self.generation += 1;
        0
    }

    /// `true` while a `UDP_RECVFROM` has `port` open.
    pub fn udp_receiving(&self, port: u16) -> bool {
        self.udp_ports.contains_key(&port)
    }

    /// A datagram reaches `port`: queued while a `UDP_RECVFROM` has it open, else lost
    /// (`false`).
    pub fn udp_deliver(&mut self, port: u16, datagram: Datagram) -> bool {
        match self.udp_ports.get_mut(&port) {
            Some(q) => {
                q.push_back(datagram);
                self.generation += 1;
                true
            }
            None => false,
        }
    }

    /// `UDP_RECVFROM` waits: the oldest datagram that reached `port`, `Pending` when none,
    /// [`TcpCode::UnknownSocket`] when the port is not open.
    pub fn udp_recv(&mut self, port: u16) -> SockPoll<Datagram> {
        match self.udp_ports.get_mut(&port).map(VecDeque::pop_front) {
            Some(Some(d)) => SockPoll::Ready(Ok(d)),
            Some(None) => SockPoll::Pending,
            None => SockPoll::Ready(Err(TcpCode::UnknownSocket.code())),
        }
    }

    /// `UDP_RECVFROM` ends (it received, timed out, or its task stopped): the port closes and
    /// datagrams still queued there are lost.
    pub fn udp_close(&mut self, port: u16) {
        if self.udp_ports.remove(&port).is_some() {
            self.generation += 1;
        }
    }

    /// `UDP_SENDTO`: the datagram waits in the outbox for the driver; always 0 (a datagram
    /// is never refused: whether it arrives is the network's business).
    pub fn udp_send(&mut self, datagram: Datagram) -> i32 {
        self.udp_sent.push_back(datagram);
        self.generation += 1;
        0
    }

    /// Takes every datagram sent since the last call, oldest first (the driver delivers them).
    pub fn udp_take_sent(&mut self) -> Vec<Datagram> {
        self.udp_sent.drain(..).collect()
    }
}
