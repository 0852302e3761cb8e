//! Streaming a trajectory: command 7 samples stamped with the estimated server clock (default;
//! held targets by default, see [`TargetPacing`]), or command 6 waypoints at a fixed rate.

use std::future::Future;
use std::sync::atomic::Ordering;
use std::sync::Arc;
use std::time::Duration;

use fs020n_kin::RobotModel;
use fs020n_proto::{Command, JointsDeg, Request, StreamSample, JOINT_COUNT};
use serde::Serialize;
use tokio::sync::watch;
use tokio::time::Instant;

use crate::check::check_target;
use crate::clock::ClockFit;
use crate::curvature::{corrected, CurvatureCompensation, CORRECTION_RATE_DEG_S};
use crate::error::{Activity, ClientError, LinkError};
use crate::lag::{LagCompensation, LagEstimator};
use crate::motion::{only_held, LONGEST_WAIT};
use crate::pacing::{move_time_s, next_target, HeldTarget, Pace, TargetPacing};
use crate::safety::{blockers, check_stream_sample, MAX_LOOKAHEAD_PASSES};
use crate::session::{lock, Exchange, Link, SessionShared};
use crate::trajectory::{OptionError, Trajectory, TrajectoryError, TrajectorySample};

/// How samples are sent.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub enum StreamMode {
    /// Command 7: position, velocity and acceleration stamped with the server time at which
    /// they hold; the controller extrapolates to its own "now" plus `lookahead_passes` passes
    /// of its motion loop (at most 0.5 s of stamp error is absorbed). With held targets
    /// ([`StreamOptions::target_pacing`], the default) the sample is a point of the trajectory
    /// ahead with zero velocity and acceleration, the same for a few samples.
    Extrapolated {
        /// ARG2 of command 7, in passes of the motion program. Default 2.
        lookahead_passes: f64,
    },
    /// Command 6: the trajectory's position as a joint-move target every period. Simple and
    /// robust, but each target is a JMOVE at the monitor speed (the robot stops and starts if
    /// the period is long).
    Waypoints,
}

/// Options of [`Robot::stream`](crate::Robot::stream).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct StreamOptions {
    /// Command 7 (default) or command 6.
    pub mode: StreamMode,
    /// Time between samples (lock-step: a sample is sent at the earliest when the previous
    /// reply arrived). Default 20 ms (50 Hz).
    pub period: Duration,
    /// Largest change of any joint between two consecutive samples, degrees (checked on the
    /// whole trajectory at `period` before sending, and on every sample). Default 2°.
    pub max_step_deg: f64,
    /// Largest distance of the trajectory's first point from the current joints, degrees.
    /// Default 1°.
    pub start_tolerance_deg: f64,
    /// Longest gap between two samples before the stream is cancelled as an underrun (keep it
    /// below the 0.5 s the controller extrapolates at most). Default 250 ms.
    pub max_gap: Duration,
    /// After the last sample, wait until every joint is this close to the last point,
    /// degrees. Default 0.5°.
    pub end_tolerance_deg: f64,
    /// ...for at most this long (not an error: the report gives the final error). Default 3 s;
    /// at most one day.
    pub end_timeout: Duration,
    /// What HOLD does to the stream. `None` (default): the stream fails at once with
    /// [`ClientError::Aborted`] (commands 5 then 2 stop the arm). `Some(limit)`: the stream pauses with the
    /// controller — it sends command 5 (so that switching back to RUN does not replay a stale
    /// sample), stops its trajectory clock, and goes on from the same trajectory time once the
    /// controller runs again; after `limit` in HOLD it fails with
    /// [`ClientError::HoldTimeout`]. [`StreamProgress::held`] tells a progress display. At most
    /// one day.
    pub hold_timeout: Option<Duration>,
    /// How command 7 compensates the controller's tracking lag (ignored for waypoints).
    /// Default: estimated online from the replies, a lead of at most 0.3 s ([`LagCompensation`]).
    pub lag_compensation: LagCompensation,
    /// Whether command 7 boosts curved paths against the rounding of the controller's pipeline
    /// (ignored for waypoints). Default `Off`: on the emulated controller a fixed gain made the
    /// tracking worse, see [`CurvatureCompensation`] and docs/PERFORMANCE.md. Needs
    /// [`TargetPacing::Extrapolated`].
    pub curvature_compensation: CurvatureCompensation,
    /// How often command 7 gives the controller a new target (ignored for waypoints). Default
    /// [`TargetPacing::Held`]: a point of the trajectory ahead, held for 20–80 ms, so that the
    /// controller's passes do not wait for ACCURACY when the tool is fast.
    pub target_pacing: TargetPacing,
}

impl Default for StreamOptions {
    fn default() -> Self {
        StreamOptions {
            mode: StreamMode::Extrapolated {
                lookahead_passes: 2.0,
            },
            period: Duration::from_millis(20),
            max_step_deg: 2.0,
            start_tolerance_deg: 1.0,
            max_gap: Duration::from_millis(250),
            end_tolerance_deg: 0.5,
            end_timeout: Duration::from_secs(3),
            hold_timeout: None,
            lag_compensation: LagCompensation::default(),
            curvature_compensation: CurvatureCompensation::default(),
            target_pacing: TargetPacing::default(),
        }
    }
}

impl StreamOptions {
    /// Checks these options and `trajectory` streamed with them against `model` — everything
    /// [`Robot::stream`](crate::Robot::stream) checks before it sends, except what needs the
    /// robot (its current joints and status). The options against their ranges; the trajectory
    /// against the joint ranges and speeds at every point and every sample one `period` apart,
    /// and the per-cycle step; for command 7 also each sample as it would be sent
    /// ([`check_stream_sample`](crate::check_stream_sample): velocities, accelerations, every
    /// target the controller can extrapolate to).
    ///
    /// ```
    /// use fs020n_client::{StreamOptions, Trajectory, TrajectoryPoint};
    /// use fs020n_kin::RobotModel;
    /// use fs020n_proto::JointsDeg;
    /// let model = RobotModel::fs020n();
    /// let mut end = model.home;
    /// end[0] = 10.0;
    /// let t = Trajectory::new(vec![
    ///     TrajectoryPoint::new(0.0, model.home),
    ///     TrajectoryPoint::new(2.0, end),
    /// ])?;
    /// StreamOptions::default().validate(&model, &t)?;
    /// # Ok::<(), fs020n_client::TrajectoryError>(())
    /// ```
    pub fn validate(
        &self,
        model: &RobotModel,
        trajectory: &Trajectory,
    ) -> Result<(), TrajectoryError> {
        self.validate_options()?;
        match self.mode {
            StreamMode::Extrapolated { lookahead_passes } => trajectory.validate_extrapolated(
                model,
                self.period,
                self.max_step_deg,
                lookahead_passes,
            ),
            StreamMode::Waypoints => {
                trajectory.validate_waypoints(model, self.period, self.max_step_deg)
            }
        }
    }

    fn validate_options(&self) -> Result<(), OptionError> {
        let period = self.period;
        if !(Duration::from_millis(1)..=Duration::from_secs(1)).contains(&period) {
            return Err(OptionError::Period { period });
        }
        if let StreamMode::Extrapolated { lookahead_passes } = self.mode {
            if !(lookahead_passes.is_finite()
                && (0.0..=MAX_LOOKAHEAD_PASSES).contains(&lookahead_passes))
            {
                return Err(OptionError::Lookahead {
                    passes: lookahead_passes,
                    max: MAX_LOOKAHEAD_PASSES,
                });
            }
        }
        if !(self.max_step_deg.is_finite() && self.max_step_deg > 0.0) {
            return Err(OptionError::MaxStep {
                deg: self.max_step_deg,
            });
        }
        if self.lag_compensation.validate().is_err() {
            let lead = match self.lag_compensation {
                LagCompensation::Off => Duration::ZERO,
                LagCompensation::Fixed(d) | LagCompensation::Online { max: d } => d,
            };
            return Err(OptionError::Lead {
                lead,
                max: LagCompensation::LIMIT,
            });
        }
        if self.curvature_compensation.validate().is_err() {
            let (gain_s2, max_deg) = match self.curvature_compensation {
                CurvatureCompensation::Off => (0.0, 0.0),
                CurvatureCompensation::Fixed { gain_s2, max_deg } => (gain_s2, max_deg),
            };
            return Err(OptionError::Curvature { gain_s2, max_deg });
        }
        if self.target_pacing == TargetPacing::Held
            && self.curvature_compensation != CurvatureCompensation::Off
            && self.mode != StreamMode::Waypoints
        {
            return Err(OptionError::CurvatureNeedsExtrapolatedPacing);
        }
        for (option, timeout) in [
            ("end_timeout", Some(self.end_timeout)),
            ("hold_timeout", self.hold_timeout),
        ] {
            if let Some(timeout) = timeout.filter(|t| *t > LONGEST_WAIT) {
                return Err(OptionError::Timeout { option, timeout });
            }
        }
        if self.max_gap < period * 2 || self.max_gap > Duration::from_millis(500) {
            return Err(OptionError::MaxGap {
                gap: self.max_gap,
                period,
            });
        }
        for (option, deg) in [
            ("start_tolerance_deg", self.start_tolerance_deg),
            ("end_tolerance_deg", self.end_tolerance_deg),
        ] {
            if !(deg.is_finite() && deg > 0.0) {
                return Err(OptionError::Tolerance { option, deg });
            }
        }
        Ok(())
    }
}

/// Progress of a stream.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize)]
pub struct StreamProgress {
    /// Samples sent.
    pub index: u64,
    /// Trajectory time of the last sample, seconds.
    pub time_s: f64,
    /// Fraction of the trajectory's duration streamed, [0, 1].
    pub fraction: f64,
    /// Replies slower than the period so far.
    pub late_replies: u64,
    /// Cycles that started more than one period late so far.
    pub underruns: u64,
    /// Largest tracking error so far, degrees.
    pub tracking_error_max_deg: f64,
    /// All samples sent (the robot may still be settling).
    pub done: bool,
    /// The controller holds the motion (RUN/HOLD on HOLD) and the stream waits for RUN
    /// ([`StreamOptions::hold_timeout`]).
    pub held: bool,
}

/// How a stream ended.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum StreamOutcome {
    /// Every sample was sent.
    Completed,
    /// Cancelled by the user (commands 5 and 2 sent).
    Cancelled,
}

/// The final report of a stream.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct StreamReport {
    /// Completed or cancelled.
    pub outcome: StreamOutcome,
    /// Samples sent.
    pub samples_sent: u64,
    /// Replies slower than the period.
    pub late_replies: u64,
    /// Cycles that started more than one period late.
    pub underruns: u64,
    /// Largest tracking error, degrees: the largest per-joint difference between the joints in
    /// a reply and the trajectory at the same server time (TIMER(1) of that reply).
    pub tracking_error_max_deg: f64,
    /// Root mean square of those per-reply tracking errors, degrees.
    pub tracking_error_rms_deg: f64,
    /// Replies the tracking error was computed from.
    pub tracking_samples: u64,
    /// Largest per-joint distance to the last point at the end, degrees.
    pub final_error_deg: f64,
    /// The robot came within `end_tolerance_deg` of the last point before `end_timeout`.
    pub settled: bool,
    /// Time from the first sample to the end of the report.
    pub duration: Duration,
    /// Round trips of the samples: mean.
    pub rtt_mean: Duration,
    /// Round trips of the samples: slowest.
    pub rtt_max: Duration,
    /// The time shift that best aligns the arm with the trajectory over the stream, seconds
    /// (positive: the arm is behind); `None` without replies while the trajectory moved.
    pub lag_s: Option<f64>,
    /// The lead command 7 was stamped with at the end, seconds (see [`LagCompensation`]).
    pub lead_s: f64,
    /// The curvature gain command 7 was corrected with, seconds² (see
    /// [`CurvatureCompensation`]; 0 when off or for waypoints).
    pub curvature_gain_s2: f64,
    /// The server-clock estimate at the end (command 7 only).
    #[serde(skip)]
    pub clock: Option<ClockFit>,
}

/// Checks done before anything is sent: [`StreamOptions::validate`], then the start against
/// the current joints.
pub(crate) fn check(
    model: &RobotModel,
    trajectory: &Trajectory,
    options: &StreamOptions,
    current: &JointsDeg,
) -> Result<(), ClientError> {
    options.validate(model, trajectory)?;
    let first = trajectory.first();
    let (joint, distance) = (0..JOINT_COUNT)
        .map(|j| (j + 1, (first[j] - current[j]).abs()))
        .fold((1, 0.0), |a, b| if b.1 > a.1 { b } else { a });
    if distance > options.start_tolerance_deg {
        return Err(TrajectoryError::StartTooFar {
            joint,
            distance_deg: distance,
            tolerance_deg: options.start_tolerance_deg,
        }
        .into());
    }
    Ok(())
}

/// A running stream: wait for it, watch it, cancel it. Clones share the stream.
///
/// Like [`MoveHandle`](crate::MoveHandle): [`wait`](Self::wait) and [`cancel`](Self::cancel)
/// take `&self`; `cancel` acts only while this stream is the current motion; and dropping the
/// last clone while the stream runs cancels it (commands 5 and 2), also while the robot
/// settles on the last point.
#[derive(Debug, Clone)]
#[must_use = "dropping the last StreamHandle cancels the stream: keep it and call wait()"]
pub struct StreamHandle {
    inner: Arc<StreamInner>,
}

type StreamResult = Option<Result<StreamReport, ClientError>>;

#[derive(Debug)]
struct StreamInner {
    progress: watch::Receiver<StreamProgress>,
    result: watch::Receiver<StreamResult>,
    shared: Arc<SessionShared>,
    epoch: u64,
}

impl StreamInner {
    fn is_finished(&self) -> bool {
        // A sender dropped without a result: the task was aborted (runtime shut down).
        self.result.borrow().is_some() || self.result.has_changed().is_err()
    }

    fn cancel_now(&self) {
        if !self.is_finished() && self.shared.current_epoch() == self.epoch {
            self.shared.bump_epoch();
        }
    }
}

impl Drop for StreamInner {
    fn drop(&mut self) {
        self.cancel_now();
    }
}

impl StreamHandle {
    /// Spawns the stream task. `epoch` is the motion epoch read when the caller started
    /// (before any await): a cancel or stop issued since then cancels the stream before its
    /// first sample.
    pub(crate) fn spawn(
        link: Link,
        model: RobotModel,
        trajectory: Trajectory,
        options: StreamOptions,
        epoch: u64,
    ) -> Result<StreamHandle, ClientError> {
        let shared = link.shared.clone();
        if shared.streaming.swap(true, Ordering::SeqCst) {
            return Err(ClientError::Busy(Activity::Stream));
        }
        let (tx, progress) = watch::channel(StreamProgress::default());
        let (result_tx, result) = watch::channel(None);
        let guard = StreamingGuard(shared.clone());
        tokio::spawn(async move {
            let r = Streamer {
                link,
                model,
                trajectory,
                options,
                progress: tx,
                epoch,
            }
            .run()
            .await;
            // Not streaming any more before anyone learns the result.
            drop(guard);
            result_tx.send_replace(Some(r));
        });
        Ok(StreamHandle {
            inner: Arc::new(StreamInner {
                progress,
                result,
                shared,
                epoch,
            }),
        })
    }

    /// The latest progress.
    pub fn progress(&self) -> StreamProgress {
        *self.inner.progress.borrow()
    }

    /// A receiver of progress updates (one per sample).
    pub fn subscribe(&self) -> watch::Receiver<StreamProgress> {
        self.inner.progress.clone()
    }

    /// Cancels the stream, if it is still the current motion: no further sample is sent,
    /// command 5 brakes the robot and command 2 ends the motion program (so no planned segment
    /// runs after the brake). Returns once the stream has ended; [`wait`](Self::wait) then
    /// gives a report with [`StreamOutcome::Cancelled`]. After a newer motion, a cancel or a
    /// stop, or once the stream has ended, it does nothing.
    pub async fn cancel(&self) -> Result<(), ClientError> {
        self.inner.cancel_now();
        match self.wait().await {
            Err(e) if e.is_link_dead() => Err(e),
            _ => Ok(()),
        }
    }

    /// `true` once the stream task has ended.
    pub fn is_finished(&self) -> bool {
        self.inner.is_finished()
    }

    /// Waits for the end of the stream and returns its report (every clone gets the same).
    pub async fn wait(&self) -> Result<StreamReport, ClientError> {
        let mut rx = self.inner.result.clone();
        let r = match rx.wait_for(Option::is_some).await {
            Ok(r) => r.clone(),
            Err(_) => None,
        };
        r.unwrap_or(Err(LinkError::SessionEnded.into()))
    }
}

struct StreamingGuard(Arc<SessionShared>);

impl Drop for StreamingGuard {
    fn drop(&mut self) {
        self.0.streaming.store(false, Ordering::SeqCst);
    }
}

struct Streamer {
    link: Link,
    model: RobotModel,
    trajectory: Trajectory,
    options: StreamOptions,
    progress: watch::Sender<StreamProgress>,
    epoch: u64,
}

#[derive(Default)]
struct Tally {
    lag: Option<LagEstimator>,
    samples: u64,
    late: u64,
    underruns: u64,
    track_max: f64,
    track_sq: f64,
    track_n: u64,
    rtt_sum: Duration,
    rtt_max: Duration,
}

enum End {
    Done,
    Cancelled,
}

/// How the wait after the last sample ended (with the final error, degrees, if not cancelled).
enum Settle {
    Reached(f64),
    TimedOut(f64),
    Cancelled,
}

impl Streamer {
    fn cancelled(&self) -> bool {
        self.link.shared.current_epoch() != self.epoch
    }

    /// The controller's move time at the monitor speed this session set, seconds.
    fn move_s(&self) -> f64 {
        move_time_s(self.link.shared.speed_percent())
    }

    /// Command 7 with held targets ([`TargetPacing::Held`]).
    fn held(&self) -> bool {
        matches!(self.options.mode, StreamMode::Extrapolated { .. })
            && self.options.target_pacing == TargetPacing::Held
    }

    fn server_time(&self, at: Instant) -> Option<f64> {
        lock(&self.link.shared.clock).server_time(at)
    }

    /// Stops the arm for sure: commands 5 then 2 (best effort: the error that ended the
    /// stream is what gets reported).
    async fn brake(&self) {
        if let Err(e) = self.link.halt().await {
            tracing::warn!(error = %e, "could not send the cancel at the end of a stream");
        }
    }

    async fn run(self) -> Result<StreamReport, ClientError> {
        let mut tally = Tally {
            // Waypoints are not stamped: their lag is only measured.
            lag: Some(match self.options.mode {
                // Held targets: the moves' own delay is half a move; the online lead starts
                // there instead of at none.
                StreamMode::Extrapolated { .. } if self.held() => {
                    LagEstimator::starting_at(self.options.lag_compensation, 0.5 * self.move_s())
                }
                StreamMode::Extrapolated { .. } => LagEstimator::new(self.options.lag_compensation),
                StreamMode::Waypoints => LagEstimator::new(LagCompensation::Off),
            }),
            ..Tally::default()
        };
        let started = Instant::now();
        let r = self.send_all(&mut tally).await;
        let end = match r {
            Ok(end) => end,
            Err(e) => {
                if !e.is_link_dead() {
                    self.brake().await;
                }
                return Err(e);
            }
        };
        let settle = match end {
            End::Cancelled => Settle::Cancelled,
            End::Done => match self.settle().await {
                Ok(s) => s,
                Err(e) => {
                    if !e.is_link_dead() {
                        self.brake().await;
                    }
                    return Err(e);
                }
            },
        };
        let (outcome, final_error_deg, settled) = match settle {
            Settle::Reached(e) => (StreamOutcome::Completed, e, true),
            Settle::TimedOut(e) => (StreamOutcome::Completed, e, false),
            // Cancelled while sending or while the robot was still settling on the last
            // point (the newest command is still a 7): brake either way.
            Settle::Cancelled => {
                self.brake().await;
                let err = self
                    .link
                    .latest()
                    .status
                    .joints
                    .max_abs_diff(&self.trajectory.last());
                (StreamOutcome::Cancelled, err, false)
            }
        };
        let rtt_mean = if tally.samples > 0 {
            tally.rtt_sum / u32::try_from(tally.samples).unwrap_or(u32::MAX)
        } else {
            Duration::ZERO
        };
        Ok(StreamReport {
            outcome,
            samples_sent: tally.samples,
            late_replies: tally.late,
            underruns: tally.underruns,
            tracking_error_max_deg: tally.track_max,
            tracking_error_rms_deg: if tally.track_n > 0 {
                (tally.track_sq / tally.track_n as f64).sqrt()
            } else {
                0.0
            },
            tracking_samples: tally.track_n,
            final_error_deg,
            settled,
            duration: started.elapsed(),
            rtt_mean,
            rtt_max: tally.rtt_max,
            lag_s: tally.lag.as_ref().and_then(LagEstimator::apparent_lag_s),
            lead_s: tally.lag.as_ref().map_or(0.0, LagEstimator::lead_s),
            curvature_gain_s2: match self.options.mode {
                StreamMode::Extrapolated { .. } => self.options.curvature_compensation.gain_s2(),
                StreamMode::Waypoints => 0.0,
            },
            clock: lock(&self.link.shared.clock).fit(),
        })
    }

    /// The command for one sample at trajectory time `tau`, checked before it is sent: the
    /// position against the ranges and, for command 7, the whole sample with
    /// [`check_stream_sample`] (velocity, acceleration, every extrapolated target).
    fn command_for(
        &self,
        tau: f64,
        s: &TrajectorySample,
        t0_s: Option<f64>,
    ) -> Result<Command, ClientError> {
        self.command_within(&self.model, tau, s, t0_s)
    }

    /// [`command_for`](Self::command_for) against `model` (the robot's, or its ranges shrunk
    /// for a curvature-corrected sample).
    fn command_within(
        &self,
        model: &RobotModel,
        tau: f64,
        s: &TrajectorySample,
        t0_s: Option<f64>,
    ) -> Result<Command, ClientError> {
        check_target(model, &s.position)?;
        Ok(match self.options.mode {
            StreamMode::Extrapolated { lookahead_passes } => {
                let t0_s = t0_s.ok_or(ClientError::NoServerClock)?;
                let sample = StreamSample {
                    t0_s,
                    lookahead_passes,
                    position: s.position,
                    velocity: s.velocity,
                    acceleration: s.acceleration,
                };
                check_stream_sample(model, &sample).map_err(|error| {
                    ClientError::Trajectory(TrajectoryError::Sample { time_s: tau, error })
                })?;
                Command::StreamedMove(sample)
            }
            StreamMode::Waypoints => Command::JointMove { target: s.position },
        })
    }

    /// `true` when the stream should wait out this HOLD rather than fail.
    fn waits_in(&self, b: &[crate::Blocker]) -> bool {
        self.options.hold_timeout.is_some() && only_held(b)
    }

    /// The controller holds the motion: command 5 (so that RUN does not replay the last
    /// sample, stale by then — but not command 2, which would end the program the controller
    /// is about to resume), then wait for RUN. `Ok(Some(held))` when the controller runs again,
    /// `Ok(None)` on a cancel.
    async fn hold(&self) -> Result<Option<Duration>, ClientError> {
        let since = Instant::now();
        let limit = self
            .options
            .hold_timeout
            .unwrap_or_default()
            .min(LONGEST_WAIT);
        self.progress.send_modify(|p| p.held = true);
        tracing::info!("stream held (RUN/HOLD on HOLD); waiting for RUN");
        self.link
            .command(&Request::new(Command::CancelMotion))
            .await?;
        let mut rx = self.link.status.clone();
        let mut epoch_rx = self.link.shared.epoch.subscribe();
        loop {
            if self.cancelled() {
                return Ok(None);
            }
            let b = blockers(&rx.borrow_and_update().status, true);
            if b.is_empty() {
                self.progress.send_modify(|p| p.held = false);
                tracing::info!("stream resumed");
                return Ok(Some(since.elapsed()));
            }
            if !only_held(&b) {
                return Err(ClientError::Aborted {
                    during: "stream",
                    blockers: b,
                });
            }
            tokio::select! {
                r = rx.changed() => if r.is_err() { return Err(self.link.shared.death()) },
                _ = epoch_rx.changed() => {}
                _ = tokio::time::sleep_until(since + limit) => {
                    return Err(ClientError::HoldTimeout { during: "stream", waited: since.elapsed() });
                }
            }
        }
    }

    async fn send_all(&self, tally: &mut Tally) -> Result<End, ClientError> {
        let period = self.options.period;
        let period_s = period.as_secs_f64();
        let (t_begin, t_end) = (self.trajectory.start_s(), self.trajectory.end_s());
        let span = (t_end - t_begin).max(0.0);
        let mut epoch_rx = self.link.shared.epoch.subscribe();
        // Local time of trajectory time `t_begin`; moved on by the time spent in HOLD.
        let mut local_start = Instant::now();
        let mut last_sent: Option<Instant> = None;
        let mut prev_pos = self.trajectory.first();
        // The curvature correction of the sample sent last (sent − plain), degrees.
        let mut correction = JointsDeg::ZERO;
        // A corrected sample must stay the correction's bound inside the ranges (over the
        // whole extrapolation window): it never brings a target closer to a limit than the
        // plain samples could be, where rounding would decide.
        let boost_model = {
            let margin = self.options.curvature_compensation.max_deg();
            let mut m = self.model.clone();
            for joint in &mut m.joints {
                let mid = 0.5 * (joint.min_deg + joint.max_deg);
                joint.min_deg = (joint.min_deg + margin).min(mid);
                joint.max_deg = (joint.max_deg - margin).max(mid);
            }
            m
        };
        let mut rtt_est = self.link.latest().rtt;
        let mut next_due: Option<Instant> = None;
        // The timers of the next sample and of the one after it, used in turn (see below).
        let mut timers = [
            Box::pin(tokio::time::sleep(Duration::ZERO)),
            Box::pin(tokio::time::sleep(Duration::ZERO)),
        ];
        let mut next_timer = 0;
        // The target the controller holds (held pacing), and the trajectory time of the last
        // one sent (kept across a HOLD, which drops the held target).
        let mut held: Option<HeldTarget> = None;
        let mut last_target_s = t_begin;
        let pace = Pace {
            period_s,
            move_s: self.move_s(),
        };
        loop {
            if self.cancelled() {
                return Ok(End::Cancelled);
            }
            if self.waits_in(&blockers(&self.link.latest().status, true)) {
                match self.hold().await? {
                    None => return Ok(End::Cancelled),
                    Some(paused) => {
                        local_start += paused;
                        last_sent = None;
                        next_due = None;
                        // The brake ended the held target's move: place a new one.
                        held = None;
                        continue;
                    }
                }
            }
            let now = Instant::now();
            let mut allowed_step = self.options.max_step_deg;
            if let Some(prev) = last_sent {
                let gap = now.duration_since(prev);
                if gap > self.options.max_gap {
                    lock(&self.link.shared.common.stats).stats.stream_underruns += 1;
                    return Err(ClientError::StreamUnderrun {
                        gap,
                        allowed: self.options.max_gap,
                    });
                }
                if gap > period * 2 {
                    tally.underruns += 1;
                    lock(&self.link.shared.common.stats).stats.stream_underruns += 1;
                }
                allowed_step *= (gap.as_secs_f64() / period_s).max(1.0);
            }
            // The sample the controller should act on: where the trajectory is when the request
            // arrives (half a round trip from now).
            let elapsed = now.saturating_duration_since(local_start) + rtt_est / 2;
            let tau = (t_begin + elapsed.as_secs_f64()).min(t_end);
            let last = tau >= t_end;
            let sample = if last {
                TrajectorySample {
                    position: self.trajectory.last(),
                    velocity: JointsDeg::ZERO,
                    acceleration: JointsDeg::ZERO,
                }
            } else {
                self.trajectory.sample_for_streaming(tau, &self.model)
            };
            let at = local_start + Duration::from_secs_f64((tau - t_begin).max(0.0));
            // Lag compensation: stamped as if it held `lead` earlier, the sample is extrapolated
            // that much further by the controller.
            let lead_s = tally.lag.as_ref().map_or(0.0, LagEstimator::lead_s);
            let lead = Duration::from_secs_f64(lead_s);
            // Held pacing: the held target, with zero velocity and acceleration (the controller
            // then starts one move per target); a new one may step by `max_step_deg` per period
            // of trajectory time since the one before.
            let sample = if self.held() {
                if let Some(next) = next_target(
                    &self.model,
                    &self.trajectory,
                    held.as_ref(),
                    tau,
                    lead_s,
                    pace,
                    last,
                ) {
                    allowed_step = allowed_step.max(
                        self.options.max_step_deg
                            * ((next.time_s - last_target_s) / period_s).max(1.0),
                    );
                    last_target_s = next.time_s;
                    held = Some(next);
                }
                TrajectorySample {
                    position: held.map_or(sample.position, |h| h.position),
                    velocity: JointsDeg::ZERO,
                    acceleration: JointsDeg::ZERO,
                }
            } else {
                sample
            };
            let stamp_at = at.checked_sub(lead).unwrap_or(at);
            let t0_s = self.server_time(stamp_at);
            // Curvature compensation (command 7, not the last sample, which holds the end
            // point): the corrected sample is sent only if it passes every check the plain one
            // must pass (the step; the ranges, over the extrapolation window, shrunk by the
            // correction's bound); otherwise the correction returning toward zero, otherwise
            // the plain sample.
            let gain = self.options.curvature_compensation.gain_s2();
            let plain = sample;
            let boosted = match self.options.mode {
                StreamMode::Extrapolated { .. }
                    if !last && (gain > 0.0 || correction != JointsDeg::ZERO) =>
                {
                    let max_deg = self.options.curvature_compensation.max_deg();
                    let max_change = CORRECTION_RATE_DEG_S * period_s;
                    // the boost asked for; else back toward the plain sample at the same rate
                    [gain, 0.0].into_iter().find_map(|g| {
                        let c = corrected(
                            &self.trajectory,
                            tau,
                            &plain,
                            g,
                            max_deg,
                            &correction,
                            max_change,
                        );
                        if c.position.max_abs_diff(&prev_pos) > allowed_step {
                            return None;
                        }
                        self.command_within(&boost_model, tau, &c, t0_s)
                            .ok()
                            .map(|cmd| (c, cmd))
                    })
                }
                _ => None,
            };
            let (sample, command) = match boosted {
                Some((c, cmd)) => (c, Ok(cmd)),
                None => {
                    let command = self.command_for(tau, &plain, t0_s);
                    (plain, command)
                }
            };
            for j in 0..JOINT_COUNT {
                correction[j] = sample.position[j] - plain.position[j];
            }
            let step = sample.position.max_abs_diff(&prev_pos);
            if step > allowed_step + 1e-9 {
                let joint = (0..JOINT_COUNT)
                    .max_by(|&a, &b| {
                        let da = (sample.position[a] - prev_pos[a]).abs();
                        let db = (sample.position[b] - prev_pos[b]).abs();
                        da.total_cmp(&db)
                    })
                    .unwrap_or(0);
                return Err(TrajectoryError::StepTooLarge {
                    time_s: tau,
                    joint: joint + 1,
                    step_deg: step,
                    max_deg: allowed_step,
                }
                .into());
            }
            let command = command?;
            let text = Request::new(command).encode()?;
            // The timers are in the runtime's timer wheel before the runtime sleeps for this
            // reply: the next sample's, and the one after it. A timer armed earlier than every
            // other one makes tokio wake its own driver (an eventfd write and one more
            // epoll_wait); on the fixed schedule each timer is armed one period after the
            // other one's deadline, so that never happens.
            let due = next_due.unwrap_or_else(Instant::now) + period;
            let [a, b] = &mut timers;
            let (this, after) = if next_timer == 0 { (a, b) } else { (b, a) };
            if this.deadline() != due {
                this.as_mut().reset(due);
            }
            if after.deadline() != due + period {
                after.as_mut().reset(due + period);
            }
            std::future::poll_fn(|cx| {
                let _ = this.as_mut().poll(cx);
                let _ = after.as_mut().poll(cx);
                std::task::Poll::Ready(())
            })
            .await;
            let ex = match self.link.exchange_own_motion(text, self.epoch).await {
                Ok(ex) => ex,
                Err(ClientError::Cancelled(_)) => return Ok(End::Cancelled),
                // HOLD arrived with a keep-alive before this sample left: it was not sent.
                Err(ClientError::Blocked(b)) if self.waits_in(&b) => continue,
                Err(ClientError::Blocked(b)) => {
                    return Err(ClientError::Aborted {
                        during: "stream",
                        blockers: b,
                    })
                }
                Err(e) => return Err(e),
            };
            tally.samples += 1;
            lock(&self.link.shared.common.stats).stats.stream_samples += 1;
            let rtt = ex.rtt();
            rtt_est = if tally.samples == 1 {
                rtt
            } else {
                (rtt_est * 7 + rtt) / 8
            };
            tally.rtt_sum += rtt;
            tally.rtt_max = tally.rtt_max.max(rtt);
            if rtt > period {
                tally.late += 1;
                lock(&self.link.shared.common.stats)
                    .stats
                    .stream_late_replies += 1;
            }
            last_sent = Some(ex.sent_at);
            prev_pos = sample.position;
            self.track(&ex, local_start, t_begin, t_end, tally);
            let b = blockers(&ex.frame.status, true);
            if !b.is_empty() && !self.waits_in(&b) {
                return Err(ClientError::Aborted {
                    during: "stream",
                    blockers: b,
                });
            }
            self.progress.send_replace(StreamProgress {
                index: tally.samples,
                time_s: tau,
                fraction: if span > 0.0 {
                    ((tau - t_begin) / span).clamp(0.0, 1.0)
                } else {
                    1.0
                },
                late_replies: tally.late,
                underruns: tally.underruns,
                tracking_error_max_deg: tally.track_max,
                done: last,
                held: false,
            });
            if last {
                return Ok(End::Done);
            }
            if !b.is_empty() {
                // Held: the next turn of the loop waits for RUN.
                continue;
            }
            // Samples on a fixed schedule, one period apart: a timer that fires late (the
            // runtime's timers have 1 ms resolution) does not delay the ones after it, so the
            // rate is the one asked for. Behind schedule, the next sample goes out at once.
            let due = due.max(Instant::now());
            next_due = Some(due);
            tokio::select! {
                // Already elapsed when behind schedule.
                _ = timers[next_timer].as_mut() => {}
                _ = epoch_rx.changed() => {}
            }
            next_timer = 1 - next_timer;
        }
    }

    /// Tracking error of one reply: its joints against the trajectory at the reply's server
    /// time.
    fn track(
        &self,
        ex: &Exchange,
        local_start: Instant,
        t_begin: f64,
        t_end: f64,
        tally: &mut Tally,
    ) {
        let Some(server_s) = ex.frame.status.timer.seconds() else {
            return;
        };
        let Some(local) = lock(&self.link.shared.clock).local_instant(server_s) else {
            return;
        };
        if local < local_start {
            return;
        }
        let tau = t_begin + local.duration_since(local_start).as_secs_f64();
        if tau > t_end {
            return;
        }
        if let Some(lag) = &mut tally.lag {
            let lead = lag.lead_s();
            lag.observe(&self.trajectory, tau, &ex.frame.status.joints, lead);
        }
        let e = self
            .trajectory
            .sample(tau)
            .position
            .max_abs_diff(&ex.frame.status.joints);
        tally.track_max = tally.track_max.max(e);
        tally.track_sq += e * e;
        tally.track_n += 1;
    }

    /// After the last sample: waits (on the keep-alive statuses) until the robot is at the last
    /// point, the end timeout, or a cancel.
    async fn settle(&self) -> Result<Settle, ClientError> {
        let target = self.trajectory.last();
        let now = Instant::now();
        let mut deadline = now
            .checked_add(self.options.end_timeout.min(LONGEST_WAIT))
            .unwrap_or(now + LONGEST_WAIT);
        let mut rx = self.link.status.clone();
        let mut epoch_rx = self.link.shared.epoch.subscribe();
        let mut held_since: Option<Instant> = None;
        loop {
            let s = rx.borrow_and_update().clone();
            let b = blockers(&s.status, true);
            // The last sample holds the end point with zero velocity: after HOLD the robot
            // just goes on to it, so a held settle needs no brake.
            let held = self.waits_in(&b);
            if !b.is_empty() && !held {
                return Err(ClientError::Aborted {
                    during: "stream",
                    blockers: b,
                });
            }
            match (held, held_since) {
                (true, None) => {
                    held_since = Some(s.received_at);
                    self.progress.send_modify(|p| p.held = true);
                }
                (false, Some(since)) => {
                    deadline += s.received_at.saturating_duration_since(since);
                    held_since = None;
                    self.progress.send_modify(|p| p.held = false);
                }
                _ => {}
            }
            let err = s.status.joints.max_abs_diff(&target);
            if self.cancelled() {
                return Ok(Settle::Cancelled);
            }
            if !held && err <= self.options.end_tolerance_deg {
                return Ok(Settle::Reached(err));
            }
            let wake = match (held_since, self.options.hold_timeout) {
                (Some(since), Some(limit)) => since + limit.min(LONGEST_WAIT),
                _ => deadline,
            };
            tokio::select! {
                r = rx.changed() => if r.is_err() { return Err(self.link.shared.death()) },
                _ = epoch_rx.changed() => {}
                _ = tokio::time::sleep_until(wake) => {
                    if let Some(since) = held_since {
                        return Err(ClientError::HoldTimeout { during: "stream", waited: since.elapsed() });
                    }
                    return Ok(Settle::TimedOut(err));
                }
            }
        }
    }
}
