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
//!   `end_tolerance_deg`); dropping it does not stop the motion (as arci asks). One trajectory
//!   at a time: a second call while one runs fails with the reason (wait for the first, or
//!   cancel it with `Robot::cancel`).
//!
//! The client needs a tokio runtime (it spawns the stream's waiting task on it) and a robot
//! with the program running (`Robot::start`). Example: `examples/emulator.rs`.
#![forbid(unsafe_code)]
#![warn(missing_docs)]

use std::sync::Arc;
use std::time::Duration;

use arci::{Error, JointTrajectoryClient, TrajectoryPoint as ArciPoint, WaitFuture};
use fs020n_client::{
    ClientError, Robot, StreamOptions, StreamOutcome, Trajectory, TrajectoryError, TrajectoryPoint,
};
use fs020n_proto::{JointsDeg, JOINT_COUNT};

/// An FS020N as an [`arci::JointTrajectoryClient`].
pub struct Fs020nClient {
    robot: Arc<Robot>,
    joint_names: Vec<String>,
    options: StreamOptions,
    runtime: tokio::runtime::Handle,
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

    /// Checks the trajectory (ranges, speeds, steps, command 7's extrapolation) and its start
    /// before anything is sent, then streams it from a task; the future waits for its end.
    fn start(&self, mut points: Vec<TrajectoryPoint>) -> Result<WaitFuture, Error> {
        let current = self.current_deg()?;
        if points.first().is_some_and(|p| p.time_s > 0.0) {
            points.insert(0, TrajectoryPoint::new(0.0, current));
        }
        let trajectory = Trajectory::new(points).map_err(|e| self.refusal(e))?;
        self.options
            .validate(self.robot.model(), &trajectory)
            .map_err(|e| self.refusal(e))?;
        let robot = self.robot.clone();
        let options = self.options;
        let task = self.runtime.spawn(async move {
            let handle = robot.stream(trajectory, options).await?;
            handle.wait().await
        });
        let names = self.joint_names.clone();
        Ok(WaitFuture::new(async move {
            let report = task
                .await
                .map_err(|e| Error::Other(anyhow::anyhow!("the stream task ended: {e}")))?
                .map_err(|e| client_error(e, &names))?;
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
        }))
    }

    fn refusal(&self, e: TrajectoryError) -> Error {
        if let TrajectoryError::OutOfRange { limit, .. } = &e {
            let j = limit.joint.saturating_sub(1).min(JOINT_COUNT - 1);
            return Error::OutOfLimit {
                name: self.joint_names[j].clone(),
                position: limit.value_deg.to_radians(),
                limit: limit.min_deg.to_radians()..=limit.max_deg.to_radians(),
            };
        }
        Error::Other(anyhow::anyhow!("trajectory refused before sending: {e}"))
    }
}

fn client_error(e: ClientError, names: &[String]) -> Error {
    match e {
        ClientError::LinkLost(_) | ClientError::Closed | ClientError::Connect { .. } => {
            Error::Connection {
                message: e.to_string(),
            }
        }
        ClientError::Cancelled(m) => Error::Canceled {
            message: m.to_string(),
        },
        ClientError::Limit(limit) => {
            let j = limit.joint.saturating_sub(1).min(JOINT_COUNT - 1);
            Error::OutOfLimit {
                name: names.get(j).cloned().unwrap_or_default(),
                position: limit.value_deg.to_radians(),
                limit: limit.min_deg.to_radians()..=limit.max_deg.to_radians(),
            }
        }
        other => Error::Other(anyhow::Error::new(other)),
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

/// The README's examples, compiled as doctests.
#[cfg(doctest)]
#[doc = include_str!("../README.md")]
struct ReadmeDoctests;
