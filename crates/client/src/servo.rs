//! Online servoing: samples pushed at the caller's own rate, sent as command 7 on the estimated
//! controller clock (ur_rtde's `servoJ`, for teleoperation and visual servoing).
//!
//! [`Robot::servo`](crate::Robot::servo) opens a [`ServoHandle`]. The caller pushes samples
//! (position, optionally velocity and acceleration) whenever it has one
//! ([`ServoHandle::push`], which does not wait for the network); a background task sends the
//! newest one as soon as the previous reply has arrived (strict lock-step), as command 7 stamped
//! with the estimated controller time (TIMER(1)) **of the push**. The controller extrapolates
//! each sample to its own "now" plus the look-ahead (spec §2.4), so the time a sample spends
//! queued or on the wire is compensated by its velocity. Samples pushed faster than round trips
//! are coalesced: only the newest is sent (the controller acts on the newest command only, so
//! the others would be skipped there anyway); [`ServoStats::coalesced`] counts them.
//!
//! # Checks before sending
//!
//! Every push is checked at once, before it is queued, and refused with the error of the
//! offline stream checks (nothing is sent, [`Stats::refused_before_sending`](crate::Stats)
//! counts it):
//!
//! * the position is finite and inside the joint ranges;
//! * the whole command-7 sample, as the controller can extrapolate it
//!   ([`check_stream_sample`]): velocity and acceleration within the
//!   model's, every target within the [`extrapolation_window`](crate::extrapolation_window)
//!   inside the ranges;
//! * the first sample is within [`ServoOptions::start_tolerance_deg`] of the current joints;
//! * no joint jumps from one push to the next by more than [`ServoOptions::max_step_deg`] plus
//!   what the joint can travel at its maximum speed in the time between the two pushes (a
//!   guard against unit mix-ups and glitches of the source).
//!
//! Without a velocity, the velocity is estimated by the backward difference of the last two
//! accepted pushes ([`ServoOptions::estimate_velocity`]); without an acceleration, zero is sent.
//! The latest status is checked again by the session task right before each write (no motion
//! while it shows an error, HOLD, TEACH, the lock, power off or the program not running).
//!
//! # The watchdog: a sure stop (5 then 2), not a brake alone
//!
//! When no sample has been accepted for [`ServoOptions::watchdog`] (default 200 ms) after the
//! first one, the caller is taken to have stopped driving (a crash, a hung loop, a long pause)
//! and the servo ends with [`ServoOutcome::Watchdog`]. By default it then stops the arm for
//! sure, as every cancel of this client does: **command 5** (`BRAKE`, the motion stops at once)
//! **then command 2** (the motion program ends). A 5 alone is not enough: the spec (§2.1) says
//! that after a `BRAKE` a motion the program had already planned by look-ahead may still be
//! executed on a real controller, and that *a client that must be sure the arm stays still
//! sends 2*. Nobody is watching the arm at that moment, so the client fails closed. The price is
//! that the program must be started again ([`Robot::start`](crate::Robot::start)) before the
//! next motion. [`WatchdogAction::Brake`] sends only 5, for setups that accept that risk to keep
//! the program running. Until the watchdog fires, the controller never extrapolates a sample by
//! more than 0.5 s plus the look-ahead, and every such target was checked to be inside the
//! ranges.
//!
//! [`ServoHandle::stop`] (or dropping the handle) and a fault while servoing (an error, HOLD,
//! E-stop, …, reported as [`ClientError::Aborted`]) stop the arm the same way (5 then 2), as
//! cancelling a stream does, so that nothing resumes when a switch is turned back. A cancel,
//! stop or close of the robot ends the servo with [`ServoOutcome::Cancelled`] (the cancel itself
//! stops the arm); a lost link ends it with [`ClientError::LinkLost`].

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::time::Duration;

use fs020n_kin::RobotModel;
use fs020n_proto::{Command, JointsDeg, Request, Status, StreamSample, JOINT_COUNT};
use serde::Serialize;
use tokio::sync::Notify;
use tokio::task::JoinHandle;
use tokio::time::Instant;

use crate::check::check_target;
use crate::error::{Activity, Cancellation, ClientError, LinkError};
use crate::safety::{blockers, check_stream_sample, MAX_LOOKAHEAD_PASSES};
use crate::session::{lock, Link, SessionShared};
use crate::trajectory::{OptionError, TrajectoryError};

/// Shortest accepted [`ServoOptions::watchdog`].
pub const SERVO_WATCHDOG_MIN: Duration = Duration::from_millis(10);
/// Longest accepted [`ServoOptions::watchdog`]: the controller absorbs at most 0.5 s of
/// time-stamp error, so a longer silence is never a live source.
pub const SERVO_WATCHDOG_MAX: Duration = Duration::from_millis(500);

/// What the watchdog sends when the caller stops pushing.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum WatchdogAction {
    /// Commands 5 then 2: brake, then stop the motion program. The arm stays still for sure;
    /// the program must be started again before the next motion. The default (the client
    /// fails closed).
    #[default]
    StopProgram,
    /// Command 5 only: brake. The program keeps running, but a motion it had already planned
    /// may still be executed (spec §2.1).
    Brake,
}

/// Options of [`Robot::servo`](crate::Robot::servo).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct ServoOptions {
    /// ARG2 of command 7, in passes of the motion program, 0–50. Default 2.
    pub lookahead_passes: f64,
    /// Longest time without an accepted push (after the first) before the watchdog ends the
    /// servo. 10–500 ms; default 200 ms.
    pub watchdog: Duration,
    /// What the watchdog sends. Default [`WatchdogAction::StopProgram`] (commands 5 then 2).
    pub on_watchdog: WatchdogAction,
    /// Largest jump of a joint between two pushes beyond what the joint can travel at its
    /// maximum speed in the time between them, degrees. Default 2°.
    pub max_step_deg: f64,
    /// Largest distance of the first sample from the current joints, degrees. Default 1°.
    pub start_tolerance_deg: f64,
    /// Estimate a missing velocity from the last two pushes (backward difference). Default
    /// `true`; `false` sends zero velocity when none is given.
    pub estimate_velocity: bool,
}

impl Default for ServoOptions {
    fn default() -> Self {
        ServoOptions {
            lookahead_passes: 2.0,
            watchdog: Duration::from_millis(200),
            on_watchdog: WatchdogAction::StopProgram,
            max_step_deg: 2.0,
            start_tolerance_deg: 1.0,
            estimate_velocity: true,
        }
    }
}

impl ServoOptions {
    /// Checks the values (each error names the option and its range).
    pub fn validate(&self) -> Result<(), ClientError> {
        let opt = |e: OptionError| Err(ClientError::Trajectory(TrajectoryError::Options(e)));
        let l = self.lookahead_passes;
        if !(l.is_finite() && (0.0..=MAX_LOOKAHEAD_PASSES).contains(&l)) {
            return opt(OptionError::Lookahead {
                passes: l,
                max: MAX_LOOKAHEAD_PASSES,
            });
        }
        if !(SERVO_WATCHDOG_MIN..=SERVO_WATCHDOG_MAX).contains(&self.watchdog) {
            return opt(OptionError::Watchdog {
                watchdog: self.watchdog,
                min: SERVO_WATCHDOG_MIN,
                max: SERVO_WATCHDOG_MAX,
            });
        }
        if !(self.max_step_deg.is_finite() && self.max_step_deg > 0.0) {
            return opt(OptionError::MaxStep {
                deg: self.max_step_deg,
            });
        }
        let t = self.start_tolerance_deg;
        if !(t.is_finite() && t > 0.0) {
            return opt(OptionError::Tolerance {
                option: "start_tolerance_deg",
                deg: t,
            });
        }
        Ok(())
    }
}

/// One pushed sample: joint positions (degrees), optionally velocities (deg/s) and
/// accelerations (deg/s²), all valid at the instant of the push.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct ServoSample {
    /// Positions, degrees.
    pub position: JointsDeg,
    /// Velocities, deg/s (`None`: estimated, see [`ServoOptions::estimate_velocity`]).
    pub velocity: Option<JointsDeg>,
    /// Accelerations, deg/s² (`None`: zero).
    pub acceleration: Option<JointsDeg>,
}

impl ServoSample {
    /// A sample with a position only.
    pub fn new(position: JointsDeg) -> ServoSample {
        ServoSample {
            position,
            velocity: None,
            acceleration: None,
        }
    }

    /// Sets the velocity, deg/s.
    pub fn with_velocity(mut self, velocity: JointsDeg) -> ServoSample {
        self.velocity = Some(velocity);
        self
    }

    /// Sets the acceleration, deg/s².
    pub fn with_acceleration(mut self, acceleration: JointsDeg) -> ServoSample {
        self.acceleration = Some(acceleration);
        self
    }
}

impl From<JointsDeg> for ServoSample {
    fn from(position: JointsDeg) -> Self {
        ServoSample::new(position)
    }
}

/// How a servo ended without a fault.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum ServoOutcome {
    /// [`ServoHandle::stop`] or the handle was dropped: commands 5 then 2 sent.
    Stopped,
    /// A cancel, stop or close of the robot ([`Robot::cancel`](crate::Robot::cancel),
    /// [`Robot::stop_program`](crate::Robot::stop_program), [`Robot::close`](crate::Robot::close)).
    Cancelled,
    /// No push within [`ServoOptions::watchdog`]: [`ServoOptions::on_watchdog`] was sent.
    Watchdog,
}

/// Figures of a servo (live with [`ServoHandle::stats`], final in [`ServoReport`]).
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize)]
pub struct ServoStats {
    /// Pushes accepted.
    pub pushes: u64,
    /// Pushes refused by the checks (nothing queued).
    pub refused: u64,
    /// Samples sent (command 7).
    pub sent: u64,
    /// Accepted pushes replaced by a newer one before they could be sent.
    pub coalesced: u64,
    /// Accepted pushes neither sent nor coalesced: the newest one, still waiting for the
    /// previous reply when the servo ended (a stop sends no further sample). Zero while the
    /// servo runs; in the final [`ServoReport`], `sent + coalesced + unsent == pushes`.
    pub unsent: u64,
    /// Mean time between accepted pushes.
    pub push_interval_mean: Duration,
    /// Longest time between accepted pushes.
    pub push_interval_max: Duration,
    /// Mean time from a push to the write of its sample.
    pub push_to_send_mean: Duration,
    /// Longest time from a push to the write of its sample.
    pub push_to_send_max: Duration,
    /// Mean round trip of the samples.
    pub rtt_mean: Duration,
    /// Slowest round trip of the samples.
    pub rtt_max: Duration,
    /// Largest tracking error, degrees: per reply, the largest per-joint difference between the
    /// joints and the newest sample extrapolated to the reply's server time (as the controller
    /// extrapolates it, without the look-ahead).
    pub tracking_error_max_deg: f64,
    /// Root mean square of those tracking errors, degrees.
    pub tracking_error_rms_deg: f64,
    /// Replies the tracking error was computed from.
    pub tracking_samples: u64,
}

/// The final report of a servo.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ServoReport {
    /// How it ended.
    pub outcome: ServoOutcome,
    /// Its figures.
    pub stats: ServoStats,
    /// The joints in the last status, degrees.
    pub final_joints: Option<JointsDeg>,
    /// Time from opening to the end.
    pub duration: Duration,
}

/// What a push returns after the servo ended without a fault.
fn ended_error(outcome: ServoOutcome) -> ClientError {
    ClientError::Cancelled(match outcome {
        ServoOutcome::Stopped => Cancellation::ServoStopped,
        ServoOutcome::Cancelled => Cancellation::Cancelled,
        ServoOutcome::Watchdog => Cancellation::ServoWatchdog,
    })
}

#[derive(Debug, Clone, Copy)]
struct Pending {
    position: JointsDeg,
    velocity: JointsDeg,
    acceleration: JointsDeg,
    pushed_at: Instant,
}

#[derive(Debug, Default)]
struct Sums {
    stats: ServoStats,
    interval_sum: Duration,
    push_to_send_sum: Duration,
    rtt_sum: Duration,
    track_sq: f64,
}

impl Sums {
    fn snapshot(&self) -> ServoStats {
        let mean = |sum: Duration, n: u64| {
            if n == 0 {
                Duration::ZERO
            } else {
                sum / u32::try_from(n).unwrap_or(u32::MAX)
            }
        };
        let mut s = self.stats;
        s.push_interval_mean = mean(self.interval_sum, s.pushes.saturating_sub(1));
        s.push_to_send_mean = mean(self.push_to_send_sum, s.sent);
        s.rtt_mean = mean(self.rtt_sum, s.sent);
        s.tracking_error_rms_deg = if s.tracking_samples > 0 {
            (self.track_sq / s.tracking_samples as f64).sqrt()
        } else {
            0.0
        };
        s
    }
}

#[derive(Debug, Default)]
struct Input {
    /// The last accepted push: position and when.
    last: Option<(JointsDeg, Instant)>,
    /// The newest accepted push not sent yet.
    pending: Option<Pending>,
    /// Set when the servo has ended: what a push then returns.
    ended: Option<ClientError>,
    sums: Sums,
}

#[derive(Debug)]
struct ServoState {
    model: RobotModel,
    options: ServoOptions,
    opened: Instant,
    input: Mutex<Input>,
    /// Wakes the task on a push or a stop.
    wake: Notify,
    stop: AtomicBool,
}

/// A running servo: push samples with [`push`](Self::push), end it with
/// [`stop`](Self::stop) and [`wait`](Self::wait). Dropping the handle stops it (commands 5
/// then 2).
///
/// ```no_run
/// use fs020n_client::{ClientConfig, JointsDeg, Robot, ServoOptions};
/// # async fn demo() -> Result<(), fs020n_client::ClientError> {
/// let robot = Robot::connect("192.168.0.2:10050", ClientConfig::default()).await?;
/// robot.set_speed(100.0).await?;
/// robot.start().await?;
/// let servo = robot.servo(ServoOptions::default()).await?;
/// let mut tick = tokio::time::interval(std::time::Duration::from_millis(8));
/// for k in 0..500 {
///     tick.tick().await;
///     let t = k as f64 * 0.008;
///     let q = JointsDeg::new([5.0 * (t * 0.5).sin(), 0.0, -90.0, 0.0, -90.0, 0.0]);
///     servo.push(q)?; // never waits for the network
/// }
/// servo.stop();
/// let report = servo.wait().await?;
/// println!("{} sent, {} coalesced", report.stats.sent, report.stats.coalesced);
/// # Ok(()) }
/// ```
#[derive(Debug)]
#[must_use = "dropping a ServoHandle stops the servo: keep it and push samples"]
pub struct ServoHandle {
    state: Arc<ServoState>,
    link: Link,
    epoch: u64,
    task: Option<JoinHandle<Result<ServoReport, ClientError>>>,
}

/// Opens a servo: checks the options and the status, then starts the sending task. `epoch` is
/// the motion epoch when the caller asked; `current` a fresh status.
pub(crate) fn open(
    link: Link,
    model: RobotModel,
    options: ServoOptions,
    epoch: u64,
    current: &Status,
) -> Result<ServoHandle, ClientError> {
    let shared = link.shared.clone();
    options
        .validate()
        .inspect_err(|_| shared.common.refused())?;
    let b = blockers(current, true);
    if !b.is_empty() {
        return Err(ClientError::Blocked(b));
    }
    if shared.current_epoch() != epoch {
        shared.common.refused();
        return Err(ClientError::Cancelled(Cancellation::NotSent));
    }
    if shared.streaming.swap(true, Ordering::SeqCst) {
        shared.common.refused();
        return Err(ClientError::Busy(Activity::Servo));
    }
    let guard = MotionChannel(shared);
    let state = Arc::new(ServoState {
        model,
        options,
        opened: Instant::now(),
        input: Mutex::new(Input::default()),
        wake: Notify::new(),
        stop: AtomicBool::new(false),
    });
    let task = tokio::spawn({
        let state = state.clone();
        let link = link.clone();
        async move {
            let r = Servo {
                state: state.clone(),
                link,
                epoch,
            }
            .run()
            .await;
            // Later pushes learn why the servo ended; the motion channel is free again only
            // after that.
            lock(&state.input).ended.get_or_insert_with(|| match &r {
                Ok(report) => ended_error(report.outcome),
                Err(e) => e.clone(),
            });
            drop(guard);
            r
        }
    });
    Ok(ServoHandle {
        state,
        link,
        epoch,
        task: Some(task),
    })
}

/// Holds the session's single motion channel (the `streaming` flag) while a servo runs.
struct MotionChannel(Arc<SessionShared>);

impl Drop for MotionChannel {
    fn drop(&mut self) {
        self.0.streaming.store(false, Ordering::SeqCst);
    }
}

impl ServoHandle {
    /// Checks a sample and queues it as the newest (it replaces one not sent yet). Never waits
    /// for the network: the sample is sent as soon as the previous reply has arrived, stamped
    /// with the estimated controller time of this call. Refused samples (see the module
    /// documentation) leave the previous one in force and do not feed the watchdog. After the
    /// servo has ended, returns why (the fault, or [`ClientError::Cancelled`] naming the
    /// watchdog, a stop or a cancel).
    pub fn push(&self, sample: impl Into<ServoSample>) -> Result<(), ClientError> {
        let sample = sample.into();
        let now = Instant::now();
        let st = &*self.state;
        let mut input = lock(&st.input);
        if let Some(e) = &input.ended {
            return Err(e.clone());
        }
        if self.link.shared.current_epoch() != self.epoch || st.stop.load(Ordering::SeqCst) {
            return Err(ClientError::Cancelled(Cancellation::Cancelled));
        }
        let checked = self.check(&input, &sample, now);
        let pending = match checked {
            Ok(p) => p,
            Err(e) => {
                input.sums.stats.refused += 1;
                drop(input);
                self.link.shared.common.refused();
                return Err(e);
            }
        };
        if let Some((_, at)) = input.last {
            let gap = now.saturating_duration_since(at);
            let sums = &mut input.sums;
            sums.interval_sum += gap;
            sums.stats.push_interval_max = sums.stats.push_interval_max.max(gap);
        }
        input.sums.stats.pushes += 1;
        if input.pending.replace(pending).is_some() {
            input.sums.stats.coalesced += 1;
        }
        input.last = Some((sample.position, now));
        drop(input);
        st.wake.notify_one();
        Ok(())
    }

    fn check(
        &self,
        input: &Input,
        sample: &ServoSample,
        now: Instant,
    ) -> Result<Pending, ClientError> {
        let st = &*self.state;
        let p = sample.position;
        check_target(&st.model, &p)?;
        let velocity = match (sample.velocity, input.last) {
            (Some(v), _) => v,
            (None, Some((prev, at))) if st.options.estimate_velocity && now > at => {
                let dt = now.duration_since(at).as_secs_f64();
                p.zip_with(&prev, |a, b| (a - b) / dt)
            }
            (None, _) => JointsDeg::ZERO,
        };
        let time_s = now.saturating_duration_since(st.opened).as_secs_f64();
        match input.last {
            Some((prev, at)) => {
                let gap = now.saturating_duration_since(at).as_secs_f64();
                for (j, spec) in st.model.joints.iter().enumerate().take(JOINT_COUNT) {
                    let step = (p[j] - prev[j]).abs();
                    let max = st.options.max_step_deg + spec.max_speed_deg_s * gap;
                    if step > max {
                        return Err(TrajectoryError::StepTooLarge {
                            time_s,
                            joint: j + 1,
                            step_deg: step,
                            max_deg: max,
                        }
                        .into());
                    }
                }
            }
            None => {
                let current = self.link.latest().status.joints;
                let (joint, distance) = (0..JOINT_COUNT)
                    .map(|j| (j + 1, (p[j] - current[j]).abs()))
                    .fold((1, 0.0), |a, b| if b.1 > a.1 { b } else { a });
                if distance > st.options.start_tolerance_deg {
                    return Err(TrajectoryError::StartTooFar {
                        joint,
                        distance_deg: distance,
                        tolerance_deg: st.options.start_tolerance_deg,
                    }
                    .into());
                }
            }
        }
        let acceleration = sample.acceleration.unwrap_or(JointsDeg::ZERO);
        // The time stamp only needs to be finite here; the real one is taken when it is sent.
        check_stream_sample(
            &st.model,
            &StreamSample {
                t0_s: 0.0,
                lookahead_passes: st.options.lookahead_passes,
                position: p,
                velocity,
                acceleration,
            },
        )?;
        Ok(Pending {
            position: p,
            velocity,
            acceleration,
            pushed_at: now,
        })
    }

    /// Asks the servo to end: no further sample is sent, command 5 brakes the robot and command
    /// 2 ends the motion program (start it again to move).
    /// [`wait`](Self::wait) then returns a report with [`ServoOutcome::Stopped`].
    pub fn stop(&self) {
        self.state.stop.store(true, Ordering::SeqCst);
        self.state.wake.notify_one();
    }

    /// The figures so far.
    pub fn stats(&self) -> ServoStats {
        lock(&self.state.input).sums.snapshot()
    }

    /// The options in force.
    pub fn options(&self) -> ServoOptions {
        self.state.options
    }

    /// `true` once the servo has ended (stopped, cancelled, watchdog, fault).
    pub fn is_finished(&self) -> bool {
        !matches!(&self.task, Some(t) if !t.is_finished())
    }

    /// Waits for the end of the servo (after [`stop`](Self::stop), a cancel of the robot, the
    /// watchdog, or a fault) and returns its report; a fault or a lost link is the error.
    pub async fn wait(mut self) -> Result<ServoReport, ClientError> {
        let Some(task) = self.task.take() else {
            return Err(ClientError::Cancelled(Cancellation::Cancelled));
        };
        match task.await {
            Ok(r) => r,
            Err(_) => Err(ClientError::LinkLost(LinkError::SessionEnded)),
        }
    }

    /// [`stop`](Self::stop), then [`wait`](Self::wait).
    pub async fn finish(self) -> Result<ServoReport, ClientError> {
        self.stop();
        self.wait().await
    }
}

impl Drop for ServoHandle {
    fn drop(&mut self) {
        if self.task.as_ref().is_some_and(|t| !t.is_finished()) {
            self.stop();
        }
    }
}

/// The sending task.
struct Servo {
    state: Arc<ServoState>,
    link: Link,
    epoch: u64,
}

enum Next {
    Send(Pending),
    End(ServoOutcome),
}

impl Servo {
    fn cancelled(&self) -> bool {
        self.link.shared.current_epoch() != self.epoch
    }

    /// Stops the arm for sure (commands 5 then 2, as every cancel of the client does); best
    /// effort: what ended the servo is what gets reported.
    async fn halt_best_effort(&self) {
        if self.link.shared.is_dead() {
            return;
        }
        if let Err(e) = self.link.halt().await {
            tracing::warn!(error = %e, "could not stop the arm at the end of a servo");
        }
    }

    fn report(&self, outcome: ServoOutcome) -> ServoReport {
        let mut stats = lock(&self.state.input).sums.snapshot();
        stats.unsent = stats
            .pushes
            .saturating_sub(stats.sent)
            .saturating_sub(stats.coalesced);
        ServoReport {
            outcome,
            stats,
            final_joints: Some(self.link.latest().status.joints),
            duration: self.state.opened.elapsed(),
        }
    }

    async fn run(self) -> Result<ServoReport, ClientError> {
        let end = self.send_loop().await;
        match end {
            Ok(ServoOutcome::Watchdog) => {
                tracing::warn!(
                    action = ?self.state.options.on_watchdog,
                    "servo watchdog: no sample within {:?}",
                    self.state.options.watchdog
                );
                match self.state.options.on_watchdog {
                    WatchdogAction::StopProgram => {
                        self.link.halt().await?;
                    }
                    WatchdogAction::Brake => {
                        // Nothing queued before this may be sent any more.
                        self.link.shared.bump_epoch();
                        self.link
                            .command(&Request::new(Command::CancelMotion))
                            .await?;
                    }
                }
                Ok(self.report(ServoOutcome::Watchdog))
            }
            Ok(ServoOutcome::Stopped) => {
                self.halt_best_effort().await;
                Ok(self.report(ServoOutcome::Stopped))
            }
            // Whoever cancelled stops the arm (Robot::cancel: 5 then 2; stop_program: 2;
            // close: 255).
            Ok(ServoOutcome::Cancelled) => Ok(self.report(ServoOutcome::Cancelled)),
            Err(e) => {
                if !e.is_link_dead() {
                    self.halt_best_effort().await;
                }
                Err(e)
            }
        }
    }

    /// What to do next: the newest pending sample, or the end (stop, cancel, watchdog).
    async fn next(&self, epoch_rx: &mut tokio::sync::watch::Receiver<u64>) -> Next {
        loop {
            if self.state.stop.load(Ordering::SeqCst) {
                return Next::End(ServoOutcome::Stopped);
            }
            if self.cancelled() {
                return Next::End(ServoOutcome::Cancelled);
            }
            let (pending, deadline) = {
                let mut input = lock(&self.state.input);
                let deadline = input.last.map(|(_, at)| at + self.state.options.watchdog);
                (input.pending.take(), deadline)
            };
            if let Some(p) = pending {
                return Next::Send(p);
            }
            if deadline.is_some_and(|d| Instant::now() >= d) {
                return Next::End(ServoOutcome::Watchdog);
            }
            let watchdog = async {
                match deadline {
                    Some(d) => tokio::time::sleep_until(d).await,
                    None => std::future::pending().await,
                }
            };
            tokio::select! {
                _ = self.state.wake.notified() => {}
                _ = epoch_rx.changed() => {}
                _ = watchdog => {}
            }
        }
    }

    async fn send_loop(&self) -> Result<ServoOutcome, ClientError> {
        let mut epoch_rx = self.link.shared.epoch.subscribe();
        let model = &self.state.model;
        loop {
            let p = match self.next(&mut epoch_rx).await {
                Next::Send(p) => p,
                Next::End(outcome) => return Ok(outcome),
            };
            let t0_s = lock(&self.link.shared.clock)
                .server_time(p.pushed_at)
                .ok_or_else(|| {
                    ClientError::Config(
                        "no server-clock estimate: no reply carried TIMER(1) (it shows asterisks \
                         after 11.6 days of one session); reconnect"
                            .into(),
                    )
                })?;
            let sample = StreamSample {
                t0_s,
                lookahead_passes: self.state.options.lookahead_passes,
                position: p.position,
                velocity: p.velocity,
                acceleration: p.acceleration,
            };
            check_stream_sample(model, &sample)?;
            let text = Request::new(Command::StreamedMove(sample)).encode()?;
            let ex = match self.link.exchange_own_motion(text, self.epoch).await {
                Ok(ex) => ex,
                Err(ClientError::Cancelled(_)) => return Ok(ServoOutcome::Cancelled),
                Err(ClientError::Blocked(b)) => {
                    return Err(ClientError::Aborted {
                        during: "servo",
                        blockers: b,
                    })
                }
                Err(e) => return Err(e),
            };
            lock(&self.link.shared.common.stats).stats.stream_samples += 1;
            {
                let mut input = lock(&self.state.input);
                let sums = &mut input.sums;
                let rtt = ex.rtt();
                let queued = ex.sent_at.saturating_duration_since(p.pushed_at);
                sums.stats.sent += 1;
                sums.push_to_send_sum += queued;
                sums.stats.push_to_send_max = sums.stats.push_to_send_max.max(queued);
                sums.rtt_sum += rtt;
                sums.stats.rtt_max = sums.stats.rtt_max.max(rtt);
                if let Some(now_s) = ex.frame.status.timer.seconds() {
                    let dt = (now_s - t0_s)
                        .clamp(-StreamSample::TIME_CLAMP_S, StreamSample::TIME_CLAMP_S);
                    let expected = JointsDeg::new(std::array::from_fn(|j| {
                        p.position[j] + p.velocity[j] * dt + 0.5 * p.acceleration[j] * dt * dt
                    }));
                    let e = expected.max_abs_diff(&ex.frame.status.joints);
                    sums.stats.tracking_error_max_deg = sums.stats.tracking_error_max_deg.max(e);
                    sums.track_sq += e * e;
                    sums.stats.tracking_samples += 1;
                }
            }
            let b = blockers(&ex.frame.status, true);
            if !b.is_empty() {
                return Err(ClientError::Aborted {
                    during: "servo",
                    blockers: b,
                });
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn options_are_validated() {
        assert!(ServoOptions::default().validate().is_ok());
        let bad = [
            ServoOptions {
                lookahead_passes: f64::NAN,
                ..ServoOptions::default()
            },
            ServoOptions {
                lookahead_passes: 51.0,
                ..ServoOptions::default()
            },
            ServoOptions {
                watchdog: Duration::from_millis(5),
                ..ServoOptions::default()
            },
            ServoOptions {
                watchdog: Duration::from_millis(501),
                ..ServoOptions::default()
            },
            ServoOptions {
                max_step_deg: 0.0,
                ..ServoOptions::default()
            },
            ServoOptions {
                start_tolerance_deg: f64::INFINITY,
                ..ServoOptions::default()
            },
        ];
        for o in bad {
            let e = o.validate().unwrap_err();
            assert!(
                matches!(e, ClientError::Trajectory(TrajectoryError::Options(_))),
                "{o:?}: {e}"
            );
        }
    }

    #[test]
    fn a_push_after_the_end_says_why() {
        let text = |o| ended_error(o).to_string();
        let watchdog = text(ServoOutcome::Watchdog);
        assert!(
            watchdog.contains("watchdog") && watchdog.contains("Robot::start"),
            "{watchdog}"
        );
        assert!(text(ServoOutcome::Stopped).contains("ServoHandle::stop"));
        assert_eq!(
            ended_error(ServoOutcome::Cancelled),
            ClientError::Cancelled(Cancellation::Cancelled)
        );
        let e = ServoOptions {
            watchdog: Duration::from_secs(1),
            ..ServoOptions::default()
        }
        .validate()
        .unwrap_err();
        assert!(e.to_string().contains("servo watchdog"), "{e}");
    }

    #[test]
    fn stats_means() {
        let mut s = Sums::default();
        assert_eq!(s.snapshot(), ServoStats::default());
        s.stats.pushes = 3;
        s.interval_sum = Duration::from_millis(20);
        s.stats.sent = 2;
        s.rtt_sum = Duration::from_millis(2);
        s.push_to_send_sum = Duration::from_millis(4);
        s.stats.tracking_samples = 2;
        s.track_sq = 8.0;
        let v = s.snapshot();
        assert_eq!(v.push_interval_mean, Duration::from_millis(10));
        assert_eq!(v.rtt_mean, Duration::from_millis(1));
        assert_eq!(v.push_to_send_mean, Duration::from_millis(2));
        assert!((v.tracking_error_rms_deg - 2.0).abs() < 1e-12);
    }
}
