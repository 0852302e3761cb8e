//! The native server's view ([`NativeView`]): its session (the communication task) and its
//! motion program, as a driver and a test read them. Without the native server every answer
//! is empty (no session, not listening, 0).

use std::time::Duration;

use fs020n_proto::Command;

use super::Controller;
use crate::native::{NativeServer, SessionId};
use crate::snapshot::{PassInfo, SessionEnd};

/// The native protocol-1040 server of a [`Controller`], borrowed
/// ([`Controller::native`]): the session's state and the wake-up times of its listen windows
/// and receive timeout, and what the motion program decided.
#[derive(Debug, Clone, Copy)]
pub struct NativeView<'a> {
    pub(super) c: &'a Controller,
}

impl<'a> NativeView<'a> {
    fn server(&self) -> Option<&'a NativeServer> {
        self.c.native_server()
    }

    /// The open session, if any.
    pub fn session(&self) -> Option<SessionId> {
        self.server().and_then(NativeServer::session)
    }

    /// `true` while `id` is the open session.
    pub fn is_session_open(&self, id: SessionId) -> bool {
        self.session() == Some(id)
    }

    /// How the latest session ended.
    pub fn last_session_end(&self) -> Option<(SessionId, SessionEnd)> {
        self.server().and_then(NativeServer::last_session_end)
    }

    /// TIMER(1): seconds since the session was accepted (1 ms resolution), 0 without a session.
    pub fn timer1_s(&self) -> f64 {
        self.server().map_or(0.0, |n| n.timer1_s(&self.c.machine))
    }

    /// The newest command of the ring as the motion program reads it (command 0 right after
    /// accept), while a session is open.
    pub fn newest_command(&self) -> Option<Command> {
        self.server().and_then(NativeServer::newest_command)
    }

    /// The ring index of the newest command, while a session is open.
    pub fn newest_index(&self) -> Option<usize> {
        self.server().and_then(NativeServer::newest_index)
    }

    /// When the open session times out for lack of requests (`None` while a delayed reply is
    /// being sent).
    pub fn receive_deadline(&self) -> Option<Duration> {
        self.server().and_then(NativeServer::receive_deadline)
    }

    /// `true` while connections are accepted now.
    pub fn is_listening(&self) -> bool {
        self.server()
            .is_some_and(|n| n.is_listening(&self.c.machine))
    }

    /// When the listening state changes next (window opens or closes); `None` during a session.
    pub fn next_listen_change(&self) -> Option<Duration> {
        self.server()
            .and_then(|n| n.next_listen_change(&self.c.machine))
    }

    /// `true` while signal 2007 (stop the native motion program) is on.
    pub fn stop_signal(&self) -> bool {
        self.server().is_some_and(NativeServer::stop_signal)
    }

    /// The native program's average pass duration `step`, seconds (0 when not running).
    pub fn step_s(&self) -> f64 {
        self.server().map_or(0.0, NativeServer::step_s)
    }

    /// What the latest pass of the native motion program decided.
    pub fn last_pass(&self) -> Option<PassInfo> {
        self.server().and_then(NativeServer::last_pass)
    }
}
