//! A blocking API on top of the asynchronous one.
//!
//! [`Robot`] owns a small tokio runtime with **one worker thread**. It cannot be a
//! current-thread runtime (as tokio-modbus's synchronous client uses): the session task must
//! keep polling the controller while the caller is busy elsewhere, otherwise the controller's
//! 5 s receive timeout would end the session (and stop the robot) whenever the program paused
//! between two calls. Each method runs the async method with `block_on`.
//!
//! Do not use it from inside an async runtime (tokio forbids blocking there); use
//! [`crate::Robot`] there. Inside a runtime, every blocking method returns
//! [`ClientError::InsideAsyncRuntime`] instead of blocking (or panicking), and dropping a [`Robot`] hands
//! the closing 255 and the runtime's shutdown to a helper thread.

use std::future::Future;
use std::ops::Deref;
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

/// The blocking client's own runtime. Dropped where blocking is not allowed (inside another
/// async runtime, where a plain drop panics), it is shut down in the background instead.
#[derive(Debug)]
struct ClientRuntime(Option<Runtime>);

impl Deref for ClientRuntime {
    type Target = Runtime;

    fn deref(&self) -> &Runtime {
        // Only `Drop` takes it out.
        #[allow(clippy::expect_used)]
        self.0.as_ref().expect("the runtime is present until drop")
    }
}

impl Drop for ClientRuntime {
    fn drop(&mut self) {
        if let Some(rt) = self.0.take() {
            if in_async_context() {
                rt.shutdown_background();
            }
        }
    }
}

type Rt = Arc<ClientRuntime>;

fn in_async_context() -> bool {
    tokio::runtime::Handle::try_current().is_ok()
}

/// Refuses to block inside an async runtime (tokio would panic).
fn outside_async_context() -> Result<(), ClientError> {
    if in_async_context() {
        return Err(ClientError::InsideAsyncRuntime);
    }
    Ok(())
}

/// Runs `f` to completion on the client's runtime; refused inside an async runtime.
fn block_on<T>(
    rt: &Runtime,
    f: impl Future<Output = Result<T, ClientError>>,
) -> Result<T, ClientError> {
    outside_async_context()?;
    rt.block_on(f)
}

fn runtime() -> Result<Rt, ClientError> {
    outside_async_context()?;
    tokio::runtime::Builder::new_multi_thread()
        .worker_threads(1)
        .thread_name("fs020n-client")
        .enable_all()
        .build()
        .map(|rt| Arc::new(ClientRuntime(Some(rt))))
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
    rt: Rt,
    inner: Option<crate::Robot>,
}

impl Robot {
    /// See [`crate::Robot::connect`]. Inside an async runtime it returns
    /// [`ClientError::InsideAsyncRuntime`] (use the async [`crate::Robot`] there).
    pub fn connect(addr: &str, config: ClientConfig) -> Result<Robot, ClientError> {
        let rt = runtime()?;
        let inner = rt.block_on(crate::Robot::connect(addr, config))?;
        Ok(Robot {
            rt,
            inner: Some(inner),
        })
    }

    /// See [`crate::Robot::connect_with`]. Inside an async runtime it returns
    /// [`ClientError::InsideAsyncRuntime`].
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
            Some(inner) => block_on(&rt, inner.reconnect()),
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
    pub fn status(&self) -> StatusSnapshot {
        self.r().status()
    }

    /// See [`crate::Robot::subscribe`] (use `borrow()` / `has_changed()` from blocking code).
    pub fn subscribe(&self) -> watch::Receiver<StatusSnapshot> {
        self.r().subscribe()
    }

    /// See [`crate::Robot::poll`].
    pub fn poll(&self) -> Result<Status, ClientError> {
        block_on(&self.rt, self.r().poll())
    }

    /// See [`crate::Robot::preflight`].
    pub fn preflight(&self) -> Result<(), ClientError> {
        block_on(&self.rt, self.r().preflight())
    }

    /// See [`crate::Robot::start`].
    pub fn start(&self) -> Result<(), ClientError> {
        block_on(&self.rt, self.r().start())
    }

    /// See [`crate::Robot::stop_program`].
    pub fn stop_program(&self) -> Result<Status, ClientError> {
        block_on(&self.rt, self.r().stop_program())
    }

    /// See [`crate::Robot::set_speed`].
    pub fn set_speed(&self, percent: f64) -> Result<Status, ClientError> {
        block_on(&self.rt, self.r().set_speed(percent))
    }

    /// See [`crate::Robot::cancel`].
    pub fn cancel(&self) -> Result<Status, ClientError> {
        block_on(&self.rt, self.r().cancel())
    }

    /// See [`crate::Robot::close`].
    pub fn close(&self) -> Result<(), ClientError> {
        block_on(&self.rt, self.r().close())
    }

    /// See [`crate::Robot::move_joints`].
    pub fn move_joints(&self, target: JointsDeg) -> Result<MoveHandle, ClientError> {
        let inner = block_on(&self.rt, self.r().move_joints(target))?;
        Ok(MoveHandle {
            rt: self.rt.clone(),
            inner,
        })
    }

    /// See [`crate::Robot::move_joints_and_wait`]: one call that returns when the robot is at
    /// the target.
    ///
    /// ```no_run
    /// use fs020n_client::{blocking::Robot, ClientConfig, Completion, JointsDeg};
    /// let robot = Robot::connect("127.0.0.1:10050", ClientConfig::default())?;
    /// robot.start()?;
    /// let target = JointsDeg::new([10.0, 0.0, -90.0, 0.0, -90.0, 0.0]);
    /// let report = robot.move_joints_and_wait(target, Completion::default())?;
    /// println!("reached in {:?}", report.elapsed);
    /// # Ok::<(), fs020n_client::ClientError>(())
    /// ```
    pub fn move_joints_and_wait(
        &self,
        target: JointsDeg,
        completion: Completion,
    ) -> Result<MoveReport, ClientError> {
        block_on(&self.rt, self.r().move_joints_and_wait(target, completion))
    }

    /// See [`crate::Robot::move_pose_and_wait`].
    pub fn move_pose_and_wait(
        &self,
        target: impl Into<Pose>,
        completion: Completion,
    ) -> Result<MoveReport, ClientError> {
        block_on(&self.rt, self.r().move_pose_and_wait(target, completion))
    }

    /// See [`crate::Robot::move_pose`].
    pub fn move_pose(&self, target: impl Into<Pose>) -> Result<MoveHandle, ClientError> {
        let inner = block_on(&self.rt, self.r().move_pose(target))?;
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
        let inner = block_on(&self.rt, self.r().stream(trajectory, options))?;
        Ok(StreamHandle {
            rt: self.rt.clone(),
            inner,
        })
    }

    /// See [`crate::Robot::send_raw`].
    pub fn send_raw(&self, text: &str, allow_motion: bool) -> Result<ReplyFrame, ClientError> {
        block_on(&self.rt, self.r().send_raw(text, allow_motion))
    }

    /// See [`crate::Robot::stats`].
    pub fn stats(&self) -> Stats {
        self.r().stats()
    }

    /// See [`crate::Robot::flush_recording`].
    pub fn flush_recording(&self) -> Result<(), ClientError> {
        block_on(&self.rt, self.r().flush_recording())
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
    ///
    /// Inside an async runtime, where blocking panics, the close and the drop of the handle and
    /// runtime run on a helper thread; the drop waits for it (bounded the same way).
    fn drop(&mut self) {
        let Some(inner) = self.inner.take() else {
            return;
        };
        let rt = self.rt.clone();
        let close = move || {
            if inner.is_connected() {
                let limit = inner.config().close_timeout + inner.config().reply_timeout;
                let _ = rt.block_on(async { tokio::time::timeout(limit, inner.close()).await });
            }
            drop(inner);
            drop(rt);
        };
        if !in_async_context() {
            close();
            return;
        }
        match std::thread::Builder::new()
            .name("fs020n-client-close".into())
            .spawn(close)
        {
            Ok(thread) => {
                if thread.join().is_err() {
                    tracing::warn!("the thread closing the blocking client panicked");
                }
            }
            Err(e) => tracing::warn!(
                error = %e,
                "cannot start a thread to close the blocking client; the session ends when the \
                 controller's receive timeout expires"
            ),
        }
    }
}

/// Blocking handle of a joint move; see [`crate::MoveHandle`] (dropping the last clone while
/// the move runs cancels it).
#[derive(Debug, Clone)]
#[must_use = "dropping the last MoveHandle cancels the move: keep it and call wait()"]
pub struct MoveHandle {
    rt: Rt,
    inner: crate::MoveHandle,
}

impl MoveHandle {
    /// See [`crate::MoveHandle::wait`].
    pub fn wait(&self, completion: Completion) -> Result<MoveReport, ClientError> {
        block_on(&self.rt, self.inner.wait(completion))
    }

    /// See [`crate::MoveHandle::cancel`].
    pub fn cancel(&self) -> Result<(), ClientError> {
        block_on(&self.rt, self.inner.cancel())
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

/// Blocking handle of a stream; see [`crate::StreamHandle`] (dropping the last clone while
/// the stream runs cancels it).
#[derive(Debug, Clone)]
#[must_use = "dropping the last StreamHandle cancels the stream: keep it and call wait()"]
pub struct StreamHandle {
    rt: Rt,
    inner: crate::StreamHandle,
}

impl StreamHandle {
    /// See [`crate::StreamHandle::wait`].
    pub fn wait(&self) -> Result<StreamReport, ClientError> {
        block_on(&self.rt, self.inner.wait())
    }

    /// See [`crate::StreamHandle::cancel`].
    pub fn cancel(&self) -> Result<(), ClientError> {
        block_on(&self.rt, self.inner.cancel())
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
