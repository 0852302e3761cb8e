//! The machine as an AS interpreter's [`System`], for one `run_until`: motions go to the
//! machine's planner (the same joint moves, straight lines, blending, braking and limits as the
//! native server; circles for `C1MOVE`/`C2MOVE`, hybrid paths for `HMOVE`), `SWITCH(…)`,
//! `ERROR` and `MC …` read and operate its panel, the `UDP_…` instructions real UDP sockets
//! ([`UdpPorts`]), and the
//! `TCP_…` instructions use the program's [`SocketTable`] (the emulator keeps only its fault
//! hooks: reply faults, paused reading, counting sessions). A `TCP_CONNECT` or `UDP_SENDTO`
//! goes where the controller's network says ([`crate::Network::route`]): its own ports, a
//! mapped host (a dial the network layer makes), or nowhere (E4023, logged).

use std::time::Duration;

use fs020n_as::flange;
use fs020n_as::sockets::{SocketTable, TcpCode};
use fs020n_as::{
    Datagram, Issued, Joints, MotionKind, MotionRequest, PanelState, SockPoll, Speed, System,
    Target, TaskId, Trans,
};
use fs020n_kin::JointMove;
use fs020n_proto::{ErrorCode, JointsDeg};

use super::net::{delivery_of, Reach, UdpPorts};
use crate::machine::{Machine, OnTick, PlannedAfterBrake};
use crate::motion::{CircularPath, CircularPlanError, HybridPath, LinearPath, Motion, Shape};
use crate::network::Route;

/// Tool speed that percent and mm/s speeds of an `LMOVE` refer to, mm/s (an assumption: the
/// FS020N's maximum TCP speed is not published; the protocol-1040 server uses time-based
/// LMOVEs, which do not depend on it).
pub const MAX_TOOL_SPEED_MM_S: f64 = 2000.0;

/// What the machine's tick needs from the program: the ACCURACY its look-ahead blends in with.
#[derive(Debug, Clone, Copy, Default)]
pub(crate) struct MotionLink {
    /// ACCURACY of the motion in progress, mm (the next one blends in within it).
    pub(crate) accuracy_mm: f64,
    /// ACCURACY of the planned motion (it becomes the current one's when it starts).
    pub(crate) planned_accuracy_mm: f64,
}

/// An AS program's planned motion blends in once the tool is within its ACCURACY; the
/// interpreter does everything else at its own steps.
impl OnTick for MotionLink {
    fn is_idle(&self) -> bool {
        true
    }

    fn deadline(&self) -> Option<Duration> {
        None
    }

    fn on_time(&mut self, _m: &mut Machine) {}

    fn before_motion(&mut self, m: &mut Machine) {
        if m.panel().run {
            if let Some(motion) = m.take_planned_if_ready(self.accuracy_mm) {
                self.accuracy_mm = self.planned_accuracy_mm;
                m.start_motion(motion);
            }
        }
    }

    fn after_motion(&mut self, _m: &mut Machine) {}
}

/// The panel as the interpreter sees it.
pub(crate) fn panel_of(m: &Machine) -> PanelState {
    let p = m.panel();
    PanelState {
        power: p.power,
        run: p.run,
        repeat: p.repeat,
        teach_lock: p.teach_lock,
    }
}

/// The controller as the interpreter's system, for one `run_until`.
pub(crate) struct Host<'a> {
    pub(crate) m: &'a mut Machine,
    pub(crate) net: &'a mut SocketTable,
    pub(crate) planned: &'a mut Option<(MotionRequest, JointsDeg)>,
    pub(crate) link: &'a mut MotionLink,
    pub(crate) udp: &'a mut UdpPorts,
    pub(crate) reach: &'a mut Reach,
}

impl Host<'_> {
    /// The program speed as a fraction of the joints' maximum speeds, with the monitor speed
    /// (product, or minimum with ABS.SPEED).
    fn joint_fraction(&self, req: &MotionRequest, from: JointsDeg, to: JointsDeg) -> f64 {
        let monitor = self.m.monitor_speed();
        let program = match req.speed {
            Speed::Percent(p) => p,
            Speed::MmPerS(v) => 100.0 * v / MAX_TOOL_SPEED_MM_S,
            Speed::Seconds(s) => {
                // A time for a joint move: the percentage that takes that long at 100 %.
                let full = JointMove::plan(self.m.model(), from, to, 1.0).duration_s();
                if s > 0.0 {
                    100.0 * full / s
                } else {
                    100.0
                }
            }
        }
        .clamp(0.01, 100.0);
        let eff = if req.abs_speed {
            program.min(monitor)
        } else {
            program * monitor / 100.0
        };
        (eff / 100.0).clamp(1.0e-4, 1.0)
    }

    /// The duration asked of a straight-line move, seconds (the planner stretches it when a
    /// joint would exceed its speed).
    fn linear_duration(&self, req: &MotionRequest, from: JointsDeg, to: JointsDeg) -> f64 {
        let model = self.m.model();
        let dist_mm = model
            .forward(&from.to_rad())
            .distance_m(&model.forward(&to.to_rad()))
            * 1000.0;
        self.tool_path_duration(req, dist_mm)
    }

    /// The duration asked of a tool path `dist_mm` long (a line's or a circle's), seconds: the
    /// length at the tool speed, or the time the program gives.
    fn tool_path_duration(&self, req: &MotionRequest, dist_mm: f64) -> f64 {
        let monitor = self.m.monitor_speed().max(0.01);
        let tool_speed = |program_mm_s: f64| {
            let v = if req.abs_speed {
                program_mm_s.min(MAX_TOOL_SPEED_MM_S * monitor / 100.0)
            } else {
                program_mm_s * monitor / 100.0
            };
            dist_mm / v.max(1.0e-3)
        };
        match req.speed {
            // Time and absolute speeds are defined at monitor 100 % (the native server's rule).
            Speed::Seconds(s) => s * 100.0 / monitor,
            Speed::MmPerS(v) => tool_speed(v),
            Speed::Percent(p) => tool_speed(MAX_TOOL_SPEED_MM_S * p.clamp(0.01, 100.0) / 100.0),
        }
    }

    fn build(
        &self,
        req: &MotionRequest,
        from: JointsDeg,
    ) -> Result<(Motion, JointsDeg), ErrorCode> {
        let model = self.m.model();
        let target = match (req.kind, req.target) {
            (MotionKind::Delay, _) => from,
            (_, Target::Joints(j)) => JointsDeg(j),
            (_, Target::Pose(p)) => model
                .inverse_nearest(&flange::pose_of(&p), &from.to_rad())
                .map(|q| q.to_deg())
                .map_err(|_| ErrorCode::DESTINATION_OUT_OF_RANGE)?,
        };
        if !target.is_finite() || !model.within_limits(&target) {
            tracing::warn!(%target, "E1088: destination is out of motion range");
            return Err(ErrorCode::DESTINATION_OUT_OF_RANGE);
        }
        let tick = self.m.timing().tick.as_secs_f64();
        let shape = match req.kind {
            MotionKind::Joint => Shape::Joint(JointMove::plan(
                model,
                from,
                target,
                self.joint_fraction(req, from, target),
            )),
            MotionKind::Linear => {
                let d = self.linear_duration(req, from, target);
                match LinearPath::plan(model, from, target, d, tick) {
                    Some(p) => Shape::Linear(p),
                    None => {
                        tracing::warn!(%target, "E1088: no straight-line path to the destination");
                        return Err(ErrorCode::DESTINATION_OUT_OF_RANGE);
                    }
                }
            }
            MotionKind::Circular => {
                let Some(via) = req.via else {
                    return Err(ErrorCode::C1MOVE_REQUIRED_BEFORE_C2MOVE);
                };
                let duration_of = |length_mm| self.tool_path_duration(req, length_mm);
                match CircularPath::plan(model, from, &flange::pose_of(&via), target, duration_of) {
                    Ok(p) => Shape::Circular(p),
                    Err(CircularPlanError::NoCircle(e)) => {
                        tracing::warn!(%e, "E1099: the three points of the arc define no circle");
                        return Err(ErrorCode::NO_ARC_THROUGH_POINTS);
                    }
                    Err(CircularPlanError::Unreachable) => {
                        tracing::warn!(%target, "E1088: no circular path to the destination");
                        return Err(ErrorCode::DESTINATION_OUT_OF_RANGE);
                    }
                }
            }
            MotionKind::Hybrid => {
                let duration_of = |length_mm| self.tool_path_duration(req, length_mm);
                match HybridPath::plan(model, from, target, duration_of) {
                    Some(p) => Shape::Hybrid(p),
                    None => {
                        tracing::warn!(%target, "E1088: no hybrid path to the destination");
                        return Err(ErrorCode::DESTINATION_OUT_OF_RANGE);
                    }
                }
            }
            MotionKind::Delay => {
                match LinearPath::plan(model, from, from, req.delay_s.max(0.0), tick) {
                    Some(p) => Shape::Linear(p),
                    None => return Err(ErrorCode::DESTINATION_OUT_OF_RANGE),
                }
            }
        };
        Ok((
            Motion {
                from,
                to: target,
                shape,
            },
            target,
        ))
    }

    fn accuracy_of(req: &MotionRequest) -> f64 {
        if req.fine || !req.cp {
            0.0
        } else {
            req.accuracy_mm
        }
    }
}

impl System for Host<'_> {
    fn advance_to(&mut self, t: Duration) {
        self.m.integrate_to(t, &mut *self.link);
    }

    fn joints(&self) -> Joints {
        self.m.arm().joints().0
    }

    fn pose(&self) -> Option<Trans> {
        Some(flange::forward(self.m.model(), &self.m.arm().joints().0))
    }

    fn forward(&self, joints: &Joints) -> Option<Trans> {
        Some(flange::forward(self.m.model(), joints))
    }

    fn inverse_all(&self, pose: &Trans) -> Vec<Joints> {
        flange::inverse_all(self.m.model(), pose)
    }

    fn inverse(&self, pose: &Trans, near: &Joints) -> Option<Joints> {
        flange::inverse(self.m.model(), pose, near)
    }

    fn home(&self) -> Joints {
        self.m.model().home.0
    }

    fn issue_motion(&mut self, req: &MotionRequest) -> Result<Issued, ErrorCode> {
        let error = self.m.error();
        if !error.is_none() {
            // In error (an error program runs): the arm does not move before a reset.
            return Err(error);
        }
        let from = self.m.arm().target();
        let (m, target) = self.build(req, from)?;
        let accuracy = Host::accuracy_of(req);
        if !self.m.arm().has_planned() && self.m.ready_for_next(self.link.accuracy_mm) {
            self.link.accuracy_mm = accuracy;
            self.m.start_motion(m);
            *self.planned = None;
            Ok(Issued::Started)
        } else {
            self.link.planned_accuracy_mm = accuracy;
            self.m.plan_motion(m);
            *self.planned = Some((*req, target));
            Ok(Issued::Planned)
        }
    }

    fn motion_planned(&self) -> bool {
        self.m.arm().has_planned()
    }

    fn motion_in_progress(&self) -> bool {
        !self.m.arm().is_still()
    }

    fn brake(&mut self) {
        let had_planned = self.m.arm().has_planned();
        self.m.brake();
        let planned = self.planned.take();
        if self.m.behaviour().planned_after_brake == PlannedAfterBrake::Execute && had_planned {
            // The planned motion starts from where the brake stops the arm.
            if let Some((req, _)) = planned {
                let from = self.m.arm().target();
                match self.build(&req, from) {
                    Ok((m, target)) => {
                        self.m.plan_motion(m);
                        *self.planned = Some((req, target));
                    }
                    Err(code) => self.m.raise(code),
                }
            }
        }
    }

    fn cut_motion(&mut self) {
        self.m.brake();
        *self.planned = None;
    }

    fn set_program_hold(&mut self, held: bool) {
        let run = self.m.panel().run;
        self.m.set_hold(held || !run);
    }

    fn panel(&self) -> PanelState {
        panel_of(self.m)
    }

    fn error(&self) -> ErrorCode {
        self.m.error()
    }

    fn raise_error(&mut self, code: ErrorCode) {
        tracing::warn!(%code, "AS program error");
        self.m.raise(code);
    }

    fn reset_error(&mut self) -> Result<(), String> {
        self.m.reset_error().map_err(|e| e.to_string())
    }

    fn set_motor_power(&mut self, on: bool) -> Result<(), String> {
        self.m.set_power(on).map_err(|e| e.to_string())
    }

    fn monitor_speed(&self) -> f64 {
        self.m.monitor_speed()
    }

    fn set_monitor_speed(&mut self, percent: f64) -> Result<(), String> {
        if !(percent.is_finite() && percent > 0.0) {
            return Err(format!("monitor speed {percent} % is not above 0"));
        }
        self.m
            .set_monitor_speed(percent.min(100.0))
            .map_err(|e| e.to_string())
    }

    fn tcp_listen(&mut self, port: u16) -> i32 {
        self.net.listen(port)
    }

    fn tcp_end_listen(&mut self, port: u16) -> i32 {
        self.net.end_listen(port)
    }

    fn tcp_accept(&mut self, port: u16) -> SockPoll<(i32, [u8; 4])> {
        let accepted = self.net.accept(port);
        if let SockPoll::Ready(Ok((id, _))) = accepted {
            // Session counting: a client of the served port is a session.
            if self.net.served_port() == Some(port) {
                self.m.counters_mut().sessions += 1;
            }
            tracing::info!(port, socket = id, "AS program accepted a connection");
        }
        accepted
    }

    fn tcp_connect(&mut self, ip: [u8; 4], port: u16) -> SockPoll<i32> {
        match self.reach.route(self.m.network(), "TCP_CONNECT", ip, port) {
            // The program's own listeners (a controller talking to itself).
            Ok(Route::Own) => match self.net.connect_local(port) {
                Some(id) => SockPoll::Ready(Ok(id)),
                None => SockPoll::Ready(Err(TcpCode::Broken.code())),
            },
            // A real host: the network layer dials it.
            Ok(Route::Host(_)) => self.net.connect_remote(ip, port),
            Ok(Route::Unmapped) | Err(_) => SockPoll::Ready(Err(TcpCode::Unreachable.code())),
        }
    }

    fn tcp_connect_abandon(&mut self, ip: [u8; 4], port: u16) {
        self.net.abandon_connect(ip, port);
    }

    fn tcp_recv(&mut self, sock: i32, max: usize) -> SockPoll<Vec<u8>> {
        // Fault hook: `stop_reading` holds a client's bytes back.
        if self.m.reading_paused_until().is_some() && self.net.is_client(sock) {
            return SockPoll::Pending;
        }
        self.net.recv(sock, max)
    }

    fn tcp_send(&mut self, sock: i32, data: &[u8]) -> SockPoll<()> {
        let now = self.m.now();
        let m = &mut *self.m;
        // Fault hook: the next reply fault shapes what a client receives (asked only when
        // the send is taken).
        self.net
            .send(sock, data, now, || delivery_of(m.next_reply_fault()))
    }

    fn tcp_close(&mut self, sock: i32) -> i32 {
        self.net.close(sock)
    }

    fn tcp_status(&self) -> Vec<fs020n_as::SocketStatus> {
        self.net.status()
    }

    fn udp_open(&mut self, port: u16) -> i32 {
        self.udp.open(self.net, port)
    }

    fn udp_recv(&mut self, port: u16) -> SockPoll<Datagram> {
        self.udp.pump(self.net, port, self.m.network());
        self.net.udp_recv(port)
    }

    fn udp_close(&mut self, port: u16) {
        self.udp.close(self.net, port);
    }

    fn udp_send(&mut self, ip: [u8; 4], port: u16, data: &[u8]) -> i32 {
        let to = match self.reach.route(self.m.network(), "UDP_SENDTO", ip, port) {
            Ok(Route::Own) => self.udp.own(),
            Ok(Route::Host(real)) => real,
            Ok(Route::Unmapped) => return TcpCode::Unreachable.code(),
            Err(code) => return code,
        };
        self.udp.send(std::net::SocketAddr::new(to, port), data)
    }

    fn terminal(&mut self, task: TaskId, line: &str) {
        tracing::debug!(%task, line, "AS terminal");
    }
}
