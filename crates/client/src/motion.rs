//! Joint moves in progress: waiting for completion, progress, cancellation.

use std::sync::atomic::Ordering;
use std::time::Duration;

use fs020n_kin::{JointMove, RobotModel};
use fs020n_proto::JointsDeg;
use tokio::sync::watch;
use tokio::time::Instant;

use crate::error::ClientError;
use crate::safety::blockers;
use crate::session::{Link, MotionTag, StatusSnapshot};

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
    /// as one day.
    pub timeout: Option<Duration>,
}

impl Completion {
    /// Checks the values: `tolerance_deg` finite and above 0, `settle` at most one day.
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
        Ok(())
    }
}

impl Default for Completion {
    fn default() -> Self {
        Completion {
            tolerance_deg: 0.1,
            settle: Duration::from_millis(100),
            timeout: None,
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

/// A joint move that was sent. Dropping the handle does not stop the move (it is a bounded
/// motion to a checked target); [`cancel`](Self::cancel) does.
#[derive(Debug, Clone)]
pub struct MoveHandle {
    link: Link,
    from: JointsDeg,
    target: JointsDeg,
    tag: MotionTag,
    sent_at: Instant,
    planned: Duration,
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
            link,
            from,
            target,
            tag,
            sent_at,
            planned: Duration::from_secs_f64(plan.duration_s().clamp(0.0, 1e6)),
        }
    }

    /// The target, degrees.
    pub fn target(&self) -> JointsDeg {
        self.target
    }

    /// The joints when the move was sent.
    pub fn start(&self) -> JointsDeg {
        self.from
    }

    /// The move's duration as planned with the robot model at the assumed speed.
    pub fn planned_duration(&self) -> Duration {
        self.planned
    }

    /// Progress from the latest status (for a progress bar); `None` once the session is gone.
    pub fn progress(&self) -> Option<MoveProgress> {
        if self.link.shared.is_dead() {
            return None;
        }
        self.link.latest().map(|s| self.progress_of(&s))
    }

    fn progress_of(&self, s: &StatusSnapshot) -> MoveProgress {
        let remaining = self.target.max_abs_diff(&s.status.joints);
        let total = self.target.max_abs_diff(&self.from);
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
        }
    }

    /// Every new status (progress can be computed from each).
    pub fn subscribe(&self) -> watch::Receiver<Option<StatusSnapshot>> {
        self.link.status.clone()
    }

    /// Cancels the move for sure (commands 5 then 2, as [`Robot::cancel`](crate::Robot::cancel)):
    /// the robot brakes to a stop and the motion program ends; start it again to move.
    pub async fn cancel(&self) -> Result<(), ClientError> {
        self.link.halt().await.map(|_| ())
    }

    fn still_current(&self) -> Result<(), ClientError> {
        let shared = &self.link.shared;
        if shared.current_epoch() != self.tag.epoch {
            return Err(ClientError::Cancelled(
                "the move was cancelled (cancel or stop requested)",
            ));
        }
        if shared.last_motion.load(Ordering::Relaxed) != self.tag.id {
            return Err(ClientError::Cancelled(
                "the move was superseded by a newer motion command",
            ));
        }
        Ok(())
    }

    /// Waits until the robot is at the target (see [`Completion`]). Fails — and cancels the
    /// move for sure (commands 5 then 2), so that it cannot resume later (e.g. when HOLD is
    /// switched back to RUN) — when the controller reports an error, HOLD, TEACH, the lock, power off or the
    /// program stopped, on timeout, and when `completion` is invalid
    /// ([`Completion::validate`], `ClientError::Config`). Fails without sending anything when
    /// the move was cancelled or superseded, or the link is lost.
    pub async fn wait(&self, completion: Completion) -> Result<MoveReport, ClientError> {
        if let Err(e) = completion.validate() {
            // The caller cannot wait for this move: do not leave it running unobserved.
            if self.still_current().is_ok() {
                self.abort().await;
            }
            return Err(e);
        }
        let timeout = completion
            .timeout
            .unwrap_or_else(|| self.planned.mul_f64(1.5) + Duration::from_secs(3))
            .min(LONGEST_WAIT);
        let deadline = self
            .sent_at
            .checked_add(timeout)
            .unwrap_or_else(|| Instant::now() + LONGEST_WAIT);
        let mut rx = self.link.status.clone();
        let mut epoch = self.link.shared.epoch.subscribe();
        let mut inside_since: Option<Instant> = None;
        let mut last = None;
        loop {
            self.still_current()?;
            let snap = rx.borrow_and_update().clone();
            if let Some(s) = snap {
                let b = blockers(&s.status, true);
                if !b.is_empty() {
                    self.abort().await;
                    return Err(ClientError::Aborted {
                        during: "joint move",
                        blockers: b,
                    });
                }
                let remaining = self.target.max_abs_diff(&s.status.joints);
                if remaining <= completion.tolerance_deg {
                    let since = *inside_since.get_or_insert(s.received_at);
                    if s.received_at.duration_since(since) >= completion.settle {
                        return Ok(MoveReport {
                            final_joints: s.status.joints,
                            error_deg: remaining,
                            elapsed: s.received_at.duration_since(self.sent_at),
                        });
                    }
                } else {
                    inside_since = None;
                }
                last = Some(remaining);
            }
            tokio::select! {
                r = rx.changed() => if r.is_err() { return Err(self.link.shared.death()) },
                _ = epoch.changed() => {}
                _ = tokio::time::sleep_until(deadline) => {
                    self.still_current()?;
                    self.abort().await;
                    return Err(ClientError::MoveTimeout {
                        timeout,
                        remaining_deg: last.unwrap_or(f64::NAN),
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
