//! The AS program's views: what it shows ([`ProgramView`]: tasks, terminal, signals,
//! variables, ports) and its inputs ([`ProgramMut`]: clients, connections to other hosts,
//! input signals, tracing). Starting and stopping its tasks as the terminal does is in
//! `tasks.rs`. Without an AS program every answer is empty and every input is refused or
//! dropped.

use std::time::Duration;

use fs020n_as::{TaskId, TaskInfo, TerminalLine, TraceLine};

use super::memory::task_index;
use super::{Controller, Server};
use crate::program::{ClientId, ClientRead, ProgramDial, ProgramServer};
use crate::snapshot::Refused;

/// The AS program of a [`Controller`], borrowed to read ([`Controller::program`]).
#[derive(Debug, Clone, Copy)]
pub struct ProgramView<'a> {
    pub(super) c: &'a Controller,
}

/// The AS program of a [`Controller`], borrowed to drive ([`Controller::program_mut`]): its
/// clients, the connections it makes, its inputs, and its tasks as the terminal starts and
/// stops them.
#[derive(Debug)]
pub struct ProgramMut<'a> {
    pub(super) c: &'a mut Controller,
}

impl<'a> ProgramView<'a> {
    fn server(&self) -> Option<&'a ProgramServer> {
        self.c.server_program()
    }

    /// `true` when the controller runs an AS program (not the native server, not a bare
    /// controller before its first programs).
    pub fn runs(&self) -> bool {
        self.server().is_some()
    }

    /// The program's tasks (program, line, state, what they wait for).
    pub fn tasks(&self) -> Option<Vec<TaskInfo>> {
        self.server().map(|p| p.info(&self.c.machine).tasks)
    }

    /// The program's latest terminal lines (`PRINT`/`TYPE` and controller messages).
    pub fn terminal(&self) -> Vec<TerminalLine> {
        self.server()
            .map(ProgramServer::terminal)
            .unwrap_or_default()
    }

    /// What the interface panel shows (`IFPWPRINT` …, docs/AS.md "The interface panel");
    /// `None` without AS programs.
    pub fn interface_panel(&self) -> Option<&'a fs020n_as::InterfacePanel> {
        self.server().map(|p| p.interpreter().interface_panel())
    }

    /// When the program does something next by itself (a step, a timeout, a poll), `None`
    /// when it waits only for clients. A driver advances the controller then.
    pub fn next_event(&self) -> Option<Duration> {
        self.server().and_then(ProgramServer::next_event)
    }

    /// A signal of the program (outputs 1–999, inputs 1001–1999, internal 2001–2960);
    /// `None` without a program.
    pub fn signal(&self, n: i32) -> Option<bool> {
        self.server().map(|p| p.signal(n))
    }

    /// A global real of the program (`None`: unknown or never assigned).
    pub fn real(&self, name: &str) -> Option<f32> {
        self.server().and_then(|p| p.real(name))
    }

    /// The address the AS program's UDP sockets (`UDP_SENDTO`, `UDP_RECVFROM`) bind to on
    /// this machine: 127.0.0.1 (loopback only) unless set; `None` without an AS program.
    pub fn udp_address(&self) -> Option<std::net::Ipv4Addr> {
        self.server().map(ProgramServer::udp_address)
    }

    /// Counts every change a client can see (listening, data, a close): a network layer waits
    /// for it to change.
    pub(crate) fn io_generation(&self) -> u64 {
        self.server().map_or(0, ProgramServer::io_generation)
    }

    /// The port served at the robot's address (the first the program listened on).
    pub fn served_port(&self) -> Option<u16> {
        self.server().and_then(ProgramServer::served_port)
    }

    /// `true` while the program listens on `port` (`None`: the served port).
    pub fn listening(&self, port: Option<u16>) -> bool {
        self.server().is_some_and(|p| p.listening(port))
    }

    /// The ports the program listens on now (each served on the host through the port map).
    pub fn listening_ports(&self) -> Vec<u16> {
        self.server()
            .map(ProgramServer::listening_ports)
            .unwrap_or_default()
    }

    /// `true` while `task` runs (running, paused or finishing its motion).
    pub fn task_running(&self, task: TaskId) -> bool {
        self.c.task_facts(task_index(task)).0
    }

    /// `task`'s cycle counts as `PCSTATUS` shows them: `(completed, remaining)`, remaining
    /// negative for a task started to run until aborted; `(0, 0)` without AS programs.
    pub fn task_cycles(&self, task: TaskId) -> (u32, i64) {
        self.c.interpreter().map_or((0, 0), |i| i.cycles(task))
    }

    /// The program on `task`'s stack: started and not killed (and not completed).
    pub fn task_program(&self, task: TaskId) -> Option<String> {
        self.c.stack_program(task_index(task))
    }
}

impl ProgramMut<'_> {
    fn server(&mut self) -> Option<&mut ProgramServer> {
        self.c.server_program_mut()
    }

    /// Records every step the program executes from now on (`--trace`); see
    /// [`ProgramMut::take_trace`].
    pub fn set_trace(&mut self, on: bool) {
        if let Some(p) = self.server() {
            p.set_trace(on);
        }
    }

    /// The steps executed since the last call (empty unless tracing).
    pub fn take_trace(&mut self) -> Vec<TraceLine> {
        self.server()
            .map(ProgramServer::take_trace)
            .unwrap_or_default()
    }

    /// Sets an external input signal (1001–1999) of the program, as wiring would.
    pub fn set_input(&mut self, n: i32, on: bool) {
        if let Some(p) = self.server() {
            p.set_input(n, on);
        }
    }

    /// Binds the AS program's UDP sockets to `address` from their next use on (e.g.
    /// 0.0.0.0 to let other machines reach `UDP_RECVFROM`); `false` without an AS program.
    pub fn set_udp_address(&mut self, address: std::net::Ipv4Addr) -> bool {
        match self.server() {
            Some(p) => {
                p.set_udp_address(address);
                true
            }
            None => false,
        }
    }

    /// A client connects to `port` (`None`: the served port) from `ip`. Refused while the
    /// program does not listen there (its `TCP_ACCEPT` then takes the connection).
    pub fn connect(&mut self, port: Option<u16>, ip: [u8; 4]) -> Result<ClientId, Refused> {
        let c = &mut *self.c;
        match &mut c.server {
            Server::Program(p) => p.connect(&mut c.machine, port, ip),
            Server::Native(_) | Server::Empty => {
                c.machine.counters_mut().refused += 1;
                Err(Refused::ListenGap)
            }
        }
    }

    /// A client sends bytes; `false` when its connection is gone (closed by the program).
    pub fn send(&mut self, client: ClientId, bytes: &[u8]) -> bool {
        self.server().is_some_and(|p| p.send(client, bytes))
    }

    /// What a client reads now: the bytes due, whether the program closed the connection, and
    /// when more bytes become due.
    pub fn recv(&mut self, client: ClientId) -> ClientRead {
        let now = self.c.machine.now();
        match self.server() {
            Some(p) => p.recv(now, client),
            None => ClientRead {
                closed: true,
                ..ClientRead::default()
            },
        }
    }

    /// The client closes its connection (the program's next receive reports it broken).
    pub fn close(&mut self, client: ClientId) {
        if let Some(p) = self.server() {
            p.close(client);
        }
    }

    /// Takes the connections the program asked for (`TCP_CONNECT` to mapped hosts) for the
    /// network layer to make; it reports each with [`ProgramMut::dialed`], then moves its
    /// bytes as a client's ([`ProgramMut::send`], [`ProgramMut::recv`]).
    pub fn take_dials(&mut self) -> Vec<ProgramDial> {
        let c = &mut *self.c;
        match &mut c.server {
            Server::Program(p) => p.take_dials(&c.machine),
            Server::Native(_) | Server::Empty => Vec::new(),
        }
    }

    /// How a dial went: connected, or the code the program's `TCP_CONNECT` gets (−34025 when
    /// the host refused). `false` when the program no longer waits for it: close it.
    pub fn dialed(&mut self, client: ClientId, result: Result<(), i32>) -> bool {
        self.server().is_some_and(|p| p.dialed(client, result))
    }
}
