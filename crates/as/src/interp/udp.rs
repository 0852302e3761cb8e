//! UDP statements: `UDP_SENDTO` and `UDP_RECVFROM`, each on its own socket for as long as it
//! runs ([`crate::sockets`], "UDP").

use std::sync::Arc;

use crate::compile::{Op, UdpRecvFrom, UdpSendTo};
use crate::error::RuntimeError;
use crate::sockets::TcpCode;
use crate::system::{Datagram, SockPoll, System};
use crate::value::MAX_INDEX;

use super::arith::{ns, Ns, R};
use super::task::{Flow, TaskSlot, Wait};
use super::Interpreter;
use super::MAX_TRANSFER;

impl Interpreter {
    /// `UDP_SENDTO ret, ip[i], port, $buf[i], n[, timeout]`: one datagram of the elements'
    /// bytes. A send never waits (UDP has no flow control): the timeout is checked, not used.
    pub(super) fn udp_sendto(
        &mut self,
        i: TaskSlot,
        op: &UdpSendTo,
        sys: &mut dyn System,
    ) -> R<Flow> {
        let ip = self.ip_address(i, &op.ip, sys)?;
        let port = self.remote_port(i, &op.port, sys)?;
        self.timeout(i, op.timeout.as_ref(), sys)?;
        let count = self.eval_r(i, &op.n, sys)?.trunc();
        if !(0.0..=MAX_INDEX as f32).contains(&count) {
            return Err(Box::new(RuntimeError::IllegalValue(format!(
                "UDP_SENDTO element count {count}"
            ))));
        }
        let data = self.string_elements(i, &op.buf, count as i32, MAX_TRANSFER, sys)?;
        let r = if data.len() > MAX_TRANSFER {
            TcpCode::TooLong.code()
        } else {
            sys.udp_send(ip, port, &data)
        };
        self.write_r(i, &op.ret, r as f32, sys)?;
        Ok(Flow::Shared)
    }

    /// `UDP_RECVFROM ret, port, $buf[i], count[, timeout[, ip[i][, max]]]`: opens the port,
    /// waits for one datagram.
    pub(super) fn udp_recvfrom(
        &mut self,
        i: TaskSlot,
        op: &UdpRecvFrom,
        sys: &mut dyn System,
        pc: usize,
        now: Ns,
    ) -> R<Flow> {
        let port = self.port(i, &op.port, sys)?;
        let deadline = now.saturating_add(ns(self.timeout(i, op.timeout.as_ref(), sys)?));
        let max = self.element_size(i, op.max.as_ref(), "UDP_RECVFROM", sys)?;
        self.set_pc(i, pc);
        let opened = sys.udp_open(port);
        if opened < 0 {
            self.finish_udp_recv(i, Err(opened), max, sys)?;
            return Ok(Flow::Shared);
        }
        self.tasks[i].udp_port = Some(port);
        Ok(match sys.udp_recv(port) {
            SockPoll::Ready(r) => {
                self.finish_udp_recv(i, r, max, sys)?;
                Flow::Shared
            }
            SockPoll::Pending => Flow::Wait(Box::new(Wait::UdpRecv {
                port,
                max,
                deadline,
            })),
        })
    }

    /// Ends task `i`'s `UDP_RECVFROM` (at its pc) with a datagram or a code: closes its port,
    /// fills the elements, the count, the sender's address and `ret`, and goes on.
    pub(super) fn finish_udp_recv(
        &mut self,
        i: TaskSlot,
        r: Result<Datagram, i32>,
        max: usize,
        sys: &mut dyn System,
    ) -> R<()> {
        if let Some(port) = self.tasks[i].udp_port.take() {
            sys.udp_close(port);
        }
        // A handle on the code (not a copy of the op's variables) while the variables change.
        let code = Arc::clone(&self.code);
        let op = self.tasks[i]
            .frames
            .last()
            .and_then(|f| code.programs.get(f.prog)?.ops.get(f.pc));
        let Some(Op::UdpRecvFrom(op)) = op else {
            return Ok(());
        };
        let ret = match r {
            Ok(d) => {
                let bytes = &d.bytes[..d.bytes.len().min(MAX_TRANSFER)];
                let n = self.split_into_elements(i, &op.buf, bytes, max, sys)?;
                self.write_r(i, &op.count, n as f32, sys)?;
                if let Some(ip) = &op.ip {
                    let dims = ip.idx.len().clamp(1, 3);
                    let base = self.indices(i, ip, sys)?;
                    for (k, b) in d.ip.iter().enumerate() {
                        let mut at = base;
                        at[0] += k as i32;
                        self.write_r_at(i, ip.var, &at[..dims], f32::from(*b))?;
                    }
                }
                0
            }
            Err(e) => {
                self.write_r(i, &op.count, 0.0, sys)?;
                e
            }
        };
        self.write_r(i, &op.ret, ret as f32, sys)?;
        self.advance_pc(i);
        Ok(())
    }

    /// Closes the port of every task that left its `UDP_RECVFROM` without finishing it (it
    /// was aborted, or an interrupt took it elsewhere).
    pub(super) fn close_left_udp_ports(&mut self, sys: &mut dyn System) {
        for t in &mut self.tasks {
            if t.udp_port.is_some() && !matches!(t.wait, Some(Wait::UdpRecv { .. })) {
                if let Some(port) = t.udp_port.take() {
                    sys.udp_close(port);
                }
            }
        }
    }
}
