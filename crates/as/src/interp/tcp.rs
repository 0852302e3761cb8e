//! TCP statements: `TCP_LISTEN` … `TCP_CLOSE`, their ports, timeouts and results.

use std::sync::Arc;
use std::time::Duration;

use crate::compile::{LRef, Op, RExpr, Ty};
use crate::error::RuntimeError;
use crate::sockets::TcpCode;
use crate::system::{SockPoll, System};
use crate::value::{Bytes, MAX_INDEX};

use super::arith::{ns, Ns, R};
use super::task::{Flow, TaskSlot, Wait};
use super::Interpreter;
use super::MAX_TRANSFER;

impl Interpreter {
    /// `TCP_LISTEN ret, port` (`listen`) or `TCP_END_LISTEN ret, port`.
    #[inline(always)]
    pub(super) fn tcp_listening(
        &mut self,
        i: TaskSlot,
        ret: &LRef,
        port: &RExpr,
        listen: bool,
        sys: &mut dyn System,
    ) -> R<Flow> {
        let port = self.port(i, port, sys)?;
        let r = if listen {
            sys.tcp_listen(port)
        } else {
            sys.tcp_end_listen(port)
        };
        self.write_r(i, ret, r as f32, sys)?;
        Ok(Flow::Shared)
    }

    /// `TCP_ACCEPT ret, port, timeout[, ip]`: waits for a connection.
    #[inline(always)]
    pub(super) fn tcp_accept(
        &mut self,
        i: TaskSlot,
        port: &RExpr,
        timeout: &Option<RExpr>,
        sys: &mut dyn System,
        pc: usize,
        now: Ns,
    ) -> R<Flow> {
        let port = self.port(i, port, sys)?;
        let deadline = now.saturating_add(ns(self.timeout(i, timeout.as_ref(), sys)?));
        self.set_pc(i, pc);
        Ok(match sys.tcp_accept(port) {
            SockPoll::Ready(r) => {
                self.finish_accept(i, r, sys)?;
                Flow::Shared
            }
            SockPoll::Pending => Flow::Wait(Box::new(Wait::Accept { port, deadline })),
        })
    }

    /// `TCP_CONNECT ret, port, ip[i], timeout`.
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    pub(super) fn tcp_connect(
        &mut self,
        i: TaskSlot,
        port: &RExpr,
        ip: &LRef,
        timeout: &Option<RExpr>,
        sys: &mut dyn System,
        pc: usize,
        now: Ns,
    ) -> R<Flow> {
        let port = self.remote_port(i, port, sys)?;
        let deadline = now.saturating_add(ns(self.timeout(i, timeout.as_ref(), sys)?));
        let addr = self.ip_address(i, ip, sys)?;
        self.set_pc(i, pc);
        Ok(match sys.tcp_connect(addr, port) {
            SockPoll::Ready(r) => {
                self.finish_ret(i, r.unwrap_or_else(|e| e) as f32, sys)?;
                Flow::Shared
            }
            SockPoll::Pending => Flow::Wait(Box::new(Wait::Connect {
                ip: addr,
                port,
                deadline,
            })),
        })
    }

    /// `TCP_RECV ret, sock, $buf[i], n, timeout[, max]`: waits for bytes.
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    pub(super) fn tcp_recv(
        &mut self,
        i: TaskSlot,
        sock: &RExpr,
        timeout: &Option<RExpr>,
        max: &Option<RExpr>,
        sys: &mut dyn System,
        pc: usize,
        now: Ns,
    ) -> R<Flow> {
        let sock = self.eval_r(i, sock, sys)?.trunc() as i32;
        let deadline = now.saturating_add(ns(self.timeout(i, timeout.as_ref(), sys)?));
        let max = self.element_size(i, max.as_ref(), "TCP_RECV", sys)?;
        self.set_pc(i, pc);
        Ok(match sys.tcp_recv(sock, MAX_TRANSFER) {
            SockPoll::Ready(r) => {
                self.finish_recv(i, r, max, sys)?;
                Flow::Shared
            }
            SockPoll::Pending => Flow::Wait(Box::new(Wait::Recv {
                sock,
                max,
                deadline,
            })),
        })
    }

    /// `TCP_CLOSE ret, sock`.
    #[inline(always)]
    pub(super) fn tcp_close(
        &mut self,
        i: TaskSlot,
        ret: &LRef,
        sock: &RExpr,
        sys: &mut dyn System,
    ) -> R<Flow> {
        let sock = self.eval_r(i, sock, sys)?.trunc() as i32;
        let r = sys.tcp_close(sock);
        self.write_r(i, ret, r as f32, sys)?;
        Ok(Flow::Shared)
    }

    /// `TCP_STATUS ret, port[i], sock[i], err[i], sub[i], $ip[i]`: `ret` is the number of open
    /// sockets; element `i + k` of each array describes the k-th (sub-error always 0, the
    /// address as `"a.b.c.d"`).
    pub(super) fn tcp_status(
        &mut self,
        i: TaskSlot,
        ret: &LRef,
        arrays: &[LRef; 5],
        sys: &mut dyn System,
    ) -> R<Flow> {
        let list = sys.tcp_status();
        for (k, s) in list.iter().enumerate() {
            let ip = format!("{}.{}.{}.{}", s.ip[0], s.ip[1], s.ip[2], s.ip[3]);
            let values = [f32::from(s.port), s.sock as f32, s.error as f32, 0.0];
            for (a, v) in arrays.iter().zip(values) {
                let n = a.idx.len().clamp(1, 3);
                let mut at = self.indices(i, a, sys)?;
                at[0] += k as i32;
                self.write_r_at(i, a.var, &at[..n], v)?;
            }
            let a = &arrays[4];
            let n = a.idx.len().clamp(1, 3);
            let mut at = self.indices(i, a, sys)?;
            at[0] += k as i32;
            self.write_s_at(i, a.var, &at[..n], Bytes::from(ip.as_bytes()))?;
        }
        self.write_r(i, ret, list.len() as f32, sys)?;
        Ok(Flow::Next)
    }

    /// The 4 elements from `ip[i]` as an IPv4 address (each 0–255).
    pub(super) fn ip_address(
        &mut self,
        i: TaskSlot,
        ip: &LRef,
        sys: &mut dyn System,
    ) -> R<[u8; 4]> {
        let dims = ip.idx.len().clamp(1, 3);
        let base = self.indices(i, ip, sys)?;
        let mut addr = [0u8; 4];
        for (k, b) in addr.iter_mut().enumerate() {
            let mut at = base;
            at[0] += k as i32;
            let v = match self
                .store(i, ip.var.global)
                .reals
                .get(ip.var.slot as usize)
                .and_then(|x| x.get(&at[..dims]))
            {
                Some(v) => *v,
                None => return Err(self.undefined(i, ip, Ty::Real, &at[..dims])),
            };
            if !(0.0..=255.0).contains(&v) {
                return Err(Box::new(RuntimeError::IllegalValue(format!(
                    "IP address byte {v}"
                ))));
            }
            *b = v as u8;
        }
        Ok(addr)
    }

    /// The bytes per element of `TCP_RECV`/`UDP_RECVFROM` (`what`): 1–255, 255 when omitted.
    pub(super) fn element_size(
        &mut self,
        i: TaskSlot,
        max: Option<&RExpr>,
        what: &str,
        sys: &mut dyn System,
    ) -> R<usize> {
        let Some(m) = max else { return Ok(255) };
        let m = self.eval_r(i, m, sys)?.trunc();
        if !(1.0..=255.0).contains(&m) {
            return Err(Box::new(RuntimeError::IllegalValue(format!(
                "{what} element size {m} (1 to 255)"
            ))));
        }
        Ok(m as usize)
    }

    /// A port of another host (`TCP_CONNECT`, `UDP_SENDTO`): 1–65535. The 8192–65535 rule of
    /// the manual is for the controller's own listening ports; a PC or camera may listen
    /// anywhere (our reading: the manuals give no range for a remote port).
    pub(super) fn remote_port(&mut self, i: TaskSlot, e: &RExpr, sys: &mut dyn System) -> R<u16> {
        let p = self.eval_r(i, e, sys)?.trunc();
        if !(1.0..=65535.0).contains(&p) {
            return Err(Box::new(RuntimeError::IllegalValue(format!(
                "port {p} (1 to 65535)"
            ))));
        }
        Ok(p as u16)
    }

    /// One of the controller's own ports (`TCP_LISTEN`, `TCP_ACCEPT`, `TCP_END_LISTEN`,
    /// `UDP_RECVFROM`): 8192–65535 (TCP/IP manual E).
    pub(super) fn port(&mut self, i: TaskSlot, e: &RExpr, sys: &mut dyn System) -> R<u16> {
        let p = self.eval_r(i, e, sys)?.trunc();
        if !(8192.0..=65535.0).contains(&p) {
            return Err(Box::new(RuntimeError::IllegalValue(format!(
                "port {p} (8192 to 65535)"
            ))));
        }
        Ok(p as u16)
    }

    pub(super) fn timeout(
        &mut self,
        i: TaskSlot,
        e: Option<&RExpr>,
        sys: &mut dyn System,
    ) -> R<Duration> {
        let v = match e {
            Some(e) => self.eval_r(i, e, sys)?,
            None => 1.0,
        };
        if !(0.0..=60.0).contains(&v) {
            return Err(Box::new(RuntimeError::IllegalValue(format!(
                "timeout {v} s (0 to 60)"
            ))));
        }
        Ok(Duration::from_secs_f64(f64::from(v)))
    }

    /// Writes a socket instruction's result to its `ret` variable and goes on.
    pub(super) fn finish_ret(&mut self, i: TaskSlot, v: f32, sys: &mut dyn System) -> R<()> {
        let code = Arc::clone(&self.code);
        let op = self.tasks[i]
            .frames
            .last()
            .and_then(|f| code.programs.get(f.prog)?.ops.get(f.pc));
        let ret = match op {
            Some(
                Op::TcpConnect { ret, .. }
                | Op::TcpSend { ret, .. }
                | Op::TcpAccept { ret, .. }
                | Op::TcpRecv { ret, .. },
            ) => ret,
            _ => return Ok(()),
        };
        self.write_r(i, ret, v, sys)?;
        self.advance_pc(i);
        Ok(())
    }

    pub(super) fn finish_accept(
        &mut self,
        i: TaskSlot,
        r: Result<(i32, [u8; 4]), i32>,
        sys: &mut dyn System,
    ) -> R<()> {
        let ip = match self.current_op(i) {
            Some(Op::TcpAccept { ip, .. }) => ip.clone(),
            _ => None,
        };
        if let (Ok((_, addr)), Some(ip)) = (&r, ip) {
            let n = ip.idx.len().clamp(1, 3);
            let base = self.indices(i, &ip, sys)?;
            for (k, b) in addr.iter().enumerate() {
                let mut at = base;
                at[0] += k as i32;
                self.write_r_at(i, ip.var, &at[..n], f32::from(*b))?;
            }
        }
        let v = match r {
            Ok((id, _)) => id as f32,
            Err(e) => e as f32,
        };
        self.finish_ret(i, v, sys)
    }

    pub(super) fn finish_recv(
        &mut self,
        i: TaskSlot,
        r: Result<Vec<u8>, i32>,
        max: usize,
        sys: &mut dyn System,
    ) -> R<()> {
        // A handle on the code (not a copy of the op's variables) while the variables change.
        let code = Arc::clone(&self.code);
        let op = self.tasks[i]
            .frames
            .last()
            .and_then(|f| code.programs.get(f.prog)?.ops.get(f.pc));
        let (buf, count) = match op {
            Some(Op::TcpRecv { buf, count, .. }) => (buf, count),
            _ => return Ok(()),
        };
        match r {
            Ok(bytes) => {
                let n = self.split_into_elements(i, buf, &bytes, max, sys)?;
                self.write_r(i, count, n as f32, sys)?;
                self.finish_ret(i, 0.0, sys)
            }
            Err(e) => {
                self.write_r(i, count, 0.0, sys)?;
                self.finish_ret(i, e as f32, sys)
            }
        }
    }

    /// `TCP_SEND ret, sock, $buf[i], n, timeout`: waits until the peer takes the bytes.
    /// `None`: refused at once for its size (`ret` = −34022), and the step takes no time.
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    pub(super) fn tcp_send(
        &mut self,
        i: TaskSlot,
        ret: &LRef,
        sock: &RExpr,
        buf: &LRef,
        n: &RExpr,
        timeout: &Option<RExpr>,
        sys: &mut dyn System,
        pc: usize,
        now: Ns,
    ) -> R<Option<Flow>> {
        let sock = self.eval_r(i, sock, sys)?.trunc() as i32;
        let deadline = now.saturating_add(ns(self.timeout(i, timeout.as_ref(), sys)?));
        let count = self.eval_r(i, n, sys)?.trunc();
        if !(0.0..=MAX_INDEX as f32).contains(&count) {
            return Err(Box::new(RuntimeError::IllegalValue(format!(
                "TCP_SEND element count {count}"
            ))));
        }
        let data = self.string_elements(i, buf, count as i32, MAX_TRANSFER, sys)?;
        if data.len() > MAX_TRANSFER {
            self.write_r(i, ret, TcpCode::TooLong.code() as f32, sys)?;
            return Ok(None);
        }
        self.set_pc(i, pc);
        Ok(Some(match sys.tcp_send(sock, &data) {
            SockPoll::Ready(r) => {
                self.finish_ret(i, r.map_or_else(|e| e as f32, |()| 0.0), sys)?;
                Flow::Shared
            }
            SockPoll::Pending => Flow::Wait(Box::new(Wait::Send {
                sock,
                data,
                deadline,
            })),
        }))
    }
}
