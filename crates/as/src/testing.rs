//! A minimal [`System`] for tests of AS programs and of the interpreter itself (feature
//! `testing`): an FS020N model for ranges, HOME and the forward kinematics of `HERE`, a
//! deliberately simple motion (each joint moves linearly, all arriving together, at
//! `max_speed_deg_s` × the effective speed; a circular motion too, once its circle is checked), the controller's socket table ([`crate::sockets`]) with in-process test clients, and a
//! terminal that keeps every line.
//!
//! It is **not** the emulator: `fs020n-sim` implements [`System`] with the real motion planner
//! (trapezoidal joint moves, straight lines through inverse kinematics, blending, braking),
//! panel, pendant and TCP server. Use this one when a program's logic is under test, the
//! emulator when its motion or the protocol is.

use std::time::Duration;

use fs020n_kin::{CircularArc, RobotModel};
use fs020n_proto::{ErrorCode, JointsDeg};

use crate::flange;
use crate::sockets::{Delivery, SocketLimits, SocketTable, TcpCode};
use crate::system::{
    Datagram, Issued, Joints, MotionKind, MotionRequest, PanelState, SockPoll, Speed, System,
    Target, TaskId, Trans,
};

#[derive(Debug, Clone)]
struct Seg {
    from: Joints,
    to: Joints,
    start: Duration,
    dur: Duration,
    /// Joint-space speed, °/s (`None`: a time-based motion keeps its duration).
    rate: Option<f64>,
    accuracy: f64,
    fine: bool,
    cp: bool,
}

impl Seg {
    fn pos(&self, t: Duration) -> Joints {
        if self.dur.is_zero() || t >= self.start + self.dur {
            return self.to;
        }
        let u = t.saturating_sub(self.start).as_secs_f64() / self.dur.as_secs_f64();
        let mut q = self.from;
        for (k, x) in q.iter_mut().enumerate() {
            *x += (self.to[k] - self.from[k]) * u;
        }
        q
    }

    fn end(&self) -> Duration {
        self.start + self.dur
    }

    /// When the next motion may blend in: once every joint is within `accuracy` degrees of
    /// the target (the toy's ACCURACY, in degrees), and never with FINE or CP OFF.
    fn ready_time(&self) -> Duration {
        let dist = max_abs_diff(&self.from, &self.to);
        if self.fine || !self.cp || dist <= 0.0 || self.accuracy <= 0.0 {
            return self.end();
        }
        let frac = (1.0 - self.accuracy / dist).clamp(0.0, 1.0);
        self.start + self.dur.mul_f64(frac)
    }
}

fn max_abs_diff(a: &Joints, b: &Joints) -> f64 {
    a.iter()
        .zip(b)
        .map(|(x, y)| (x - y).abs())
        .fold(0.0, f64::max)
}

/// The test system (see the module documentation). Its fields are public so that a test can
/// set the panel, read the terminal and the issued motions.
#[derive(Debug, Clone)]
pub struct VirtualSystem {
    /// Time of the latest [`System::advance_to`].
    pub now: Duration,
    /// The robot model (ranges, HOME, kinematics for `HERE` and transformation targets).
    pub model: RobotModel,
    /// Panel switches.
    pub panel: PanelState,
    /// The controller error.
    pub error: ErrorCode,
    /// Monitor speed, percent.
    pub monitor_speed: f64,
    /// Joint speed at 100 %, degrees per second (the toy motion's only parameter).
    pub max_speed_deg_s: f64,
    /// Every line printed, with its task.
    pub terminal: Vec<(TaskId, String)>,
    /// Every motion issued, with when.
    pub motions: Vec<(Duration, MotionRequest)>,
    /// Bytes a socket's receive buffer holds before `TCP_SEND` to it waits.
    pub socket_capacity: usize,
    /// `MC HOLD` in force.
    pub held: bool,
    /// Errors raised, in order.
    pub raised: Vec<ErrorCode>,
    joints: Joints,
    current: Option<Seg>,
    planned: Option<(Seg, Duration)>,
    /// The sockets (test clients are local peers of the program's sockets).
    net: SocketTable,
    /// The sockets of the test clients (local peers, not the program's: `TCP_STATUS` omits
    /// them).
    clients: Vec<i32>,
    /// Datagrams due at a time, for a port ([`VirtualSystem::script_datagram`]).
    udp_script: Vec<(Duration, u16, Datagram)>,
}

impl Default for VirtualSystem {
    fn default() -> Self {
        VirtualSystem::new()
    }
}

impl VirtualSystem {
    /// A ready controller (power ON, RUN, REPEAT, lock OFF, no error) at HOME, monitor speed
    /// 100 %, joints moving at 100 °/s at 100 %.
    pub fn new() -> VirtualSystem {
        let model = RobotModel::fs020n();
        VirtualSystem {
            now: Duration::ZERO,
            joints: model.home.0,
            model,
            panel: PanelState {
                power: true,
                run: true,
                repeat: true,
                teach_lock: false,
            },
            error: ErrorCode::NONE,
            monitor_speed: 100.0,
            max_speed_deg_s: 100.0,
            terminal: Vec::new(),
            motions: Vec::new(),
            socket_capacity: 64 * 1024,
            held: false,
            raised: Vec::new(),
            current: None,
            planned: None,
            clients: Vec::new(),
            udp_script: Vec::new(),
            net: SocketTable::new(SocketLimits {
                local_buffer: 64 * 1024,
                client_buffer: 64 * 1024,
            }),
        }
    }

    /// The terminal lines printed by `task`.
    pub fn lines_of(&self, task: TaskId) -> Vec<&str> {
        self.terminal
            .iter()
            .filter(|(t, _)| *t == task)
            .map(|(_, s)| s.as_str())
            .collect()
    }

    /// A test client connects to `port`: its socket id, `None` when nothing listens.
    pub fn connect(&mut self, port: u16) -> Option<i32> {
        let id = self.net.connect_local(port)?;
        self.clients.push(id);
        Some(id)
    }

    /// A test client sends bytes (`false` when its socket is gone or the peer closed).
    pub fn send(&mut self, client: i32, bytes: &[u8]) -> bool {
        self.net.peer_send(client, bytes)
    }

    /// Everything a test client has received so far.
    pub fn recv(&mut self, client: i32) -> Vec<u8> {
        self.net.take_inbox(client)
    }

    /// `true` when the program closed the other end of a test client's connection.
    pub fn peer_closed(&self, client: i32) -> bool {
        self.net.peer_closed(client)
    }

    /// A test client closes its connection.
    pub fn close(&mut self, client: i32) {
        self.net.close(client);
    }

    /// A datagram reaches `port` now: `false` when no `UDP_RECVFROM` has the port open (it
    /// is lost, as on a network).
    pub fn deliver_datagram(&mut self, port: u16, datagram: Datagram) -> bool {
        self.net.udp_deliver(port, datagram)
    }

    /// A datagram will reach `port` at virtual time `at` (lost if no `UDP_RECVFROM` has the
    /// port open then).
    pub fn script_datagram(&mut self, at: Duration, port: u16, datagram: Datagram) {
        self.udp_script.push((at, port, datagram));
    }

    /// Takes the datagrams the program sent (`UDP_SENDTO`) since the last call, oldest first;
    /// each names its destination.
    pub fn sent_datagrams(&mut self) -> Vec<Datagram> {
        self.net.udp_take_sent()
    }

    /// `true` while a `UDP_RECVFROM` has `port` open.
    pub fn udp_receiving(&self, port: u16) -> bool {
        self.net.udp_receiving(port)
    }

    /// Delivers the scripted datagrams due by `t`.
    fn deliver_scripted(&mut self, t: Duration) {
        if self.udp_script.is_empty() {
            return;
        }
        let (due, later): (Vec<_>, Vec<_>) = std::mem::take(&mut self.udp_script)
            .into_iter()
            .partition(|(at, ..)| *at <= t);
        self.udp_script = later;
        for (_, port, d) in due {
            self.net.udp_deliver(port, d);
        }
    }

    /// The joint angles now.
    pub fn joints_now(&self) -> Joints {
        System::joints(self)
    }

    /// `true` while `port` listens.
    pub fn listening(&self, port: u16) -> bool {
        self.net.listening(port)
    }

    fn settle(&mut self, t: Duration) {
        loop {
            if let Some((p, issued)) = &self.planned {
                let start = match &self.current {
                    Some(c) => c.ready_time().max(*issued),
                    None => *issued,
                };
                if start <= t {
                    let from = match &self.current {
                        Some(c) => c.pos(start),
                        None => self.joints,
                    };
                    let mut seg = p.clone();
                    seg.from = from;
                    seg.start = start;
                    if let Some(rate) = seg.rate {
                        seg.dur = Duration::from_secs_f64(
                            (max_abs_diff(&seg.from, &seg.to) / rate).min(1.0e6),
                        );
                    }
                    self.current = Some(seg);
                    self.planned = None;
                    continue;
                }
            }
            if let Some(c) = &self.current {
                if c.end() <= t {
                    self.joints = c.to;
                    self.current = None;
                    continue;
                }
                self.joints = c.pos(t);
            }
            break;
        }
    }

    /// The motion's duration and, for a speed (not a time), its joint rate in °/s.
    fn duration(&self, req: &MotionRequest, from: &Joints, to: &Joints) -> (Duration, Option<f64>) {
        let monitor = self.monitor_speed.clamp(0.01, 100.0);
        let mut rate = None;
        let secs = match (req.kind, req.speed) {
            (MotionKind::Delay, _) => req.delay_s,
            (_, Speed::Seconds(s)) => s * 100.0 / monitor,
            (_, speed) => {
                let program = match speed {
                    Speed::Percent(p) => p,
                    // The toy treats mm/s as °/s of the fastest joint.
                    Speed::MmPerS(v) => 100.0 * v / self.max_speed_deg_s,
                    Speed::Seconds(_) => 100.0,
                };
                let eff = if req.abs_speed {
                    program.min(monitor)
                } else {
                    program * monitor / 100.0
                };
                let r = self.max_speed_deg_s * eff.max(0.01) / 100.0;
                rate = Some(r);
                max_abs_diff(from, to) / r
            }
        };
        (Duration::from_secs_f64(secs.clamp(0.0, 1.0e6)), rate)
    }

    fn final_target(&self) -> Joints {
        match (&self.planned, &self.current) {
            (Some((p, _)), _) => p.to,
            (None, Some(c)) => c.to,
            (None, None) => self.joints,
        }
    }
}

impl System for VirtualSystem {
    fn advance_to(&mut self, t: Duration) {
        self.deliver_scripted(t);
        if t <= self.now {
            return;
        }
        if self.held || !self.panel.run {
            // Motion pauses: shift everything in progress by the held time.
            let dt = t - self.now;
            if let Some(c) = &mut self.current {
                c.start += dt;
            }
            if let Some((_, issued)) = &mut self.planned {
                *issued += dt;
            }
        }
        self.now = t;
        self.settle(t);
    }

    fn joints(&self) -> Joints {
        match &self.current {
            Some(c) => c.pos(self.now),
            None => self.joints,
        }
    }

    fn pose(&self) -> Option<Trans> {
        Some(flange::forward(&self.model, &self.joints()))
    }

    fn forward(&self, joints: &Joints) -> Option<Trans> {
        Some(flange::forward(&self.model, joints))
    }

    fn inverse_all(&self, pose: &Trans) -> Vec<Joints> {
        flange::inverse_all(&self.model, pose)
    }

    fn inverse(&self, pose: &Trans, near: &Joints) -> Option<Joints> {
        flange::inverse(&self.model, pose, near)
    }

    fn home(&self) -> Joints {
        self.model.home.0
    }

    fn issue_motion(&mut self, req: &MotionRequest) -> Result<Issued, ErrorCode> {
        if !self.error.is_none() {
            // In error (an error program runs): the arm does not move before a reset.
            return Err(self.error);
        }
        self.motions.push((self.now, *req));
        let from = self.final_target();
        let to = match (req.kind, req.target) {
            (MotionKind::Delay, _) => from,
            (_, Target::Joints(j)) => j,
            (_, Target::Pose(p)) => {
                let pose = flange::pose_of(&p);
                match self.model.inverse_nearest(&pose, &JointsDeg(from).to_rad()) {
                    Ok(q) => q.to_deg().0,
                    Err(_) => return Err(ErrorCode::DESTINATION_OUT_OF_RANGE),
                }
            }
        };
        if !to.iter().all(|v| v.is_finite()) || !self.model.within_limits(&JointsDeg(to)) {
            return Err(ErrorCode::DESTINATION_OUT_OF_RANGE);
        }
        if req.kind == MotionKind::Circular {
            // The toy moves its joints linearly to the end; it checks the circle only.
            let start = flange::pose_of(&flange::forward(&self.model, &from));
            let end = flange::pose_of(&flange::forward(&self.model, &to));
            let via = req.via.map(|v| flange::pose_of(&v));
            if via.is_none_or(|v| CircularArc::through(&start, &v, &end).is_err()) {
                return Err(ErrorCode::NO_ARC_THROUGH_POINTS);
            }
        }
        let (dur, rate) = self.duration(req, &from, &to);
        let seg = Seg {
            from,
            to,
            start: self.now,
            dur,
            rate,
            accuracy: req.accuracy_mm,
            fine: req.fine,
            cp: req.cp,
        };
        self.settle(self.now);
        let ready = match &self.current {
            None => true,
            Some(c) => c.ready_time() <= self.now,
        };
        if ready && self.planned.is_none() {
            let mut seg = seg;
            seg.from = self.joints();
            if let Some(rate) = seg.rate {
                seg.dur =
                    Duration::from_secs_f64((max_abs_diff(&seg.from, &seg.to) / rate).min(1.0e6));
            }
            self.current = Some(seg);
            Ok(Issued::Started)
        } else {
            self.planned = Some((seg, self.now));
            Ok(Issued::Planned)
        }
    }

    fn motion_planned(&self) -> bool {
        self.planned.is_some()
    }

    fn motion_in_progress(&self) -> bool {
        self.current.is_some() || self.planned.is_some()
    }

    fn brake(&mut self) {
        self.joints = self.joints();
        self.current = None;
        self.planned = None;
    }

    fn cut_motion(&mut self) {
        self.brake();
    }

    fn set_program_hold(&mut self, held: bool) {
        self.held = held;
    }

    fn panel(&self) -> PanelState {
        self.panel
    }

    fn error(&self) -> ErrorCode {
        self.error
    }

    fn raise_error(&mut self, code: ErrorCode) {
        self.error = code;
        self.raised.push(code);
        self.brake();
    }

    fn reset_error(&mut self) -> Result<(), String> {
        self.error = ErrorCode::NONE;
        Ok(())
    }

    fn set_motor_power(&mut self, on: bool) -> Result<(), String> {
        self.panel.power = on;
        if !on {
            self.brake();
        }
        Ok(())
    }

    fn monitor_speed(&self) -> f64 {
        self.monitor_speed
    }

    fn set_monitor_speed(&mut self, percent: f64) -> Result<(), String> {
        if !(percent.is_finite() && percent > 0.0) {
            return Err(format!("monitor speed {percent} is not above 0"));
        }
        self.monitor_speed = percent.min(100.0);
        Ok(())
    }

    fn tcp_listen(&mut self, port: u16) -> i32 {
        self.net.listen(port)
    }

    fn tcp_end_listen(&mut self, port: u16) -> i32 {
        self.net.end_listen(port)
    }

    fn tcp_accept(&mut self, port: u16) -> SockPoll<(i32, [u8; 4])> {
        self.net.accept(port)
    }

    fn tcp_connect(&mut self, _ip: [u8; 4], port: u16) -> SockPoll<i32> {
        match self.net.connect_local(port) {
            Some(id) => SockPoll::Ready(Ok(id)),
            None => SockPoll::Ready(Err(TcpCode::Broken.code())),
        }
    }

    fn tcp_recv(&mut self, sock: i32, max: usize) -> SockPoll<Vec<u8>> {
        self.net.recv(sock, max)
    }

    fn tcp_send(&mut self, sock: i32, data: &[u8]) -> SockPoll<()> {
        // `socket_capacity` is public: a test may change it at any time.
        let limits = SocketLimits {
            local_buffer: self.socket_capacity,
            ..self.net.limits()
        };
        self.net.set_limits(limits);
        self.net.send(sock, data, self.now, || Delivery::Now)
    }

    fn tcp_close(&mut self, sock: i32) -> i32 {
        self.net.close(sock)
    }

    fn tcp_status(&self) -> Vec<crate::system::SocketStatus> {
        let mut v = self.net.status();
        v.retain(|s| !self.clients.contains(&s.sock));
        v
    }

    fn udp_open(&mut self, port: u16) -> i32 {
        self.net.udp_open(port)
    }

    fn udp_recv(&mut self, port: u16) -> SockPoll<Datagram> {
        self.net.udp_recv(port)
    }

    fn udp_close(&mut self, port: u16) {
        self.net.udp_close(port);
    }

    fn udp_send(&mut self, ip: [u8; 4], port: u16, data: &[u8]) -> i32 {
        self.net.udp_send(Datagram {
            ip,
            port,
            bytes: data.to_vec(),
        })
    }

    fn terminal(&mut self, task: TaskId, line: &str) {
        self.terminal.push((task, line.to_owned()));
    }
}
