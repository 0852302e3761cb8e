//! A blocking API on top of the asynchronous one.
//!
//! [`Robot`] owns a small tokio runtime with **one worker thread**. It cannot be a
//! current-thread runtime (as tokio-modbus's synchronous client uses): the session task must
//! keep polling the controller while the caller is busy elsewhere, otherwise the controller's
//! 5 s receive timeout would end the session (and stop the robot) whenever the program paused
//! between two calls. Each method runs the async method with `block_on`.
//!
//! Do not call these methods from inside an async runtime (tokio panics on nested
//! `block_on`); use [`crate::Robot`] there.

use std::sync::Arc;
use std::time::Duration;

use fs020n_kin::{Pose, RobotModel};
use fs020n_proto::{JointsDeg, ReplyFrame, Status};
use tokio::runtime::Runtime;
use tokio::sync::watch;

use crate::clock::ClockFit;
use crate::config::ClientConfig;
use crate::error::ClientError;
use crate::motion::{Completion, MoveProgress, MoveReport};
use crate::session::StatusSnapshot;
use crate::stats::Stats;
use crate::stream::{StreamOptions, StreamProgress, StreamReport};
use crate::trajectory::Trajectory;
use crate::transport::Connector;

fn runtime() -> Result<Arc<Runtime>, ClientError> {
    tokio::runtime::Builder::new_multi_thread()
        .worker_threads(1)
        .thread_name("fs020n-client")
        .enable_all()
        .build()
        .map(Arc::new)
        .map_err(|e| ClientError::Config(format!("cannot start the client's runtime: {e}")))
}

/// Blocking robot handle; the methods mirror [`crate::Robot`].
///
/// ```no_run
/// use fs020n_client::{blocking::Robot, ClientConfig, Completion};
/// use fs020n_proto::JointsDeg;
/// let robot = Robot::connect("127.0.0.1:10050", ClientConfig::default())?;
/// robot.preflight()?;
/// robot.start()?;
/// robot
///     .move_joints(JointsDeg::new([10.0, 0.0, -90.0, 0.0, -90.0, 0.0]))?
///     .wait(Completion::default())?;
/// robot.close()?;
/// # Ok::<(), fs020n_client::ClientError>(())
/// ```
#[derive(Debug)]
pub struct Robot {
    rt: Arc<Runtime>,
    inner: Option<crate::Robot>,
}

impl Robot {
    /// See [`crate::Robot::connect`].
    pub fn connect(addr: &str, config: ClientConfig) -> Result<Robot, ClientError> {
        let rt = runtime()?;
        let inner = rt.block_on(crate::Robot::connect(addr, config))?;
        Ok(Robot {
            rt,
            inner: Some(inner),
        })
    }

    /// See [`crate::Robot::connect_with`].
    pub fn connect_with(
        connector: impl Connector,
        config: ClientConfig,
    ) -> Result<Robot, ClientError> {
        let rt = runtime()?;
        let inner = rt.block_on(crate::Robot::connect_with(connector, config))?;
        Ok(Robot {
            rt,
            inner: Some(inner),
        })
    }

    fn r(&self) -> &crate::Robot {
        // Only `Drop` takes it out.
        #[allow(clippy::expect_used)]
        self.inner
            .as_ref()
            .expect("the robot handle is present until drop")
    }

    /// The asynchronous handle and its runtime, for mixing both styles.
    pub fn as_async(&self) -> (&crate::Robot, &Runtime) {
        (self.r(), &self.rt)
    }

    /// See [`crate::Robot::reconnect`].
    pub fn reconnect(&mut self) -> Result<(), ClientError> {
        let rt = self.rt.clone();
        match self.inner.as_mut() {
            Some(inner) => rt.block_on(inner.reconnect()),
            None => Err(ClientError::Closed),
        }
    }

    /// See [`crate::Robot::is_connected`].
    pub fn is_connected(&self) -> bool {
        self.r().is_connected()
    }

    /// See [`crate::Robot::link_error`].
    pub fn link_error(&self) -> Option<ClientError> {
        self.r().link_error()
    }

    /// See [`crate::Robot::status`].
    pub fn status(&self) -> Option<StatusSnapshot> {
        self.r().status()
    }

    /// See [`crate::Robot::subscribe`] (use `borrow()` / `has_changed()` from blocking code).
    pub fn subscribe(&self) -> watch::Receiver<Option<StatusSnapshot>> {
        self.r().subscribe()
    }

    /// See [`crate::Robot::poll`].
    pub fn poll(&self) -> Result<Status, ClientError> {
        self.rt.block_on(self.r().poll())
    }

    /// See [`crate::Robot::preflight`].
    pub fn preflight(&self) -> Result<(), ClientError> {
        self.rt.block_on(self.r().preflight())
    }

    /// See [`crate::Robot::start`].
    pub fn start(&self) -> Result<(), ClientError> {
        self.rt.block_on(self.r().start())
    }

    /// See [`crate::Robot::stop_program`].
    pub fn stop_program(&self) -> Result<Status, ClientError> {
        self.rt.block_on(self.r().stop_program())
    }

    /// See [`crate::Robot::set_speed`].
    pub fn set_speed(&self, percent: f64) -> Result<Status, ClientError> {
        self.rt.block_on(self.r().set_speed(percent))
    }

    /// See [`crate::Robot::cancel`].
    pub fn cancel(&self) -> Result<Status, ClientError> {
        self.rt.block_on(self.r().cancel())
    }

    /// See [`crate::Robot::close`].
    pub fn close(&self) -> Result<(), ClientError> {
        self.rt.block_on(self.r().close())
    }

    /// See [`crate::Robot::move_joints`].
    pub fn move_joints(&self, target: JointsDeg) -> Result<MoveHandle, ClientError> {
        let inner = self.rt.block_on(self.r().move_joints(target))?;
        Ok(MoveHandle {
            rt: self.rt.clone(),
            inner,
        })
    }

    /// See [`crate::Robot::move_pose`].
    pub fn move_pose(&self, target: impl Into<Pose>) -> Result<MoveHandle, ClientError> {
        let inner = self.rt.block_on(self.r().move_pose(target))?;
        Ok(MoveHandle {
            rt: self.rt.clone(),
            inner,
        })
    }

    /// See [`crate::Robot::stream`].
    pub fn stream(
        &self,
        trajectory: Trajectory,
        options: StreamOptions,
    ) -> Result<StreamHandle, ClientError> {
        let inner = self.rt.block_on(self.r().stream(trajectory, options))?;
        Ok(StreamHandle {
            rt: self.rt.clone(),
            inner,
        })
    }

    /// See [`crate::Robot::send_raw`].
    pub fn send_raw(&self, text: &str, allow_motion: bool) -> Result<ReplyFrame, ClientError> {
        self.rt.block_on(self.r().send_raw(text, allow_motion))
    }

    /// See [`crate::Robot::stats`].
    pub fn stats(&self) -> Stats {
        self.r().stats()
    }

    /// See [`crate::Robot::server_clock`].
    pub fn server_clock(&self) -> Option<ClockFit> {
        self.r().server_clock()
    }

    /// See [`crate::Robot::server_time_now`].
    pub fn server_time_now(&self) -> Option<f64> {
        self.r().server_time_now()
    }

    /// See [`crate::Robot::model`].
    pub fn model(&self) -> &RobotModel {
        self.r().model()
    }
}

impl Drop for Robot {
    /// Ends the session with 255 (bounded by the close timeout) before the runtime goes away,
    /// so that the controller stops the robot at once rather than after its 5 s timeout.
    fn drop(&mut self) {
        if let Some(inner) = self.inner.take() {
            if tokio::runtime::Handle::try_current().is_err() && inner.is_connected() {
                let limit = inner.config().close_timeout + inner.config().reply_timeout;
                let _ = self
                    .rt
                    .block_on(async { tokio::time::timeout(limit, inner.close()).await });
            }
        }
    }
}

/// Blocking handle of a joint move; see [`crate::MoveHandle`].
#[derive(Debug, Clone)]
pub struct MoveHandle {
    rt: Arc<Runtime>,
    inner: crate::MoveHandle,
}

impl MoveHandle {
    /// See [`crate::MoveHandle::wait`].
    pub fn wait(&self, completion: Completion) -> Result<MoveReport, ClientError> {
        self.rt.block_on(self.inner.wait(completion))
    }

    /// See [`crate::MoveHandle::cancel`].
    pub fn cancel(&self) -> Result<(), ClientError> {
        self.rt.block_on(self.inner.cancel())
    }

    /// See [`crate::MoveHandle::progress`].
    pub fn progress(&self) -> Option<MoveProgress> {
        self.inner.progress()
    }

    /// See [`crate::MoveHandle::target`].
    pub fn target(&self) -> JointsDeg {
        self.inner.target()
    }

    /// See [`crate::MoveHandle::planned_duration`].
    pub fn planned_duration(&self) -> Duration {
        self.inner.planned_duration()
    }
}

/// Blocking handle of a stream; see [`crate::StreamHandle`]. Dropping it cancels the stream.
#[derive(Debug)]
pub struct StreamHandle {
    rt: Arc<Runtime>,
    inner: crate::StreamHandle,
}

impl StreamHandle {
    /// See [`crate::StreamHandle::wait`].
    pub fn wait(self) -> Result<StreamReport, ClientError> {
        let StreamHandle { rt, inner } = self;
        rt.block_on(inner.wait())
    }

    /// See [`crate::StreamHandle::cancel`].
    pub fn cancel(&self) {
        self.inner.cancel()
    }

    /// See [`crate::StreamHandle::progress`].
    pub fn progress(&self) -> StreamProgress {
        self.inner.progress()
    }

    /// See [`crate::StreamHandle::is_finished`].
    pub fn is_finished(&self) -> bool {
        self.inner.is_finished()
    }
}
