//! Joint moves in progress: waiting for completion, progress, cancellation.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::Duration;

use fs020n_kin::{JointMove, RobotModel};
use fs020n_proto::JointsDeg;
use tokio::sync::watch;
use tokio::time::Instant;

use crate::error::{Cancellation, ClientError};
use crate::safety::{blockers, Blocker};
use crate::session::{Link, MotionTag, StatusSnapshot};

/// `true` when HOLD is the only thing that stops the motion: the controller paused it and
/// resumes it when RUN/HOLD is switched back to RUN.
pub(crate) fn only_held(blockers: &[Blocker]) -> bool {
    blockers == [Blocker::Hold]
}

/// Longest timeout honoured by [`MoveHandle::wait`] and the stream's end wait: longer ones are
/// treated as this (one day).
pub(crate) const LONGEST_WAIT: Duration = Duration::from_secs(24 * 60 * 60);

/// When a move counts as finished.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Completion {
    /// Every joint within this many degrees of the target. Default 0.1°. Must be finite and
    /// above 0.
    pub tolerance_deg: f64,
    /// ...continuously for this long (by the replies' arrival times). Default 100 ms. At most
    /// one day.
    pub settle: Duration,
    /// Give up (and cancel the move) after this long from sending it. `None`: the planned
    /// duration of the move at the last speed set by this client (or
    /// `ClientConfig::assumed_speed_percent`), times 1.5, plus 3 s. Longer than one day counts
    /// as one day. Time spent paused by HOLD (see `hold_timeout`) does not count.
    pub timeout: Option<Duration>,
    /// What HOLD does to the wait. `None` (default): the wait fails at once with
    /// [`ClientError::Aborted`] and cancels the move (commands 5 then 2), so that switching back to RUN
    /// does not resume it unobserved. `Some(limit)`: the controller pauses the move and resumes
    /// it on RUN, and the wait waits with it — for at most `limit` in HOLD, after which it
    /// cancels the move (commands 5 then 2) and fails with [`ClientError::HoldTimeout`].
    /// [`MoveProgress::held`] tells a progress display. At most one day.
    pub hold_timeout: Option<Duration>,
}

impl Completion {
    /// Checks the values: `tolerance_deg` finite and above 0, `settle` and `hold_timeout` at
    /// most one day.
    pub fn validate(&self) -> Result<(), ClientError> {
        if !(self.tolerance_deg.is_finite() && self.tolerance_deg > 0.0) {
            return Err(ClientError::Config(format!(
                "Completion::tolerance_deg {} must be a finite number above 0",
                self.tolerance_deg
            )));
        }
        if self.settle > LONGEST_WAIT {
            return Err(ClientError::Config(format!(
                "Completion::settle {:?} must be at most {LONGEST_WAIT:?}",
                self.settle
            )));
        }
        if self.hold_timeout.is_some_and(|h| h > LONGEST_WAIT) {
            return Err(ClientError::Config(format!(
                "Completion::hold_timeout {:?} must be at most {LONGEST_WAIT:?}",
                self.hold_timeout
            )));
        }
        Ok(())
    }
}

impl Default for Completion {
    fn default() -> Self {
        Completion {
            tolerance_deg: 0.1,
            settle: Duration::from_millis(100),
            timeout: None,
            hold_timeout: None,
        }
    }
}

/// How far a move has come.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MoveProgress {
    /// Largest per-joint distance to the target, degrees.
    pub remaining_deg: f64,
    /// Largest per-joint distance from the start to the target, degrees.
    pub total_deg: f64,
    /// `1 − remaining / total`, in [0, 1] (1 for a zero-length move).
    pub fraction: f64,
    /// The joints in the status this was computed from.
    pub joints: JointsDeg,
    /// Age of that status.
    pub age: Duration,
    /// The controller holds the motion (RUN/HOLD on HOLD); it resumes on RUN.
    pub held: bool,
}

/// The outcome of a finished move.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MoveReport {
    /// The joints when the move counted as finished.
    pub final_joints: JointsDeg,
    /// Their largest per-joint distance to the target, degrees.
    pub error_deg: f64,
    /// Time from sending the move to its completion.
    pub elapsed: Duration,
}

/// A joint move that was sent: wait for it, watch it, cancel it. Clones share the move.
///
/// Like [`StreamHandle`](crate::StreamHandle): [`wait`](Self::wait) and
/// [`cancel`](Self::cancel) take `&self`; `cancel` acts only while this move is the current
/// motion (not after a newer motion superseded it, nor after a cancel or stop); and dropping
/// the last clone while the move is current and no [`wait`](Self::wait) has finished cancels
/// it (commands 5 then 2), so that a move nobody follows does not run on unobserved.
#[derive(Debug, Clone)]
#[must_use = "dropping the last MoveHandle cancels the move: keep it and call wait()"]
pub struct MoveHandle {
    inner: Arc<MoveInner>,
}

#[derive(Debug)]
struct MoveInner {
    link: Link,
    from: JointsDeg,
    target: JointsDeg,
    tag: MotionTag,
    sent_at: Instant,
    planned: Duration,
    /// A wait has finished (successfully or not): dropping no longer cancels.
    finished: AtomicBool,
}

impl MoveInner {
    fn still_current(&self) -> Result<(), ClientError> {
        let shared = &self.link.shared;
        if shared.current_epoch() != self.tag.epoch {
            return Err(Cancellation::Cancelled.into());
        }
        if shared.last_motion.load(Ordering::Relaxed) != self.tag.id {
            return Err(Cancellation::Superseded.into());
        }
        Ok(())
    }
}

impl Drop for MoveInner {
    fn drop(&mut self) {
        if !self.finished.load(Ordering::Relaxed)
            && self.still_current().is_ok()
            && !self.link.shared.is_dead()
        {
            self.link.halt_detached();
        }
    }
}

impl MoveHandle {
    pub(crate) fn new(
        link: Link,
        model: RobotModel,
        from: JointsDeg,
        target: JointsDeg,
        tag: MotionTag,
        sent_at: Instant,
        speed_percent: f64,
    ) -> MoveHandle {
        let plan = JointMove::plan(&model, from, target, speed_percent / 100.0);
        MoveHandle {
            inner: Arc::new(MoveInner {
                link,
                from,
                target,
                tag,
                sent_at,
                planned: Duration::from_secs_f64(plan.duration_s().clamp(0.0, 1e6)),
                finished: AtomicBool::new(false),
            }),
        }
    }

    /// The target, degrees.
    pub fn target(&self) -> JointsDeg {
        self.inner.target
    }

    /// The joints when the move was sent.
    pub fn start(&self) -> JointsDeg {
        self.inner.from
    }

    /// The move's duration as planned with the robot model at the assumed speed.
    pub fn planned_duration(&self) -> Duration {
        self.inner.planned
    }

    /// Progress from the latest status (for a progress bar); `None` once the session is gone.
    pub fn progress(&self) -> Option<MoveProgress> {
        if self.inner.link.shared.is_dead() {
            return None;
        }
        Some(self.progress_of(&self.inner.link.latest()))
    }

    fn progress_of(&self, s: &StatusSnapshot) -> MoveProgress {
        let target = self.inner.target;
        let remaining = target.max_abs_diff(&s.status.joints);
        let total = target.max_abs_diff(&self.inner.from);
        let fraction = if total > 0.0 {
            (1.0 - remaining / total).clamp(0.0, 1.0)
        } else {
            1.0
        };
        MoveProgress {
            remaining_deg: remaining,
            total_deg: total,
            fraction,
            joints: s.status.joints,
            age: s.age(),
            held: only_held(&blockers(&s.status, true)),
        }
    }

    /// Every new status (progress can be computed from each).
    pub fn subscribe(&self) -> watch::Receiver<StatusSnapshot> {
        self.inner.link.status.clone()
    }

    /// Cancels the move for sure (commands 5 then 2, as [`Robot::cancel`](crate::Robot::cancel)):
    /// the robot brakes to a stop and the motion program ends; start it again to move. Only
    /// while the move is the current motion: after a newer motion superseded it, or a cancel
    /// or stop, it does nothing (it must not stop the newer motion).
    pub async fn cancel(&self) -> Result<(), ClientError> {
        if self.inner.still_current().is_err() {
            return Ok(());
        }
        self.inner.link.halt().await.map(|_| ())
    }

    /// Waits until the robot is at the target (see [`Completion`]). Fails — and cancels the
    /// move for sure (commands 5 then 2), so that it cannot resume later — when the controller
    /// reports an error, TEACH, the lock, power off or the program stopped, on timeout, and when
    /// `completion` is invalid ([`Completion::validate`], `ClientError::Config`). HOLD fails
    /// it the same way unless [`Completion::hold_timeout`] is set, in which case the wait
    /// follows the controller: paused in HOLD, going on after RUN. Fails without sending
    /// anything when the move was cancelled or superseded, or the link is lost.
    pub async fn wait(&self, completion: Completion) -> Result<MoveReport, ClientError> {
        let r = self.wait_inner(completion).await;
        self.inner.finished.store(true, Ordering::Relaxed);
        r
    }

    async fn wait_inner(&self, completion: Completion) -> Result<MoveReport, ClientError> {
        let inner = &*self.inner;
        if let Err(e) = completion.validate() {
            // The caller cannot wait for this move: do not leave it running unobserved.
            if inner.still_current().is_ok() {
                self.abort().await;
            }
            return Err(e);
        }
        let timeout = completion
            .timeout
            .unwrap_or_else(|| inner.planned.mul_f64(1.5) + Duration::from_secs(3))
            .min(LONGEST_WAIT);
        let mut deadline = inner
            .sent_at
            .checked_add(timeout)
            .unwrap_or_else(|| Instant::now() + LONGEST_WAIT);
        let mut rx = inner.link.status.clone();
        let mut epoch = inner.link.shared.epoch.subscribe();
        let mut inside_since: Option<Instant> = None;
        let mut held_since: Option<Instant> = None;
        loop {
            inner.still_current()?;
            let s = rx.borrow_and_update().clone();
            let b = blockers(&s.status, true);
            let held = completion.hold_timeout.is_some() && only_held(&b);
            if !b.is_empty() && !held {
                self.abort().await;
                return Err(ClientError::Aborted {
                    during: "joint move",
                    blockers: b,
                });
            }
            match (held, held_since) {
                (true, None) => held_since = Some(s.received_at),
                (false, Some(since)) => {
                    // The time in HOLD does not count against the move's timeout.
                    deadline += s.received_at.saturating_duration_since(since);
                    held_since = None;
                }
                _ => {}
            }
            let remaining = inner.target.max_abs_diff(&s.status.joints);
            if !held && remaining <= completion.tolerance_deg {
                let since = *inside_since.get_or_insert(s.received_at);
                if s.received_at.duration_since(since) >= completion.settle {
                    return Ok(MoveReport {
                        final_joints: s.status.joints,
                        error_deg: remaining,
                        elapsed: s.received_at.duration_since(inner.sent_at),
                    });
                }
            } else {
                inside_since = None;
            }
            let wake = match (held_since, completion.hold_timeout) {
                (Some(since), Some(limit)) => since + limit,
                _ => deadline,
            };
            tokio::select! {
                r = rx.changed() => if r.is_err() { return Err(inner.link.shared.death()) },
                _ = epoch.changed() => {}
                _ = tokio::time::sleep_until(wake) => {
                    inner.still_current()?;
                    self.abort().await;
                    if let Some(since) = held_since {
                        return Err(ClientError::HoldTimeout {
                            during: "joint move",
                            waited: since.elapsed(),
                        });
                    }
                    return Err(ClientError::MoveTimeout {
                        timeout,
                        remaining_deg: remaining,
                    });
                }
            }
        }
    }

    /// Best-effort cancel after a failure (the failure is what gets reported).
    async fn abort(&self) {
        if let Err(e) = self.cancel().await {
            tracing::warn!(error = %e, "could not send the cancel after a failed move");
        }
    }
}
