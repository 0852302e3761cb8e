//! Many controllers' robot ports served by one readiness loop on the calling thread: the
//! emulator of a fleet at the cost of a plain epoll server.
//!
//! [`Emulator::serve_tcp`](crate::Emulator::serve_tcp) gives each robot a tokio task (a session
//! loop with its timers and change watcher), which a polled robot pays on every request. Here
//! the sans-IO [`Controller`]s are driven directly: one `epoll_wait` for every robot's sockets,
//! each request read, handled and answered in place, and the controllers' own deadlines (listen
//! windows, receive timeouts, fault injection's delays, the send timeout) kept as a heap of
//! timers. The behaviour is the session loop's, step for step (`tests/fleet_server.rs` runs the
//! same client scripts against both): it listens in the controller's windows and not during a
//! session, reads one request per receive, answers it with the controller's reply (or the fault
//! the controller asks for), restarts the receive timeout once the reply is out, and ends the
//! session on a lost connection, a 2 s send timeout, a receive timeout or command 255.
//!
//! There is no pendant, terminal or observer here: `fs020n sim` uses it for native robots with
//! none of those (`--robots N --threads 1`), the tokio server otherwise.

use std::cmp::Reverse;
use std::collections::{BinaryHeap, VecDeque};
use std::io::{self, Read, Write};
use std::net::SocketAddr;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

use fs020n_proto::SEND_TIMEOUT;
use mio::net::{TcpListener, TcpStream};
use mio::{Events, Interest, Poll, Token, Waker};

use super::RECEIVE_BUFFER;
use crate::controller::Controller;
use crate::fault::ReplyFault;
use crate::native::SessionId;
use crate::snapshot::SessionEnd;

/// The token of the stop waker (robots use `2·i` for the listener, `2·i + 1` for the session).
const WAKE: Token = Token(usize::MAX);

/// How long to wait before binding a robot port again after the bind failed.
const REBIND_AFTER: Duration = Duration::from_millis(100);

/// Robot ports of many controllers, served by [`FleetServer::run`] on the calling thread.
pub struct FleetServer {
    robots: Vec<Robot>,
    poll: Poll,
    waker: Arc<Waker>,
    stop: Arc<AtomicBool>,
    epoch: Instant,
    /// Deadlines: (time, robot, generation); an entry whose generation is not the robot's
    /// current one is stale.
    timers: BinaryHeap<Reverse<(Duration, usize, u64)>>,
    buf: Vec<u8>,
}

impl std::fmt::Debug for FleetServer {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("FleetServer")
            .field("robots", &self.robots.len())
            .finish()
    }
}

/// Stops a running [`FleetServer`] from another thread.
#[derive(Debug, Clone)]
pub struct FleetStop {
    stop: Arc<AtomicBool>,
    waker: Arc<Waker>,
}

impl FleetStop {
    /// Asks the loop to return; it does within one wake-up.
    pub fn stop(&self) {
        self.stop.store(true, Ordering::SeqCst);
        // A failed wake leaves the loop to notice at its next wake-up.
        let _ = self.waker.wake();
    }
}

struct Robot {
    controller: Controller,
    /// The bound address (a port 0 resolved at the first bind).
    addr: SocketAddr,
    listener: Option<TcpListener>,
    session: Option<Session>,
    /// When the last bind failed: bind again after [`REBIND_AFTER`].
    bind_failed_at: Option<Duration>,
    generation: u64,
    scheduled: Option<Duration>,
}

struct Session {
    stream: TcpStream,
    id: SessionId,
    /// Bytes due at their time (a delayed or split reply: fault injection), in order.
    outbox: VecDeque<(Duration, Vec<u8>)>,
    /// The bytes being written and how many went out.
    out: Vec<u8>,
    written: usize,
    /// Since when the socket could not take them (the send timeout runs from there).
    blocked_since: Option<Duration>,
    writable_interest: bool,
    /// The reply under way must be followed by `reply_sent` once out.
    replying: bool,
    close_after: bool,
}

impl FleetServer {
    /// Binds each controller's robot port (port 0 picks one) and returns the loop, not yet
    /// running.
    pub fn bind(robots: Vec<(Controller, SocketAddr)>) -> io::Result<FleetServer> {
        let poll = Poll::new()?;
        let waker = Arc::new(Waker::new(poll.registry(), WAKE)?);
        let mut fleet = FleetServer {
            robots: Vec::with_capacity(robots.len()),
            poll,
            waker,
            stop: Arc::new(AtomicBool::new(false)),
            epoch: Instant::now(),
            timers: BinaryHeap::new(),
            buf: vec![0; RECEIVE_BUFFER],
        };
        for (i, (controller, addr)) in robots.into_iter().enumerate() {
            let mut listener = bind_robot_port(addr)?;
            let addr = listener.local_addr()?;
            fleet
                .poll
                .registry()
                .register(&mut listener, Token(2 * i), Interest::READABLE)?;
            fleet.robots.push(Robot {
                controller,
                addr,
                listener: Some(listener),
                session: None,
                bind_failed_at: None,
                generation: 0,
                scheduled: None,
            });
        }
        Ok(fleet)
    }

    /// The robots' bound addresses, in order.
    pub fn local_addrs(&self) -> Vec<SocketAddr> {
        self.robots.iter().map(|r| r.addr).collect()
    }

    /// A handle that stops [`FleetServer::run`] from another thread.
    pub fn stopper(&self) -> FleetStop {
        FleetStop {
            stop: self.stop.clone(),
            waker: self.waker.clone(),
        }
    }

    /// Serves until stopped; returns the controllers as they are then.
    pub fn run(mut self) -> io::Result<Vec<Controller>> {
        let mut events = Events::with_capacity(1024);
        let now = self.now();
        for i in 0..self.robots.len() {
            self.service(i, now);
        }
        while !self.stop.load(Ordering::SeqCst) {
            let timeout = self
                .timers
                .peek()
                .map(|Reverse((t, _, _))| t.saturating_sub(self.now()));
            if let Err(e) = self.poll.poll(&mut events, timeout) {
                if e.kind() == io::ErrorKind::Interrupted {
                    continue;
                }
                return Err(e);
            }
            let now = self.now();
            for event in &events {
                let token = event.token();
                if token == WAKE {
                    continue;
                }
                let i = token.0 / 2;
                if i >= self.robots.len() {
                    continue;
                }
                if token.0 % 2 == 0 {
                    self.accept(i, now);
                }
                self.service(i, now);
            }
            while let Some(&Reverse((t, i, generation))) = self.timers.peek() {
                if t > now {
                    break;
                }
                self.timers.pop();
                if self
                    .robots
                    .get(i)
                    .is_some_and(|r| r.generation == generation)
                {
                    self.robots[i].scheduled = None;
                    self.service(i, now);
                }
            }
        }
        Ok(self.robots.into_iter().map(|r| r.controller).collect())
    }

    fn now(&self) -> Duration {
        self.epoch.elapsed()
    }

    /// A connection on robot `i`'s listener: the controller accepts one (then stops listening)
    /// or refuses it (a listen gap, a session open).
    fn accept(&mut self, i: usize, now: Duration) {
        let robot = &mut self.robots[i];
        loop {
            let Some(listener) = robot.listener.as_ref() else {
                return;
            };
            let (mut stream, peer) = match listener.accept() {
                Ok(s) => s,
                Err(e) if e.kind() == io::ErrorKind::WouldBlock => return,
                Err(e) if e.kind() == io::ErrorKind::Interrupted => continue,
                // Out of descriptors, a connection reset before it was taken: the next
                // connection tries again.
                Err(e) => {
                    tracing::warn!(addr = %robot.addr, error = %e, "cannot accept");
                    return;
                }
            };
            robot.controller.advance_to(now);
            match robot.controller.try_accept() {
                Ok(id) => {
                    if let Some(mut l) = robot.listener.take() {
                        let _ = self.poll.registry().deregister(&mut l);
                    }
                    let _ = stream.set_nodelay(true);
                    if self
                        .poll
                        .registry()
                        .register(&mut stream, Token(2 * i + 1), Interest::READABLE)
                        .is_err()
                    {
                        robot
                            .controller
                            .end_session_of(id, SessionEnd::Disconnected);
                        return;
                    }
                    tracing::info!(%peer, session = id.0, "client connected");
                    robot.session = Some(Session {
                        stream,
                        id,
                        outbox: VecDeque::new(),
                        out: Vec::new(),
                        written: 0,
                        blocked_since: None,
                        writable_interest: false,
                        replying: false,
                        close_after: false,
                    });
                    return;
                }
                // Dropping the stream refuses it, as the controller does.
                Err(e) => tracing::info!(%peer, "{e}"),
            }
        }
    }

    /// Brings robot `i` up to `now`, does every read and write its sockets allow, and sets its
    /// next timer.
    fn service(&mut self, i: usize, now: Duration) {
        let registry = self.poll.registry();
        let robot = &mut self.robots[i];
        robot.controller.advance_to(now);
        if let Some(session) = robot.session.as_mut() {
            let open = serve_session(
                &mut robot.controller,
                session,
                &mut self.buf,
                registry,
                Token(2 * i + 1),
                now,
            );
            if !open {
                if let Some(mut s) = robot.session.take() {
                    let _ = registry.deregister(&mut s.stream);
                    let _ = s.stream.shutdown(std::net::Shutdown::Write);
                }
            }
        }
        if robot.session.is_none() {
            let listening = robot.controller.native().is_listening();
            match (listening, robot.listener.is_some()) {
                (false, true) => {
                    if let Some(mut l) = robot.listener.take() {
                        let _ = registry.deregister(&mut l);
                    }
                }
                (true, false) if robot.bind_failed_at.is_none_or(|t| now >= t + REBIND_AFTER) => {
                    match bind_robot_port(robot.addr).and_then(|mut l| {
                        registry.register(&mut l, Token(2 * i), Interest::READABLE)?;
                        Ok(l)
                    }) {
                        Ok(l) => {
                            robot.listener = Some(l);
                            robot.bind_failed_at = None;
                            // A client may be waiting already: its connection made the
                            // listener readable before this registration saw it.
                            self.accept(i, now);
                            if self.robots[i].session.is_some() {
                                return self.service(i, now);
                            }
                        }
                        Err(e) => {
                            tracing::warn!(addr = %robot.addr, error = %e, "cannot listen; retrying");
                            robot.bind_failed_at = Some(now);
                        }
                    }
                }
                _ => {}
            }
        }
        self.schedule(i, now);
    }

    /// Robot `i`'s next deadline.
    fn schedule(&mut self, i: usize, now: Duration) {
        let robot = &mut self.robots[i];
        let c = &robot.controller;
        let next = match &robot.session {
            Some(s) => [
                c.native().receive_deadline(),
                c.reading_paused_until(),
                s.outbox.front().map(|(t, _)| *t),
                s.blocked_since.map(|t| t + SEND_TIMEOUT),
            ]
            .into_iter()
            .flatten()
            .min(),
            None => [
                c.native().next_listen_change(),
                robot.bind_failed_at.map(|t| t + REBIND_AFTER),
            ]
            .into_iter()
            .flatten()
            .min(),
        };
        let next = next.map(|t| t.max(now));
        // A receive deadline moves later with every request: a timer already set earlier is
        // kept (when it fires, the robot is serviced and the timer set again), so that a polled
        // robot does not push a timer per request.
        let earlier_set =
            matches!((robot.scheduled, next), (Some(s), Some(n)) if s > now && s <= n);
        if next != robot.scheduled && !earlier_set {
            robot.generation = robot.generation.wrapping_add(1);
            robot.scheduled = next;
            if let Some(t) = next {
                self.timers.push(Reverse((t, i, robot.generation)));
            }
        }
    }
}

/// Everything session `s` can do now: write what is due, then read and answer requests until
/// the socket has no more. `false` once the session is over.
fn serve_session(
    c: &mut Controller,
    s: &mut Session,
    buf: &mut [u8],
    registry: &mio::Registry,
    token: Token,
    now: Duration,
) -> bool {
    loop {
        // What is due goes out first (command 255's reply too, though its session has ended):
        // the session loop receives again only after a reply.
        match flush(c, s, now) {
            Flush::Done => {
                if s.writable_interest {
                    // Everything went out: no more wake-ups for room in the send buffer.
                    if registry
                        .reregister(&mut s.stream, token, Interest::READABLE)
                        .is_err()
                    {
                        c.end_session_of(s.id, SessionEnd::Disconnected);
                        return false;
                    }
                    s.writable_interest = false;
                }
            }
            Flush::Wait => {
                let want = s.blocked_since.is_some();
                if want != s.writable_interest {
                    let interest = if want {
                        Interest::READABLE | Interest::WRITABLE
                    } else {
                        Interest::READABLE
                    };
                    if registry.reregister(&mut s.stream, token, interest).is_err() {
                        c.end_session_of(s.id, SessionEnd::Disconnected);
                        return false;
                    }
                    s.writable_interest = want;
                }
                return c.native().is_session_open(s.id);
            }
            Flush::Ended(why) => {
                c.end_session_of(s.id, why);
                return false;
            }
            Flush::Closed => return false,
        }
        if !c.native().is_session_open(s.id) {
            return false;
        }
        if c.reading_paused_until().is_some() {
            return true;
        }
        let n = match s.stream.read(buf) {
            Ok(0) => {
                c.end_session_of(s.id, SessionEnd::Disconnected);
                return false;
            }
            Ok(n) => n,
            Err(e) if e.kind() == io::ErrorKind::WouldBlock => return true,
            Err(e) if e.kind() == io::ErrorKind::Interrupted => continue,
            Err(_) => {
                c.end_session_of(s.id, SessionEnd::Disconnected);
                return false;
            }
        };
        let Ok(handled) = c.handle_request(s.id, &buf[..n]) else {
            return false;
        };
        s.replying = true;
        s.close_after = handled.close;
        match handled.fault {
            // The common case: straight to the socket (the outbox is empty: requests are read
            // only once everything due is out).
            None if s.outbox.is_empty() && s.written == s.out.len() => {
                s.out = handled.reply;
                s.written = 0;
            }
            None => s.outbox.push_back((now, handled.reply)),
            Some(ReplyFault::Withhold) => {}
            Some(ReplyFault::Garbage(bytes)) => s.outbox.push_back((now, bytes)),
            Some(ReplyFault::Delay(d)) => s.outbox.push_back((now + d, handled.reply)),
            Some(ReplyFault::Split { parts, gap }) => {
                let size = handled.reply.len().div_ceil(parts.max(1)).max(1);
                let mut at = now;
                for chunk in handled.reply.chunks(size) {
                    s.outbox.push_back((at, chunk.to_vec()));
                    at += gap;
                }
            }
        }
        if n == buf.len() {
            // A full read may have left more: read on after the reply.
            continue;
        }
        // A short read drained the socket: epoll reports the next request as a new event, so
        // only the reply is left to do (no read that would find nothing).
        return match flush(c, s, now) {
            Flush::Done => c.native().is_session_open(s.id),
            Flush::Wait => serve_session(c, s, buf, registry, token, now),
            Flush::Ended(why) => {
                c.end_session_of(s.id, why);
                false
            }
            Flush::Closed => false,
        };
    }
}

enum Flush {
    /// Nothing left to write (and the reply, if one was under way, is out).
    Done,
    /// Waiting: bytes due later, or a socket that cannot take them now.
    Wait,
    /// The session ends (send timeout, lost connection).
    Ended(SessionEnd),
    /// Command 255's reply is out: the connection closes.
    Closed,
}

fn flush(c: &mut Controller, s: &mut Session, now: Duration) -> Flush {
    loop {
        if s.written == s.out.len() {
            match s.outbox.front() {
                Some((t, _)) if *t <= now => {
                    if let Some((_, bytes)) = s.outbox.pop_front() {
                        s.out = bytes;
                        s.written = 0;
                    }
                }
                Some(_) => return Flush::Wait,
                None => {
                    if s.replying {
                        s.replying = false;
                        // The communication task receives again only now (its 5 s timeout
                        // starts here).
                        c.reply_sent(s.id);
                        if s.close_after {
                            return Flush::Closed;
                        }
                    }
                    return Flush::Done;
                }
            }
            continue;
        }
        match s.stream.write(&s.out[s.written..]) {
            Ok(0) => return Flush::Ended(SessionEnd::Disconnected),
            Ok(n) => {
                s.written += n;
                s.blocked_since = None;
            }
            Err(e) if e.kind() == io::ErrorKind::WouldBlock => {
                let since = *s.blocked_since.get_or_insert(now);
                if now >= since + SEND_TIMEOUT {
                    return Flush::Ended(SessionEnd::SendTimeout);
                }
                return Flush::Wait;
            }
            Err(e) if e.kind() == io::ErrorKind::Interrupted => {}
            Err(_) => return Flush::Ended(SessionEnd::Disconnected),
        }
    }
}

/// The robot port on the loop's poll ([`super::robot_port_socket`]).
fn bind_robot_port(addr: SocketAddr) -> io::Result<TcpListener> {
    Ok(TcpListener::from_std(super::robot_port_socket(addr)?))
}
