//! The asynchronous robot handle.

use std::sync::atomic::Ordering;
use std::sync::Arc;
use std::time::Duration;

use fs020n_kin::{Pose, RobotModel};
use fs020n_proto::ServerRequest;
use fs020n_proto::MAX_REQUEST_BYTES;
use fs020n_proto::{Command, JointsDeg, ReplyFrame, Request, Status};
use tokio::sync::watch;
use tokio::time::Instant;

use crate::check::{check_speed, check_target};
use crate::clock::ClockFit;
use crate::config::ClientConfig;
use crate::error::{Activity, Cancellation, ClientError, RawRefusal};
use crate::motion::{Completion, MoveHandle, MoveReport};
use crate::safety::{blockers, check_stream_sample};
use crate::session::{establish, lock, Common, Kind, Link, MotionTag, StatusSnapshot};
use crate::stats::Stats;
use crate::stream::{StreamHandle, StreamOptions};
use crate::trajectory::Trajectory;
use crate::transport::{Connector, TcpConnector};

/// A connection to an FS020N controller (asynchronous API; see
/// [`blocking::Robot`](crate::blocking::Robot) for the blocking one).
///
/// All methods take `&self`: the handle can be shared (e.g. in an `Arc`) between a task that
/// moves the robot and one that watches it. Every request goes through one session task that
/// owns the socket (strict lock-step) and keeps the session alive with `0 0 0` polls.
///
/// ```no_run
/// use fs020n_client::{ClientConfig, Completion, Robot};
/// use fs020n_proto::JointsDeg;
/// # async fn demo() -> Result<(), fs020n_client::ClientError> {
/// let robot = Robot::connect("192.168.0.2:10050", ClientConfig::default()).await?;
/// robot.preflight().await?;           // every blocking switch, with its remedy
/// robot.set_speed(20.0).await?;
/// robot.start().await?;               // command 1, confirmed by reply field 7
/// let mv = robot.move_joints(JointsDeg::new([10.0, 0.0, -90.0, 0.0, -90.0, 0.0])).await?;
/// mv.wait(Completion::default()).await?;
/// robot.close().await?;
/// # Ok(()) }
/// ```
pub struct Robot {
    connector: Arc<dyn Connector>,
    common: Arc<Common>,
    link: Link,
}

/// How long after a stop request a motion program seen running may still be on its way out.
/// The server stops the program with signal 2007, which its `ONI` acts on only once the signal
/// has been stable for 50 ms (spec §4); every new session raises it, and so does command 2. A
/// program seen running within this time of either is not trusted as running.
pub const STOP_SETTLE: Duration = Duration::from_millis(200);

/// How often [`Robot::start`] sends command 1 again while the program does not run and
/// nothing blocks it: the controller refuses a start (P1009) while the previous program is
/// still finishing — its last motion, or the brake after a stop.
const START_RETRY: Duration = Duration::from_millis(100);

impl std::fmt::Debug for Robot {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Robot")
            .field("target", &self.connector.describe())
            .field("session", &self.link.shared.id)
            .field("connected", &self.is_connected())
            .finish()
    }
}

impl Robot {
    /// Connects over TCP to `addr` (`"host:port"`, or `"host"` for port 10050), retrying
    /// across the server's listen gaps for `config.connect_timeout`, and checks the peer with a
    /// first status poll.
    pub async fn connect(addr: &str, config: ClientConfig) -> Result<Robot, ClientError> {
        Robot::connect_with(TcpConnector::new(addr), config).await
    }

    /// Connects through any [`Connector`] (e.g. an in-memory emulator in tests).
    pub async fn connect_with(
        connector: impl Connector,
        config: ClientConfig,
    ) -> Result<Robot, ClientError> {
        let common = Arc::new(Common::new(config)?);
        let connector: Arc<dyn Connector> = Arc::new(connector);
        let link = establish(connector.as_ref(), &common).await?;
        Ok(Robot {
            connector,
            common,
            link,
        })
    }

    /// Starts a new session with the same connector and configuration, after the previous one
    /// was lost or closed (if it is still open, it is closed first with 255, which stops the
    /// robot). The new session starts from a stopped robot with the program not running:
    /// nothing is resumed; call [`start`](Self::start) again. Statistics and the recording go
    /// on; status subscribers must [`subscribe`](Self::subscribe) again.
    pub async fn reconnect(&mut self) -> Result<(), ClientError> {
        if !self.link.shared.is_dead() {
            let _ = self.link.close().await;
        }
        let link = establish(self.connector.as_ref(), &self.common).await?;
        self.link = link;
        lock(&self.common.stats).stats.reconnects += 1;
        Ok(())
    }

    /// `true` while the session is open.
    pub fn is_connected(&self) -> bool {
        !self.link.shared.is_dead()
    }

    /// Why the session ended (`None` while it is open).
    pub fn link_error(&self) -> Option<ClientError> {
        self.link.shared.is_dead().then(|| self.link.shared.death())
    }

    /// The latest status with its age, without waiting. Fresh to within the keep-alive period
    /// while the session is open; after the session ended, the last status it received.
    pub fn status(&self) -> StatusSnapshot {
        self.link.latest()
    }

    /// A receiver of every new status. `changed()` fails when the session ends.
    pub fn subscribe(&self) -> watch::Receiver<StatusSnapshot> {
        self.link.status.clone()
    }

    /// A fresh round trip (`0 0 0`): the status right now.
    pub async fn poll(&self) -> Result<Status, ClientError> {
        Ok(self.link.poll().await?.frame.status)
    }

    /// Checks, with a fresh poll, every condition that blocks starting the program or moving:
    /// `Err(ClientError::Blocked(list))` names each with its remedy.
    pub async fn preflight(&self) -> Result<(), ClientError> {
        let status = self.poll().await?;
        let b = blockers(&status, false);
        if b.is_empty() {
            Ok(())
        } else {
            Err(ClientError::Blocked(b))
        }
    }

    fn not_streaming(&self) -> Result<(), ClientError> {
        if self.link.shared.streaming.load(Ordering::SeqCst) {
            self.common.refused();
            return Err(ClientError::Busy(Activity::Stream));
        }
        Ok(())
    }

    /// Starts the motion program: preflight, command 1, then waits (up to
    /// `config.start_timeout`) for reply field 7 to show the program running. Does nothing if it
    /// is running already (a second 1 would only make the robot pause after its motion).
    ///
    /// Within [`STOP_SETTLE`] of the session's start (reply field 8) or of a command 2, the
    /// status cannot be trusted either way: signal 2007 stops the program only after 50 ms, and
    /// a program finishing its last motion (TASK(1) = 3) shows field 7 = 0 although a 1 sent
    /// then is refused (P1009) — as when the previous session ended while its program ran.
    /// `start` waits out the rest of [`STOP_SETTLE`], polls again, and sends the 1 only to a
    /// program that has ended.
    ///
    /// A 1 still refused because the previous program is finishing (its last motion, or a
    /// brake after a stop that outlasts [`STOP_SETTLE`]) is sent again every 100 ms until the
    /// program runs or the timeout.
    pub async fn start(&self) -> Result<(), ClientError> {
        self.not_streaming()?;
        let started = Instant::now();
        let mut status = self.poll().await?;
        loop {
            let b = blockers(&status, false);
            if !b.is_empty() {
                return Err(ClientError::Blocked(b));
            }
            let session_age = status.timer.seconds().map_or(Duration::MAX, |s| {
                Duration::try_from_secs_f64(s.max(0.0)).unwrap_or(Duration::MAX)
            });
            let since_stop =
                lock(&self.link.shared.last_stop).map_or(Duration::MAX, |t| t.elapsed());
            let settled = session_age.min(since_stop);
            if settled >= STOP_SETTLE {
                if status.task_running {
                    return Ok(());
                }
                break;
            }
            if started.elapsed() > self.common.config.start_timeout {
                return Err(ClientError::StartFailed {
                    waited: started.elapsed(),
                    blockers: blockers(&status, false),
                });
            }
            tokio::time::sleep(STOP_SETTLE - settled).await;
            status = self.poll().await?;
        }
        let Some(mut sent_at) = self.send_start().await? else {
            return Ok(());
        };
        let deadline = started + self.common.config.start_timeout;
        let mut rx = self.link.status.clone();
        let mut retry_at = Instant::now() + START_RETRY;
        loop {
            {
                let s = rx.borrow_and_update();
                if s.received_at > sent_at && s.status.task_running {
                    return Ok(());
                }
            }
            tokio::select! {
                r = rx.changed() => if r.is_err() { return Err(self.link.shared.death()) },
                // A 1 that reached `MC EXECUTE` while the old program was still finishing
                // (TASK(1) = 3: its last motion, or the brake after a stop) was refused
                // (P1009): send it again while nothing else blocks the start.
                _ = tokio::time::sleep_until(retry_at) => {
                    retry_at += START_RETRY;
                    let last = self.poll().await?;
                    if last.task_running {
                        return Ok(());
                    }
                    if blockers(&last, false).is_empty() {
                        match self.send_start().await? {
                            None => return Ok(()),
                            Some(at) => sent_at = at,
                        }
                    }
                }
                _ = tokio::time::sleep_until(deadline) => {
                    let last = self.poll().await?;
                    if last.task_running {
                        return Ok(());
                    }
                    return Err(ClientError::StartFailed {
                        waited: started.elapsed(),
                        blockers: blockers(&last, false),
                    });
                }
            }
        }
    }

    /// Sends a 1: `None` when its reply shows the program running, else when it was sent.
    async fn send_start(&self) -> Result<Option<Instant>, ClientError> {
        let ex = self
            .link
            .command(&Request::new(Command::StartProgram))
            .await?;
        Ok((!ex.frame.status.task_running).then_some(ex.sent_at))
    }

    /// Stops the motion program (command 2): the robot stops at once and the program ends;
    /// a running stream is cancelled. Returns the reply's status.
    pub async fn stop_program(&self) -> Result<Status, ClientError> {
        self.link.shared.bump_epoch();
        *lock(&self.link.shared.last_stop) = Some(Instant::now());
        Ok(self
            .link
            .command(&Request::new(Command::StopProgram))
            .await?
            .frame
            .status)
    }

    /// Sets the monitor speed (command 3), 1–100 %. It applies from the next planned motion.
    pub async fn set_speed(&self, percent: f64) -> Result<Status, ClientError> {
        check_speed(percent).inspect_err(|_| self.common.refused())?;
        self.not_streaming()?;
        let ex = self
            .link
            .command(&Request::new(Command::SetSpeed { percent }))
            .await?;
        self.link.shared.set_speed_percent(percent);
        Ok(ex.frame.status)
    }

    /// Cancels the current motion for sure: command 5 (the robot brakes at once), then
    /// command 2 (the motion program ends, so no motion the controller's look-ahead had
    /// already planned can run after the brake — with 5 alone, a joint move would go on to its
    /// target). A running stream is cancelled and no motion command queued before this call
    /// is sent. Call [`start`](Self::start) to move again. Returns the status of the last
    /// reply.
    pub async fn cancel(&self) -> Result<Status, ClientError> {
        Ok(self.link.halt().await?.frame.status)
    }

    /// Ends the session: 255 (the controller stops the robot and ends the program), then waits
    /// for the server to close the connection. Later calls fail with [`ClientError::Closed`]
    /// until [`reconnect`](Self::reconnect). Closing a session that is already gone is not an
    /// error. With a recording, everything recorded so far is in the file when `close` returns.
    pub async fn close(&self) -> Result<(), ClientError> {
        let closed = if self.link.shared.is_dead() {
            Ok(())
        } else {
            match self.link.close().await {
                Ok(_) | Err(ClientError::Closed) => Ok(()),
                Err(e) => Err(e),
            }
        };
        let flushed = self.flush_recording().await;
        closed.and(flushed)
    }

    /// Starts a joint move (command 6) to `target`, after checking it (finite, inside the
    /// model's ranges) and the latest status (no error, RUN, REPEAT, lock off, power on,
    /// program running). Returns at once with a handle to wait for, watch or cancel the move.
    pub async fn move_joints(&self, target: JointsDeg) -> Result<MoveHandle, ClientError> {
        let tag = self.link.shared.motion_tag();
        self.move_joints_tagged(target, tag).await
    }

    /// [`move_joints`](Self::move_joints) with a motion tag taken when the caller started: a
    /// cancel or stop issued since then (while the caller awaited something) refuses the move.
    async fn move_joints_tagged(
        &self,
        target: JointsDeg,
        tag: MotionTag,
    ) -> Result<MoveHandle, ClientError> {
        check_target(&self.common.config.model, &target).inspect_err(|_| self.common.refused())?;
        self.not_streaming()?;
        let text = Request::new(Command::JointMove { target })
            .encode()
            .inspect_err(|_| self.common.refused())?;
        let from = self.link.latest().status.joints;
        let ex = self.link.exchange(text, Kind::Motion, Some(tag)).await?;
        let speed = self
            .link
            .shared
            .speed_percent()
            .unwrap_or(self.common.config.assumed_speed_percent);
        Ok(MoveHandle::new(
            self.link.clone(),
            self.common.config.model.clone(),
            from,
            target,
            tag,
            ex.sent_at,
            speed,
        ))
    }

    /// [`move_joints`](Self::move_joints), then [`MoveHandle::wait`]: returns when the robot is
    /// at the target (or the move failed, see [`MoveHandle::wait`]).
    pub async fn move_joints_and_wait(
        &self,
        target: JointsDeg,
        completion: Completion,
    ) -> Result<MoveReport, ClientError> {
        self.move_joints(target).await?.wait(completion).await
    }

    /// [`move_pose`](Self::move_pose), then [`MoveHandle::wait`].
    pub async fn move_pose_and_wait(
        &self,
        target: impl Into<Pose>,
        completion: Completion,
    ) -> Result<MoveReport, ClientError> {
        self.move_pose(target).await?.wait(completion).await
    }

    /// Moves the tool flange to a pose (`Pose`, or AS `Xyzoat` in mm/deg) with a joint move to
    /// the inverse-kinematics solution nearest to the current joints (from a fresh poll).
    pub async fn move_pose(&self, target: impl Into<Pose>) -> Result<MoveHandle, ClientError> {
        // Before the poll: a cancel issued while this call is under way refuses the move.
        let tag = self.link.shared.motion_tag();
        let pose: Pose = target.into();
        if !pose.is_finite() {
            self.common.refused();
            return Err(ClientError::NonFinite {
                what: "target pose".into(),
            });
        }
        let now = self.poll().await?;
        let q = self
            .common
            .config
            .model
            .inverse_nearest(&pose, &now.joints.to_rad())
            .inspect_err(|_| self.common.refused())?;
        self.move_joints_tagged(q.to_deg(), tag).await
    }

    /// Streams a trajectory (commands 7 or 6, see [`StreamOptions`]) from a background task.
    /// Everything is checked before the first sample: the trajectory against the model (ranges,
    /// speeds, per-cycle step; for command 7 also accelerations and every target the
    /// controller can extrapolate to), its start against the current joints, and the latest
    /// status. A cancel or stop issued while this call is under way (e.g. during its poll)
    /// refuses the stream with [`ClientError::Cancelled`]; nothing is sent.
    pub async fn stream(
        &self,
        trajectory: Trajectory,
        options: StreamOptions,
    ) -> Result<StreamHandle, ClientError> {
        // The motion epoch when the caller asked, before any await.
        let epoch = self.link.shared.current_epoch();
        self.not_streaming()?;
        let current = self.poll().await?;
        let b = blockers(&current, true);
        if !b.is_empty() {
            return Err(ClientError::Blocked(b));
        }
        crate::stream::check(
            &self.common.config.model,
            &trajectory,
            &options,
            &current.joints,
        )
        .inspect_err(|_| self.common.refused())?;
        if self.link.shared.current_epoch() != epoch {
            self.common.refused();
            return Err(Cancellation::NotSent.into());
        }
        StreamHandle::spawn(
            self.link.clone(),
            self.common.config.model.clone(),
            trajectory,
            options,
            epoch,
        )
    }

    /// Opens an online servo ([`ServoHandle`](crate::ServoHandle)): push samples at your own
    /// rate, each sent as command 7 stamped with the estimated controller time of the push,
    /// with the checks of [`stream`](Self::stream) on every push and a watchdog that stops the
    /// arm for sure (commands 5 then 2, by default) when the pushes stop. Refused like a stream while the
    /// status blocks motion or another stream or servo runs. See [`crate::servo`].
    pub async fn servo(
        &self,
        options: crate::servo::ServoOptions,
    ) -> Result<crate::servo::ServoHandle, ClientError> {
        let epoch = self.link.shared.current_epoch();
        self.not_streaming()?;
        let current = self.poll().await?;
        crate::servo::open(
            self.link.clone(),
            self.common.config.model.clone(),
            options,
            epoch,
            &current,
        )
    }

    /// Sends a request as typed (for a CLI `raw` command) and returns the reply. Refused:
    /// non-ASCII or control characters, empty text, more than 255 bytes, and — unless
    /// `allow_motion` — anything the controller would execute as a motion (1040 6 / 1040 7,
    /// read with the controller's own parsing). Allowed motions get the same checks as typed
    /// ones (ranges, status; for 7 the whole sample, see [`check_stream_sample`](crate::check_stream_sample)),
    /// and a speed (1040 3) must be 1–100 %. While a stream runs, every request the controller
    /// would act on (version 1040) is refused with [`ClientError::Busy`] — it would become the
    /// newest command and pause the stream — except 2, 5 and 255, which end the stream as
    /// [`stop_program`](Self::stop_program), [`cancel`](Self::cancel) and
    /// [`close`](Self::close) do; polls with another version are allowed. An effective 255 ends
    /// the session as [`close`](Self::close) does.
    pub async fn send_raw(
        &self,
        text: &str,
        allow_motion: bool,
    ) -> Result<ReplyFrame, ClientError> {
        let refuse = |why: RawRefusal| {
            self.common.refused();
            Err(ClientError::RawRefused(why))
        };
        if text.is_empty() {
            return refuse(RawRefusal::Empty);
        }
        if text.len() > MAX_REQUEST_BYTES {
            return refuse(RawRefusal::TooLong {
                bytes: text.len(),
                max: MAX_REQUEST_BYTES,
            });
        }
        if !text.bytes().all(|b| b.is_ascii_graphic() || b == b' ') {
            return refuse(RawRefusal::NotPrintable);
        }
        let parsed = ServerRequest::parse(text.as_bytes());
        let effective = parsed.version_matches();
        let command = parsed.command();
        let mut motion = None;
        let mut kind = Kind::Raw;
        if effective {
            match &command {
                Command::JointMove { target }
                | Command::StreamedMove(fs020n_proto::StreamSample {
                    position: target, ..
                }) => {
                    if !allow_motion {
                        return refuse(RawRefusal::Motion {
                            text: text.to_owned(),
                        });
                    }
                    // The tag first: a cancel issued from here on refuses this motion.
                    motion = Some(self.link.shared.motion_tag());
                    check_target(&self.common.config.model, target)
                        .inspect_err(|_| self.common.refused())?;
                    if let Command::StreamedMove(sample) = &command {
                        check_stream_sample(&self.common.config.model, sample)
                            .map_err(ClientError::Sample)
                            .inspect_err(|_| self.common.refused())?;
                    }
                    self.not_streaming()?;
                    kind = Kind::Motion;
                }
                Command::StopProgram | Command::CancelMotion => self.link.shared.bump_epoch(),
                Command::EndSession => {
                    let ex = self.link.close().await?;
                    return Ok(ex.frame);
                }
                Command::SetSpeed { percent } => {
                    check_speed(*percent).inspect_err(|_| self.common.refused())?;
                    self.not_streaming()?;
                }
                // 0, 1, 4 and unknown commands: harmless alone, but each becomes the newest
                // command and would pause a running stream (spec §2.2).
                _ => self.not_streaming()?,
            }
        }
        let ex = self.link.exchange(text.to_owned(), kind, motion).await?;
        if let (true, Command::SetSpeed { percent }) = (effective, &command) {
            self.link.shared.set_speed_percent(*percent);
        }
        Ok(ex.frame)
    }

    /// Round-trip statistics and counters (kept across reconnects).
    pub fn stats(&self) -> Stats {
        lock(&self.common.stats).snapshot()
    }

    /// Waits until every request and reply recorded so far is in the recording file (an MCAP
    /// file is then complete up to here for every reader). Does nothing without a recording.
    /// The file is written by a thread of its own: requests never wait for the disk, only this.
    pub async fn flush_recording(&self) -> Result<(), ClientError> {
        match &self.common.recorder {
            Some(r) => r.flush().await,
            None => Ok(()),
        }
    }

    /// The current estimate of the controller's clock (TIMER(1)) against the local clock.
    pub fn server_clock(&self) -> Option<ClockFit> {
        lock(&self.link.shared.clock).fit()
    }

    /// The estimated controller clock (TIMER(1), seconds since the session was accepted) at
    /// this instant; `None` before the first reply with a timer.
    pub fn server_time_now(&self) -> Option<f64> {
        lock(&self.link.shared.clock).server_time(Instant::now())
    }

    /// The robot model used for the checks.
    pub fn model(&self) -> &RobotModel {
        &self.common.config.model
    }

    /// The configuration.
    pub fn config(&self) -> &ClientConfig {
        &self.common.config
    }
}
