//! # fs020n-arci
//!
//! [`arci::JointTrajectoryClient`] for the Kawasaki FS020N, over the fs020n client library, so
//! that openrr's tools (teleop, planners, `openrr-apps`) can drive the arm.
//!
//! * Joints are `joint_1` … `joint_6` (configurable), positions in radians.
//! * [`send_joint_positions`](arci::JointTrajectoryClient::send_joint_positions) moves from the
//!   current position to the target in the given time; [`send_joint_trajectory`](
//!   arci::JointTrajectoryClient::send_joint_trajectory) follows the points (the current
//!   position is prepended at time 0 when the first point is later). Both stream with
//!   command 7 (or command 6 waypoints, [`StreamOptions`]).
//! * Every trajectory passes the client library's checks **before** the call returns: a target
//!   outside a joint range is `arci::Error::OutOfLimit`, a too fast or jerky trajectory
//!   `arci::Error::Other` with the reason; nothing is sent then.
//! * The returned `WaitFuture` ends when the robot is at the last point (within
//!   `end_tolerance_deg`); dropping it does not stop the motion (as arci asks).
//! * **No command is dropped silently.** One trajectory runs at a time; a call while one runs
//!   is queued, newest target wins (as the servo of the client library coalesces its samples,
//!   and as openrr's teleop expects when it sends a target every cycle without waiting): when
//!   the running trajectory ends, the newest queued one starts from where the arm is, checked
//!   again from there. A queued command replaced by a newer one ends its `WaitFuture` with
//!   `arci::Error::Canceled` ("superseded"); an error found after the call returned (the
//!   session busy with another client's motion, a check from the new start, a fault) ends its
//!   `WaitFuture` with the error and, when that future was dropped, is logged (`tracing`
//!   warning) instead of vanishing.
//!
//! The client needs a tokio runtime (it spawns the stream's waiting task on it) and a robot
//! with the program running (`Robot::start`). Example: `examples/emulator.rs`.
#![forbid(unsafe_code)]
#![warn(missing_docs)]

use std::sync::{Arc, Mutex};
use std::time::Duration;

use arci::{Error, JointTrajectoryClient, TrajectoryPoint as ArciPoint, WaitFuture};
use fs020n_client::{
    ClientError, ErrorKind, Robot, StreamOptions, StreamOutcome, Trajectory, TrajectoryError,
    TrajectoryPoint,
};
use fs020n_proto::{JointsDeg, JOINT_COUNT};
use tokio::sync::oneshot;

/// A command waiting to run: its points and where its caller waits for the end.
struct Job {
    points: Vec<TrajectoryPoint>,
    done: oneshot::Sender<Result<(), Error>>,
}

/// The commands of one client: whether a trajectory runs, and the newest one waiting.
#[derive(Default)]
struct Queue {
    running: bool,
    pending: Option<Job>,
}

fn lock(q: &Mutex<Queue>) -> std::sync::MutexGuard<'_, Queue> {
    q.lock().unwrap_or_else(|p| p.into_inner())
}

/// An FS020N as an [`arci::JointTrajectoryClient`].
pub struct Fs020nClient {
    robot: Arc<Robot>,
    joint_names: Vec<String>,
    options: StreamOptions,
    runtime: tokio::runtime::Handle,
    queue: Arc<Mutex<Queue>>,
}

impl std::fmt::Debug for Fs020nClient {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Fs020nClient")
            .field("robot", &self.robot)
            .field("joint_names", &self.joint_names)
            .finish()
    }
}

impl Fs020nClient {
    /// A client on `robot` with joints `joint_1` … `joint_6` and the default stream options
    /// (command 7 at 50 Hz). Call it inside a tokio runtime.
    pub fn new(robot: Arc<Robot>) -> Result<Fs020nClient, Error> {
        let runtime = tokio::runtime::Handle::try_current().map_err(|_| Error::Uninitialized {
            message: "Fs020nClient::new must be called inside a tokio runtime".into(),
        })?;
        Ok(Fs020nClient {
            robot,
            joint_names: (1..=JOINT_COUNT).map(|i| format!("joint_{i}")).collect(),
            options: StreamOptions::default(),
            runtime,
            queue: Arc::default(),
        })
    }

    /// Other joint names (six, JT1 first).
    pub fn with_joint_names(mut self, names: Vec<String>) -> Result<Fs020nClient, Error> {
        if names.len() != JOINT_COUNT {
            return Err(Error::LengthMismatch {
                model: JOINT_COUNT,
                input: names.len(),
            });
        }
        self.joint_names = names;
        Ok(self)
    }

    /// Other stream options (mode, period, step bound, tolerances).
    pub fn with_stream_options(mut self, options: StreamOptions) -> Fs020nClient {
        self.options = options;
        self
    }

    /// The robot session.
    pub fn robot(&self) -> &Arc<Robot> {
        &self.robot
    }

    fn current_deg(&self) -> Result<JointsDeg, Error> {
        if let Some(e) = self.robot.link_error() {
            return Err(Error::Connection {
                message: e.to_string(),
            });
        }
        Ok(self.robot.status().status.joints)
    }

    fn to_deg(&self, values: &[f64], what: &str) -> Result<JointsDeg, Error> {
        if values.len() != JOINT_COUNT {
            return Err(Error::LengthMismatch {
                model: JOINT_COUNT,
                input: values.len(),
            });
        }
        let mut out = [0.0; JOINT_COUNT];
        for (j, v) in values.iter().enumerate() {
            if !v.is_finite() {
                return Err(Error::Other(anyhow::anyhow!(
                    "{what} of {} is not a finite number; refusing to send it",
                    self.joint_names[j]
                )));
            }
            out[j] = v.to_degrees();
        }
        Ok(JointsDeg::new(out))
    }

    /// Checks the trajectory (ranges, speeds, steps, command 7's extrapolation) from the
    /// current position before anything is sent, then runs it — or, while one runs, queues it
    /// in place of any older queued one; the future waits for its end.
    fn start(&self, points: Vec<TrajectoryPoint>) -> Result<WaitFuture, Error> {
        let current = self.current_deg()?;
        let names = self.joint_names.clone();
        plan(&self.robot, &self.options, current, points.clone(), &names)?;
        let (done, wait) = oneshot::channel();
        let job = Job { points, done };
        let mut queue = lock(&self.queue);
        if queue.running {
            if let Some(old) = queue.pending.replace(job) {
                finish(
                    old.done,
                    Err(Error::Canceled {
                        message:
                            "superseded by a newer target before it started (newest target wins)"
                                .into(),
                    }),
                );
            }
        } else {
            queue.running = true;
            let runner = Runner {
                robot: self.robot.clone(),
                options: self.options,
                names: names.clone(),
                queue: self.queue.clone(),
            };
            self.runtime.spawn(runner.run(job));
        }
        drop(queue);
        Ok(WaitFuture::new(async move {
            wait.await.unwrap_or_else(|_| {
                Err(Error::Other(anyhow::anyhow!(
                    "the trajectory's task ended without a result (runtime shut down)"
                )))
            })
        }))
    }
}

/// The trajectory of `points` from `current`: the current position prepended at time 0 when
/// the first point is later, and every check of the stream run.
fn plan(
    robot: &Robot,
    options: &StreamOptions,
    current: JointsDeg,
    mut points: Vec<TrajectoryPoint>,
    names: &[String],
) -> Result<Trajectory, Error> {
    if points.first().is_some_and(|p| p.time_s > 0.0) {
        points.insert(0, TrajectoryPoint::new(0.0, current));
    }
    let trajectory = Trajectory::new(points).map_err(|e| refusal(e, names))?;
    options
        .validate(robot.model(), &trajectory)
        .map_err(|e| refusal(e, names))?;
    Ok(trajectory)
}

fn refusal(e: TrajectoryError, names: &[String]) -> Error {
    if let TrajectoryError::OutOfRange { limit, .. } = &e {
        let j = limit.joint.saturating_sub(1).min(JOINT_COUNT - 1);
        return Error::OutOfLimit {
            name: names.get(j).cloned().unwrap_or_default(),
            position: limit.value_deg.to_radians(),
            limit: limit.min_deg.to_radians()..=limit.max_deg.to_radians(),
        };
    }
    Error::Other(anyhow::anyhow!("trajectory refused before sending: {e}"))
}

/// Gives a command its end; when its caller dropped the `WaitFuture`, an error is logged
/// rather than lost.
fn finish(done: oneshot::Sender<Result<(), Error>>, result: Result<(), Error>) {
    if let Err(Err(e)) = done.send(result) {
        tracing::warn!("an arci command whose WaitFuture was dropped failed: {e}");
    }
}

/// Runs queued trajectories one after the other until none is left.
struct Runner {
    robot: Arc<Robot>,
    options: StreamOptions,
    names: Vec<String>,
    queue: Arc<Mutex<Queue>>,
}

impl Runner {
    async fn run(self, first: Job) {
        let mut job = first;
        loop {
            let result = self.follow(job.points).await;
            finish(job.done, result);
            let next = {
                let mut queue = lock(&self.queue);
                let next = queue.pending.take();
                queue.running = next.is_some();
                next
            };
            match next {
                Some(j) => job = j,
                None => return,
            }
        }
    }

    async fn follow(&self, points: Vec<TrajectoryPoint>) -> Result<(), Error> {
        let current = match self.robot.link_error() {
            Some(e) => {
                return Err(Error::Connection {
                    message: e.to_string(),
                })
            }
            None => self.robot.status().status.joints,
        };
        let trajectory = plan(&self.robot, &self.options, current, points, &self.names)?;
        let handle = self
            .robot
            .stream(trajectory, self.options)
            .await
            .map_err(|e| client_error(e, &self.names))?;
        let report = handle
            .wait()
            .await
            .map_err(|e| client_error(e, &self.names))?;
        match report.outcome {
            StreamOutcome::Cancelled => Err(Error::Canceled {
                message: "the trajectory was cancelled; the robot braked and the motion program ended (commands 5 and 2)".into(),
            }),
            StreamOutcome::Completed if report.settled => Ok(()),
            StreamOutcome::Completed => Err(Error::Other(anyhow::anyhow!(
                "the robot ended {:.3} deg from the last point (more than the stream's end \
                 tolerance); check the monitor speed (100 % for command 7)",
                report.final_error_deg
            ))),
        }
    }
}

/// The arci error for a client error: one mapping, from the client's classification
/// ([`ClientError::kind`]). A lost or refused connection is `Connection`, a cancelled or
/// superseded motion `Canceled`, a joint outside its range `OutOfLimit` (naming the joint);
/// every other refusal, a blocked robot, a stopped motion or a timeout is `Other` with the
/// client's text and its remedy.
fn client_error(e: ClientError, names: &[String]) -> Error {
    match (e.kind(), e) {
        (ErrorKind::Connect | ErrorKind::LinkLost, e) => Error::Connection {
            message: e.to_string(),
        },
        (ErrorKind::Cancelled, e) => Error::Canceled {
            message: e.to_string(),
        },
        (ErrorKind::Refused, ClientError::Limit(limit)) => {
            let j = limit.joint.saturating_sub(1).min(JOINT_COUNT - 1);
            Error::OutOfLimit {
                name: names.get(j).cloned().unwrap_or_default(),
                position: limit.value_deg.to_radians(),
                limit: limit.min_deg.to_radians()..=limit.max_deg.to_radians(),
            }
        }
        (_, other) => Error::Other(anyhow::Error::new(other)),
    }
}

impl JointTrajectoryClient for Fs020nClient {
    fn joint_names(&self) -> Vec<String> {
        self.joint_names.clone()
    }

    fn current_joint_positions(&self) -> Result<Vec<f64>, Error> {
        Ok(self.current_deg()?.iter().map(|d| d.to_radians()).collect())
    }

    fn send_joint_positions(
        &self,
        positions: Vec<f64>,
        duration: Duration,
    ) -> Result<WaitFuture, Error> {
        let target = self.to_deg(&positions, "position")?;
        let t = duration.as_secs_f64();
        if t <= 0.0 {
            return Err(Error::Other(anyhow::anyhow!(
                "a duration of 0 asks for an infinite speed; give the time the move may take"
            )));
        }
        self.start(vec![TrajectoryPoint::new(t, target)])
    }

    fn send_joint_trajectory(&self, trajectory: Vec<ArciPoint>) -> Result<WaitFuture, Error> {
        let mut points = Vec::with_capacity(trajectory.len());
        for p in &trajectory {
            let position = self.to_deg(&p.positions, "position")?;
            let velocity = match &p.velocities {
                Some(v) => Some(self.to_deg(v, "velocity")?),
                None => None,
            };
            points.push(TrajectoryPoint {
                time_s: p.time_from_start.as_secs_f64(),
                position,
                velocity,
                acceleration: None,
            });
        }
        if points.is_empty() {
            return Err(Error::Other(anyhow::anyhow!(
                "the trajectory has no points; give at least one"
            )));
        }
        self.start(points)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use fs020n_client::{Blocker, Cancellation};

    fn names() -> Vec<String> {
        (1..=JOINT_COUNT).map(|j| format!("joint_{j}")).collect()
    }

    #[test]
    fn a_lost_link_is_a_connection_error_and_a_cancel_canceled() {
        assert!(matches!(
            client_error(ClientError::Closed, &names()),
            Error::Connection { .. }
        ));
        let e = ClientError::Address {
            target: "robot:10050".into(),
            message: "no such host".into(),
        };
        assert!(matches!(
            client_error(e, &names()),
            Error::Connection { .. }
        ));
        let e = ClientError::Cancelled(Cancellation::NotSent);
        assert!(matches!(client_error(e, &names()), Error::Canceled { .. }));
    }

    #[test]
    fn other_refusals_and_stops_keep_the_clients_text() {
        for e in [
            ClientError::Speed { percent: 0.0 },
            ClientError::Config("period 0 s".into()),
            ClientError::Blocked(vec![Blocker::ProgramNotRunning]),
        ] {
            let text = e.to_string();
            let Error::Other(inner) = client_error(e, &names()) else {
                panic!("Other expected for {text}");
            };
            assert_eq!(inner.to_string(), text);
        }
    }
}

/// The README's examples, compiled as doctests.
#[cfg(doctest)]
#[doc = include_str!("../README.md")]
struct ReadmeDoctests;
