//! `fs020n.Robot` and its handles: the Rust client with the GIL released while it waits.

use std::future::Future;
use std::path::PathBuf;
use std::sync::{Arc, Mutex, MutexGuard, RwLock};
use std::time::{Duration, Instant};

use fs020n_client::{
    self as client, ClientConfig, ClientError, Completion, LagCompensation, RecordFormat,
    Recording, ServoOptions, ServoSample, StreamMode, StreamOptions, StreamOutcome, TargetPacing,
    Trajectory, TrajectoryPoint, WatchdogAction,
};
use fs020n_kin::Xyzoat;
use fs020n_proto::JointsDeg;
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyTuple};
use pyo3::IntoPyObjectExt;

use crate::errors::{base_error, client_error, limit_error, motion_error};
use crate::kin::pose_of;
use crate::{block, numbers, rows, seconds, six, OnInterrupt};

fn lock<T>(m: &Mutex<T>) -> MutexGuard<'_, T> {
    m.lock().unwrap_or_else(|p| p.into_inner())
}

/// A controller status, as one reply reports it.
#[pyclass(module = "fs020n", frozen, get_all)]
#[derive(Clone, Debug)]
pub struct Status {
    /// The controller error as on the wire (0: none; E1088 is -31088).
    pub error: i32,
    /// The error's name (`"E1088"`), or `None`.
    pub error_name: Option<String>,
    /// The error's message, when known.
    pub error_message: Option<String>,
    /// RUN/HOLD on RUN.
    pub run: bool,
    /// TEACH/REPEAT on REPEAT.
    pub repeat: bool,
    /// TEACH LOCK on.
    pub teach_lock: bool,
    /// Motor power on.
    pub power: bool,
    /// The motion program runs (reply field 7).
    pub program_running: bool,
    /// TIMER(1): seconds since the session was accepted; `None` when it overflowed.
    pub timer: Option<f64>,
    /// JT1..JT6, degrees.
    pub joints: Vec<f64>,
    /// The flange pose (X, Y, Z mm; O, A, T deg) at these joints.
    pub pose: (f64, f64, f64, f64, f64, f64),
    /// Every condition that blocks motion, with its remedy: (what, remedy) pairs.
    pub blockers: Vec<(String, String)>,
    /// Seconds since this status arrived.
    pub age_s: f64,
}

impl Status {
    fn of(s: &fs020n_proto::Status, age: Duration) -> Status {
        let blockers = crate::errors::blocker_pairs(&client::blockers(s, true));
        Status {
            error: s.error.raw(),
            error_name: (!s.error.is_none()).then(|| s.error.to_string()),
            error_message: s.error.message().map(str::to_owned),
            run: s.run,
            repeat: s.repeat,
            teach_lock: s.teach_lock,
            power: s.power,
            program_running: s.task_running,
            timer: s.timer.seconds(),
            joints: s.joints.values().to_vec(),
            pose: pose_of(&s.joints),
            blockers,
            age_s: age.as_secs_f64(),
        }
    }
}

#[pymethods]
impl Status {
    /// `True` when nothing blocks motion (no error, RUN, REPEAT, lock off, power on, program
    /// running).
    #[getter]
    fn ready(&self) -> bool {
        self.blockers.is_empty()
    }

    fn __repr__(&self) -> String {
        format!(
            "Status(error={}, run={}, repeat={}, teach_lock={}, power={}, program_running={}, \
             timer={:?}, joints={:?})",
            self.error_name.as_deref().unwrap_or("none"),
            py_bool(self.run),
            py_bool(self.repeat),
            py_bool(self.teach_lock),
            py_bool(self.power),
            py_bool(self.program_running),
            self.timer,
            self.joints
        )
    }
}

fn py_bool(b: bool) -> &'static str {
    if b {
        "True"
    } else {
        "False"
    }
}

/// How a joint move ended.
#[pyclass(module = "fs020n", frozen, get_all)]
#[derive(Clone, Debug)]
pub struct MoveReport {
    /// `True` when the target was reached; `False` when the move was cancelled or superseded
    /// by a newer motion before (faults raise `MotionError` instead).
    pub reached: bool,
    /// Seconds from sending the move to its end.
    pub duration_s: f64,
    /// Largest per-joint distance to the target at the end, degrees.
    pub error_deg: f64,
    /// The joints at the end, degrees.
    pub final_joints: Vec<f64>,
    /// The target, degrees.
    pub target: Vec<f64>,
}

#[pymethods]
impl MoveReport {
    fn __repr__(&self) -> String {
        format!(
            "MoveReport(reached={}, duration_s={:.3}, error_deg={:.4})",
            py_bool(self.reached),
            self.duration_s,
            self.error_deg
        )
    }
}

/// Figures of a stream.
#[pyclass(module = "fs020n", frozen, get_all)]
#[derive(Clone, Debug)]
pub struct StreamReport {
    /// `"completed"` or `"cancelled"`.
    pub outcome: String,
    /// Samples sent.
    pub samples_sent: u64,
    /// Replies slower than the period.
    pub late_replies: u64,
    /// Cycles that started more than one period late.
    pub underruns: u64,
    /// Largest tracking error (joints in a reply vs the trajectory at its server time), deg.
    pub tracking_error_max_deg: f64,
    /// Root mean square of the tracking errors, degrees.
    pub tracking_error_rms_deg: f64,
    /// Replies the tracking error was computed from.
    pub tracking_samples: u64,
    /// Largest per-joint distance to the last point at the end, degrees.
    pub final_error_deg: f64,
    /// The robot came within the end tolerance of the last point in time.
    pub settled: bool,
    /// Seconds from the first sample to the end.
    pub duration_s: f64,
    /// Mean round trip of the samples, seconds.
    pub rtt_mean_s: f64,
    /// Slowest round trip of the samples, seconds.
    pub rtt_max_s: f64,
    /// The time shift that best aligns the arm with the trajectory, seconds (positive: the
    /// arm is behind); `None` when it could not be estimated.
    pub lag_s: Option<f64>,
    /// The lead command 7 was stamped with at the end, seconds.
    pub lead_s: f64,
}

impl StreamReport {
    fn of(r: &client::StreamReport) -> StreamReport {
        StreamReport {
            outcome: match r.outcome {
                StreamOutcome::Completed => "completed",
                StreamOutcome::Cancelled => "cancelled",
            }
            .into(),
            samples_sent: r.samples_sent,
            late_replies: r.late_replies,
            underruns: r.underruns,
            tracking_error_max_deg: r.tracking_error_max_deg,
            tracking_error_rms_deg: r.tracking_error_rms_deg,
            tracking_samples: r.tracking_samples,
            final_error_deg: r.final_error_deg,
            settled: r.settled,
            duration_s: r.duration.as_secs_f64(),
            rtt_mean_s: r.rtt_mean.as_secs_f64(),
            rtt_max_s: r.rtt_max.as_secs_f64(),
            lag_s: r.lag_s,
            lead_s: r.lead_s,
        }
    }
}

#[pymethods]
impl StreamReport {
    fn __repr__(&self) -> String {
        format!(
            "StreamReport(outcome={:?}, samples_sent={}, tracking_error_max_deg={:.4}, \
             tracking_error_rms_deg={:.4}, final_error_deg={:.4}, settled={})",
            self.outcome,
            self.samples_sent,
            self.tracking_error_max_deg,
            self.tracking_error_rms_deg,
            self.final_error_deg,
            py_bool(self.settled)
        )
    }
}

/// How a servo ended, with its figures.
#[pyclass(module = "fs020n", frozen, get_all)]
#[derive(Debug)]
pub struct ServoReport {
    /// `"stopped"` (servo.stop()), `"cancelled"` (robot.cancel(), stop() or close()) or
    /// `"watchdog"` (no push within the watchdog time).
    pub outcome: String,
    /// The figures, as `Servo.stats()` gives them.
    pub stats: Py<PyDict>,
    /// The joints in the last status, degrees.
    pub final_joints: Option<Vec<f64>>,
    /// Seconds from opening to the end.
    pub duration_s: f64,
}

#[pymethods]
impl ServoReport {
    fn __repr__(&self, py: Python<'_>) -> String {
        let stats = self.stats.bind(py);
        let get = |k: &str| {
            stats
                .get_item(k)
                .ok()
                .flatten()
                .map(|v| v.to_string())
                .unwrap_or_default()
        };
        format!(
            "ServoReport(outcome={:?}, pushes={}, sent={}, coalesced={}, unsent={}, duration_s={:.3})",
            self.outcome,
            get("pushes"),
            get("sent"),
            get("coalesced"),
            get("unsent"),
            self.duration_s
        )
    }
}

fn servo_stats<'py>(py: Python<'py>, s: &client::ServoStats) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    d.set_item("pushes", s.pushes)?;
    d.set_item("refused", s.refused)?;
    d.set_item("sent", s.sent)?;
    d.set_item("coalesced", s.coalesced)?;
    d.set_item("unsent", s.unsent)?;
    d.set_item("push_interval_mean_s", s.push_interval_mean.as_secs_f64())?;
    d.set_item("push_interval_max_s", s.push_interval_max.as_secs_f64())?;
    d.set_item("push_to_send_mean_s", s.push_to_send_mean.as_secs_f64())?;
    d.set_item("push_to_send_max_s", s.push_to_send_max.as_secs_f64())?;
    d.set_item("rtt_mean_s", s.rtt_mean.as_secs_f64())?;
    d.set_item("rtt_max_s", s.rtt_max.as_secs_f64())?;
    d.set_item("tracking_error_max_deg", s.tracking_error_max_deg)?;
    d.set_item("tracking_error_rms_deg", s.tracking_error_rms_deg)?;
    d.set_item("tracking_samples", s.tracking_samples)?;
    Ok(d)
}

/// A connection to an FS020N controller (or an `fs020n.Emulator`).
///
/// ```python
/// with fs020n.Robot("192.168.0.2:10050") as robot:   # close() sends 255
///     robot.preflight()                  # NotReadyError lists every blocker with its remedy
///     robot.set_speed(20)
///     robot.start()
///     robot.move_joints([0, 10, -80, 0, -90, 0])     # waits; returns a MoveReport
/// ```
///
/// Every value is checked before it is sent (`LimitError`); a lost link raises
/// `LinkLostError` and is never recovered silently (`reconnect()` is explicit and resumes
/// nothing). Blocking calls release the GIL; Ctrl-C during one stops the motion (commands 5
/// then 2), closes the session (255) and re-raises `KeyboardInterrupt`. The keep-alive runs in
/// the background whatever Python does.
#[pyclass(module = "fs020n", frozen)]
#[derive(Debug)]
pub struct Robot {
    inner: RwLock<Option<Arc<client::Robot>>>,
    address: String,
}

type PyFuture<T> = std::pin::Pin<Box<dyn Future<Output = Result<T, ClientError>> + Send>>;

impl Robot {
    pub(crate) fn client(&self, py: Python<'_>) -> PyResult<Arc<client::Robot>> {
        self.inner
            .read()
            .unwrap_or_else(|p| p.into_inner())
            .clone()
            .ok_or_else(|| client_error(py, &ClientError::Closed))
    }

    /// Runs a client call with the GIL released; Ctrl-C cancels, closes and re-raises.
    fn call<T: Send + 'static>(
        &self,
        py: Python<'_>,
        f: impl FnOnce(Arc<client::Robot>) -> PyFuture<T>,
    ) -> PyResult<T> {
        let robot = self.client(py)?;
        let interrupt = OnInterrupt::CancelAndClose(robot.clone());
        block(py, f(robot), interrupt)?.map_err(|e| client_error(py, &e))
    }

    fn latest_joints(&self, py: Python<'_>) -> Option<JointsDeg> {
        self.client(py).ok().map(|r| r.status().status.joints)
    }
}

fn completion(
    py: Python<'_>,
    timeout: Option<f64>,
    tolerance: f64,
    settle: f64,
    hold_timeout: Option<f64>,
) -> PyResult<Completion> {
    let c = Completion {
        tolerance_deg: tolerance,
        settle: seconds(py, "settle", settle)?,
        timeout: timeout.map(|t| seconds(py, "timeout", t)).transpose()?,
        hold_timeout: hold_timeout
            .map(|t| seconds(py, "hold_timeout", t))
            .transpose()?,
    };
    c.validate().map_err(|e| client_error(py, &e))?;
    Ok(c)
}

/// `None`/`"online"`, `"off"` or a fixed lead in seconds.
fn lag_compensation_arg(py: Python<'_>, v: Option<&Bound<'_, PyAny>>) -> PyResult<LagCompensation> {
    let bad = || {
        limit_error(
            py,
            "lag_compensation must be \"online\", \"off\" or a lead in seconds from 0 to 0.5",
        )
    };
    let Some(v) = v.filter(|v| !v.is_none()) else {
        return Ok(LagCompensation::default());
    };
    if let Ok(s) = v.extract::<String>() {
        return match s.as_str() {
            "online" => Ok(LagCompensation::default()),
            "off" => Ok(LagCompensation::Off),
            _ => Err(bad()),
        };
    }
    let lead: f64 = v.extract().map_err(|_| bad())?;
    if !(lead.is_finite() && (0.0..=LagCompensation::LIMIT.as_secs_f64()).contains(&lead)) {
        return Err(bad());
    }
    Ok(LagCompensation::Fixed(Duration::from_secs_f64(lead)))
}

fn record_config(
    py: Python<'_>,
    path: Option<PathBuf>,
    format: Option<&str>,
) -> PyResult<Option<Recording>> {
    let Some(path) = path else {
        return Ok(None);
    };
    let format = match format {
        Some("csv") => RecordFormat::Csv,
        Some("jsonl") => RecordFormat::JsonLines,
        Some(other) => {
            return Err(limit_error(
                py,
                &format!("record_format {other:?} must be \"csv\" or \"jsonl\""),
            ))
        }
        None => match path.extension().and_then(|e| e.to_str()) {
            Some("jsonl" | "json" | "ndjson") => RecordFormat::JsonLines,
            _ => RecordFormat::Csv,
        },
    };
    Ok(Some(Recording { path, format }))
}

#[pymethods]
impl Robot {
    /// Connects to `address` (`"host:port"`, or `"host"` for port 10050), retrying across
    /// the controller's listen gaps for `connect_timeout` seconds. `record=path` writes every
    /// request and reply to a CSV file (or JSON lines: `.jsonl`, or `record_format="jsonl"`).
    /// `reply_timeout` (below 2 s) is each reply's deadline; `keepalive_period` the period of
    /// the background status polls.
    #[new]
    #[pyo3(signature = (address, *, connect_timeout=10.0, reply_timeout=1.0, keepalive_period=0.1, record=None, record_format=None))]
    fn new(
        py: Python<'_>,
        address: &str,
        connect_timeout: f64,
        reply_timeout: f64,
        keepalive_period: f64,
        record: Option<PathBuf>,
        record_format: Option<&str>,
    ) -> PyResult<Robot> {
        let config = ClientConfig {
            connect_timeout: seconds(py, "connect_timeout", connect_timeout)?,
            reply_timeout: seconds(py, "reply_timeout", reply_timeout)?,
            keepalive_period: seconds(py, "keepalive_period", keepalive_period)?,
            record: record_config(py, record, record_format)?,
            ..ClientConfig::default()
        };
        config.validate().map_err(|e| client_error(py, &e))?;
        let addr = address.to_owned();
        let robot = block(
            py,
            async move { client::Robot::connect(&addr, config).await },
            OnInterrupt::Nothing,
        )?
        .map_err(|e| client_error(py, &e))?;
        Ok(Robot {
            inner: RwLock::new(Some(Arc::new(robot))),
            address: address.to_owned(),
        })
    }

    /// The address connected to.
    #[getter]
    fn address(&self) -> String {
        self.address.clone()
    }

    /// `True` while the session is open.
    #[getter]
    fn is_connected(&self, py: Python<'_>) -> bool {
        self.client(py).is_ok_and(|r| r.is_connected())
    }

    /// Why the session ended (the client's message), or `None` while it is open.
    #[getter]
    fn link_error(&self, py: Python<'_>) -> Option<String> {
        self.client(py)
            .ok()
            .and_then(|r| r.link_error())
            .map(|e| crate::errors::message(&e))
    }

    /// The status. `fresh=True` (default) asks the controller (one round trip, `0 0 0`,
    /// which changes nothing); `fresh=False` returns the latest reply at once (at most one
    /// keep-alive period old, see `age_s`).
    #[pyo3(signature = (fresh=true))]
    fn status(&self, py: Python<'_>, fresh: bool) -> PyResult<Status> {
        if fresh {
            let s = self.call(py, |r| Box::pin(async move { r.poll().await }))?;
            return Ok(Status::of(&s, Duration::ZERO));
        }
        let r = self.client(py)?;
        if let Some(e) = r.link_error() {
            return Err(client_error(py, &e));
        }
        let s = r.status();
        Ok(Status::of(&s.status, s.age()))
    }

    /// Checks every condition that blocks starting the program or moving; raises
    /// `NotReadyError` whose `blockers` lists each with its remedy.
    fn preflight(&self, py: Python<'_>) -> PyResult<()> {
        self.call(py, |r| Box::pin(async move { r.preflight().await }))
    }

    /// Sets the monitor speed (command 3), 1–100 %. It applies from the next motion.
    fn set_speed(&self, py: Python<'_>, percent: f64) -> PyResult<Status> {
        let s = self.call(py, |r| Box::pin(async move { r.set_speed(percent).await }))?;
        Ok(Status::of(&s, Duration::ZERO))
    }

    /// Starts the motion program (command 1) after a preflight, and waits until the
    /// controller reports it running. Does nothing if it runs already.
    fn start(&self, py: Python<'_>) -> PyResult<()> {
        self.call(py, |r| Box::pin(async move { r.start().await }))
    }

    /// Stops the motion program (command 2): the robot stops at once and the program ends
    /// (`start()` is needed to move again). A running stream or servo ends.
    fn stop(&self, py: Python<'_>) -> PyResult<Status> {
        let s = self.call(py, |r| Box::pin(async move { r.stop_program().await }))?;
        Ok(Status::of(&s, Duration::ZERO))
    }

    /// Cancels the current motion for sure: command 5 (the robot brakes at once), then command
    /// 2 (the program ends, so no motion the controller had already planned runs after the
    /// brake); `start()` again to move. A running stream or servo ends; a waiting move returns
    /// `reached=False`.
    fn cancel(&self, py: Python<'_>) -> PyResult<Status> {
        let s = self.call(py, |r| Box::pin(async move { r.cancel().await }))?;
        Ok(Status::of(&s, Duration::ZERO))
    }

    /// Moves to joint `target` (six angles, degrees; a list, tuple or numpy array) with a
    /// joint move (command 6), checked first (finite, inside the ranges: `LimitError`).
    /// With `wait=True` waits until every joint is within `tolerance` degrees for `settle`
    /// seconds and returns a `MoveReport` (`timeout` seconds, default from the planned
    /// duration); with `wait=False` returns a `Move` at once. HOLD fails the wait at once
    /// (`MotionError`, the move is stopped) unless `hold_timeout` (seconds) is given: then the
    /// wait waits out the pause (the controller resumes the move on RUN) for that long.
    #[pyo3(signature = (target, *, wait=true, timeout=None, tolerance=0.1, settle=0.1, hold_timeout=None))]
    #[allow(clippy::too_many_arguments)]
    fn move_joints(
        slf: &Bound<'_, Self>,
        py: Python<'_>,
        target: &Bound<'_, PyAny>,
        wait: bool,
        timeout: Option<f64>,
        tolerance: f64,
        settle: f64,
        hold_timeout: Option<f64>,
    ) -> PyResult<Py<PyAny>> {
        let q = JointsDeg::new(six(target, "target")?);
        let c = completion(py, timeout, tolerance, settle, hold_timeout)?;
        let sent = Instant::now();
        let handle = slf
            .get()
            .call(py, |r| Box::pin(async move { r.move_joints(q).await }))?;
        Move::start(slf, py, handle, c, sent, wait)
    }

    /// Moves the flange to a pose: X, Y, Z (mm), O, A, T (degrees, AS convention), as six
    /// arguments or one sequence, with a joint move to the inverse-kinematics solution
    /// nearest to the current joints. `wait`, `timeout`, `tolerance`, `settle`,
    /// `hold_timeout` as in `move_joints`.
    ///
    /// ```python
    /// robot.move_pose(850, 0, 1153.5, 0, 180, 0)
    /// ```
    #[pyo3(signature = (*pose, wait=true, timeout=None, tolerance=0.1, settle=0.1, hold_timeout=None))]
    #[allow(clippy::too_many_arguments)]
    fn move_pose(
        slf: &Bound<'_, Self>,
        py: Python<'_>,
        pose: &Bound<'_, PyTuple>,
        wait: bool,
        timeout: Option<f64>,
        tolerance: f64,
        settle: f64,
        hold_timeout: Option<f64>,
    ) -> PyResult<Py<PyAny>> {
        let p = if pose.len() == 1 {
            six(&pose.get_item(0)?, "pose")?
        } else {
            six(pose.as_any(), "pose")?
        };
        let c = completion(py, timeout, tolerance, settle, hold_timeout)?;
        let target = Xyzoat::new(p[0], p[1], p[2], p[3], p[4], p[5]);
        let sent = Instant::now();
        let handle = slf
            .get()
            .call(py, |r| Box::pin(async move { r.move_pose(target).await }))?;
        Move::start(slf, py, handle, c, sent, wait)
    }

    /// Streams a trajectory: `times` (N seconds, increasing from >= 0), `positions` (N x 6
    /// degrees), optionally `velocities` (N x 6 deg/s) and `accelerations` (N x 6 deg/s²);
    /// lists or numpy arrays. `mode="cmd7"` (default) sends command 7 samples stamped on the
    /// estimated controller clock, `mode="cmd6"` joint-move waypoints; `rate` samples per
    /// second. Everything is checked before the first sample (ranges, speeds, the step per
    /// cycle, every target the controller can extrapolate to, the start within
    /// `start_tolerance_deg` of the robot). `lag_compensation` (command 7): `"online"` (the
    /// lead follows the lag estimated from the replies, up to 0.3 s), `"off"`, or a fixed lead
    /// in seconds (0–0.5). `pacing` (command 7): `"held"` (default: points of the trajectory
    /// held 20–80 ms, so the controller's moves do not wait for ACCURACY; docs/CLIENT.md) or
    /// `"extrapolated"` (every sample carries the trajectory's velocity). With `wait=True`
    /// returns a `StreamReport`; with `wait=False` a `Stream` (keep it: dropping it cancels
    /// the stream).
    #[pyo3(signature = (times, positions, velocities=None, accelerations=None, *, mode="cmd7", rate=50.0, lookahead=2.0, max_step_deg=2.0, start_tolerance_deg=1.0, end_tolerance_deg=0.5, end_timeout=3.0, lag_compensation=None, pacing="held", wait=true))]
    #[allow(clippy::too_many_arguments)]
    fn stream(
        slf: &Bound<'_, Self>,
        py: Python<'_>,
        times: &Bound<'_, PyAny>,
        positions: &Bound<'_, PyAny>,
        velocities: Option<&Bound<'_, PyAny>>,
        accelerations: Option<&Bound<'_, PyAny>>,
        mode: &str,
        rate: f64,
        lookahead: f64,
        max_step_deg: f64,
        start_tolerance_deg: f64,
        end_tolerance_deg: f64,
        end_timeout: f64,
        lag_compensation: Option<&Bound<'_, PyAny>>,
        pacing: &str,
        wait: bool,
    ) -> PyResult<Py<PyAny>> {
        let lag_compensation = lag_compensation_arg(py, lag_compensation)?;
        let target_pacing = match pacing {
            "held" => TargetPacing::Held,
            "extrapolated" => TargetPacing::Extrapolated,
            other => {
                return Err(PyValueError::new_err(format!(
                    "pacing {other:?}: \"held\" or \"extrapolated\""
                )))
            }
        };
        let t = numbers(times, "times")?;
        let q = rows(positions, "positions")?;
        let v = velocities.map(|v| rows(v, "velocities")).transpose()?;
        let a = accelerations
            .map(|a| rows(a, "accelerations"))
            .transpose()?;
        for (name, n) in [
            ("positions", Some(q.len())),
            ("velocities", v.as_ref().map(Vec::len)),
            ("accelerations", a.as_ref().map(Vec::len)),
        ] {
            if let Some(n) = n {
                if n != t.len() {
                    return Err(limit_error(
                        py,
                        &format!("{name} has {n} rows but times has {}", t.len()),
                    ));
                }
            }
        }
        let points = (0..t.len())
            .map(|i| TrajectoryPoint {
                time_s: t[i],
                position: JointsDeg::new(q[i]),
                velocity: v.as_ref().map(|v| JointsDeg::new(v[i])),
                acceleration: a.as_ref().map(|a| JointsDeg::new(a[i])),
            })
            .collect();
        let trajectory =
            Trajectory::new(points).map_err(|e| client_error(py, &ClientError::Trajectory(e)))?;
        let mode = match mode {
            "cmd7" => StreamMode::Extrapolated {
                lookahead_passes: lookahead,
            },
            "cmd6" => StreamMode::Waypoints,
            other => {
                return Err(limit_error(
                    py,
                    &format!("mode {other:?} must be \"cmd7\" or \"cmd6\""),
                ))
            }
        };
        if !(rate.is_finite() && (1.0..=1000.0).contains(&rate)) {
            return Err(limit_error(
                py,
                &format!("rate {rate} must be from 1 to 1000 samples per second"),
            ));
        }
        let period = Duration::from_secs_f64(1.0 / rate);
        let options = StreamOptions {
            mode,
            period,
            max_step_deg,
            start_tolerance_deg,
            end_tolerance_deg,
            end_timeout: seconds(py, "end_timeout", end_timeout)?,
            // At least the default, and always two periods (a slow rate needs a longer gap).
            max_gap: (period * 5 / 2)
                .max(StreamOptions::default().max_gap)
                .min(Duration::from_millis(500)),
            lag_compensation,
            target_pacing,
            ..StreamOptions::default()
        };
        let handle = slf.get().call(py, |r| {
            Box::pin(async move { r.stream(trajectory, options).await })
        })?;
        let stream = Stream {
            handle,
            report: Mutex::new(None),
            robot: slf.clone().unbind(),
        };
        if wait {
            stream.wait(py)?.into_py_any(py)
        } else {
            Py::new(py, stream)?.into_py_any(py)
        }
    }

    /// Opens an online servo: push samples with `Servo.push(q, qd=None, qdd=None)` at your
    /// own rate (each is checked at once and sent as command 7, stamped with the controller
    /// time of the push; faster pushes are coalesced, the newest wins). When no push arrives
    /// for `watchdog` seconds (0.01–0.5, default 0.2) after the first, the watchdog stops the
    /// arm for sure (`on_watchdog="stop_program"`, commands 5 then 2: the arm surely stays
    /// still; call `start()` again) or only brakes (`"brake"`, command 5: the program keeps running, but a
    /// motion it had already planned may still run). `lookahead` is command 7's ARG2;
    /// `max_step_deg` bounds a jump between pushes beyond the joint's top speed;
    /// `start_tolerance_deg` the first sample's distance from the robot.
    #[pyo3(signature = (*, lookahead=2.0, watchdog=0.2, on_watchdog="stop_program", max_step_deg=2.0, start_tolerance_deg=1.0, estimate_velocity=true))]
    #[allow(clippy::too_many_arguments)]
    fn servo(
        slf: &Bound<'_, Self>,
        py: Python<'_>,
        lookahead: f64,
        watchdog: f64,
        on_watchdog: &str,
        max_step_deg: f64,
        start_tolerance_deg: f64,
        estimate_velocity: bool,
    ) -> PyResult<Servo> {
        let on_watchdog = match on_watchdog {
            "stop_program" => WatchdogAction::StopProgram,
            "brake" => WatchdogAction::Brake,
            other => {
                return Err(limit_error(
                    py,
                    &format!("on_watchdog {other:?} must be \"stop_program\" or \"brake\""),
                ))
            }
        };
        let options = ServoOptions {
            lookahead_passes: lookahead,
            watchdog: seconds(py, "watchdog", watchdog)?,
            on_watchdog,
            max_step_deg,
            start_tolerance_deg,
            estimate_velocity,
        };
        let handle = slf
            .get()
            .call(py, |r| Box::pin(async move { r.servo(options).await }))?;
        Ok(Servo {
            handle: Mutex::new(Some(handle)),
            report: Mutex::new(None),
            robot: slf.clone().unbind(),
        })
    }

    /// Sends a request as typed (e.g. `"0 0 0"`) and returns the reply text. Motion commands
    /// (1040 6 / 1040 7) are refused unless `allow_motion=True`, and then checked like typed
    /// ones.
    #[pyo3(signature = (text, *, allow_motion=false))]
    fn send_raw(&self, py: Python<'_>, text: String, allow_motion: bool) -> PyResult<String> {
        let frame = self.call(py, move |r| {
            Box::pin(async move { r.send_raw(&text, allow_motion).await })
        })?;
        Ok(frame.text)
    }

    /// The client's statistics (kept across reconnects) as a dict: request, reply, keep-alive,
    /// late-reply, refusal and stream counters, and round trips (`rtt`: count, min_s, mean_s,
    /// p99_s, max_s).
    fn stats<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let s = self.client(py)?.stats();
        let d = PyDict::new(py);
        d.set_item("requests", s.requests)?;
        d.set_item("replies", s.replies)?;
        d.set_item("keepalive_polls", s.keepalive_polls)?;
        d.set_item("late_replies", s.late_replies)?;
        d.set_item("reconnects", s.reconnects)?;
        d.set_item("links_lost", s.links_lost)?;
        d.set_item("refused_before_sending", s.refused_before_sending)?;
        d.set_item("stream_samples", s.stream_samples)?;
        d.set_item("stream_underruns", s.stream_underruns)?;
        d.set_item("stream_late_replies", s.stream_late_replies)?;
        d.set_item("record_errors", s.record_errors)?;
        d.set_item("timer_step_s", s.timer_step_s)?;
        let rtt = PyDict::new(py);
        rtt.set_item("count", s.rtt.count)?;
        rtt.set_item("min_s", s.rtt.min.as_secs_f64())?;
        rtt.set_item("mean_s", s.rtt.mean.as_secs_f64())?;
        rtt.set_item("p99_s", s.rtt.p99.as_secs_f64())?;
        rtt.set_item("max_s", s.rtt.max.as_secs_f64())?;
        d.set_item("rtt", rtt)?;
        Ok(d)
    }

    /// The estimated controller clock (TIMER(1), seconds since the session was accepted)
    /// now, or `None` before the first reply with a timer.
    fn server_time(&self, py: Python<'_>) -> PyResult<Option<f64>> {
        Ok(self.client(py)?.server_time_now())
    }

    /// Opens a new session after the previous one was lost or closed (closing it first if
    /// still open). Nothing is resumed: the program is not running; call `start()` again.
    fn reconnect(&self, py: Python<'_>) -> PyResult<()> {
        let taken = self.inner.write().unwrap_or_else(|p| p.into_inner()).take();
        let Some(arc) = taken else {
            return Err(client_error(py, &ClientError::Closed));
        };
        let mut robot = match Arc::try_unwrap(arc) {
            Ok(r) => r,
            Err(arc) => {
                *self.inner.write().unwrap_or_else(|p| p.into_inner()) = Some(arc);
                return Err(base_error(
                    py,
                    "another call on this robot is in progress (in another thread); let it \
                     finish, then reconnect",
                ));
            }
        };
        let (robot, result) = block(
            py,
            async move {
                let r = robot.reconnect().await;
                (robot, r)
            },
            OnInterrupt::Nothing,
        )?;
        *self.inner.write().unwrap_or_else(|p| p.into_inner()) = Some(Arc::new(robot));
        result.map_err(|e| client_error(py, &e))
    }

    /// Ends the session: 255 (the controller stops the robot and ends the program), then
    /// waits for the controller to close the connection. Closing twice is not an error.
    fn close(&self, py: Python<'_>) -> PyResult<()> {
        self.call(py, |r| Box::pin(async move { crate::close(&r).await }))
    }

    fn __enter__(slf: Bound<'_, Self>) -> Bound<'_, Self> {
        slf
    }

    fn __exit__(
        &self,
        py: Python<'_>,
        ty: Option<&Bound<'_, PyAny>>,
        _value: Option<&Bound<'_, PyAny>>,
        _tb: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<bool> {
        let closed = self.close(py);
        // Do not hide the exception that is leaving the block.
        if ty.is_none() {
            closed?;
        }
        Ok(false)
    }

    fn __repr__(&self, py: Python<'_>) -> String {
        format!(
            "Robot(address={:?}, connected={})",
            self.address,
            py_bool(self.is_connected(py))
        )
    }
}

/// A joint move in progress (`Robot.move_joints(..., wait=False)`). Dropping it does not stop
/// the move; `cancel()` does.
#[pyclass(module = "fs020n", frozen)]
#[derive(Debug)]
pub struct Move {
    handle: client::MoveHandle,
    completion: Completion,
    sent: Instant,
    report: Mutex<Option<MoveReport>>,
    robot: Py<Robot>,
}

impl Move {
    fn start(
        robot: &Bound<'_, Robot>,
        py: Python<'_>,
        handle: client::MoveHandle,
        completion: Completion,
        sent: Instant,
        wait: bool,
    ) -> PyResult<Py<PyAny>> {
        let m = Move {
            handle,
            completion,
            sent,
            report: Mutex::new(None),
            robot: robot.clone().unbind(),
        };
        if wait {
            m.wait(py, None)?.into_py_any(py)
        } else {
            Py::new(py, m)?.into_py_any(py)
        }
    }
}

#[pymethods]
impl Move {
    /// Waits until the robot is at the target and returns a `MoveReport` (`reached=False`
    /// when the move was cancelled or superseded). `timeout` (seconds) overrides the one
    /// given to `move_joints`. Raises `MotionError` when the controller stopped the move
    /// (error, HOLD, E-stop, …) and `MoveTimeoutError` when it did not finish in time; in both
    /// cases the move was stopped for sure (commands 5 then 2) so that it cannot resume.
    #[pyo3(signature = (timeout=None))]
    fn wait(&self, py: Python<'_>, timeout: Option<f64>) -> PyResult<MoveReport> {
        if let Some(r) = lock(&self.report).clone() {
            return Ok(r);
        }
        let mut c = self.completion;
        if let Some(t) = timeout {
            c.timeout = Some(seconds(py, "timeout", t)?);
        }
        let robot = self.robot.get();
        let interrupt = OnInterrupt::CancelAndClose(robot.client(py)?);
        let handle = self.handle.clone();
        let target = handle.target();
        let out = block(py, async move { handle.wait(c).await }, interrupt)?;
        let report = match out {
            Ok(r) => MoveReport {
                reached: true,
                duration_s: r.elapsed.as_secs_f64(),
                error_deg: r.error_deg,
                final_joints: r.final_joints.values().to_vec(),
                target: target.values().to_vec(),
            },
            Err(ClientError::Cancelled(_)) => {
                let j = robot.latest_joints(py).unwrap_or(target);
                MoveReport {
                    reached: false,
                    duration_s: self.sent.elapsed().as_secs_f64(),
                    error_deg: j.max_abs_diff(&target),
                    final_joints: j.values().to_vec(),
                    target: target.values().to_vec(),
                }
            }
            Err(e) => return Err(client_error(py, &e)),
        };
        *lock(&self.report) = Some(report.clone());
        Ok(report)
    }

    /// Cancels the move for sure (commands 5 then 2: the robot brakes, the program ends;
    /// `robot.start()` again to move); `wait()` then returns
    /// `reached=False`.
    fn cancel(&self, py: Python<'_>) -> PyResult<()> {
        let handle = self.handle.clone();
        block(
            py,
            async move { handle.cancel().await },
            OnInterrupt::Nothing,
        )?
        .map_err(|e| client_error(py, &e))
    }

    /// `True` once the move has ended: waited for, or every joint within the tolerance of
    /// the target, or the session gone.
    fn done(&self) -> bool {
        if lock(&self.report).is_some() {
            return true;
        }
        match self.handle.progress() {
            Some(p) => p.remaining_deg <= self.completion.tolerance_deg,
            None => true,
        }
    }

    /// Fraction of the move done, 0–1, from the latest status (`None` once the session is
    /// gone).
    #[getter]
    fn progress(&self) -> Option<f64> {
        self.handle.progress().map(|p| p.fraction)
    }

    /// Largest per-joint distance to the target now, degrees (`None` once the session is
    /// gone).
    #[getter]
    fn remaining_deg(&self) -> Option<f64> {
        self.handle.progress().map(|p| p.remaining_deg)
    }

    /// The target, degrees.
    #[getter]
    fn target(&self) -> Vec<f64> {
        self.handle.target().values().to_vec()
    }

    /// The planned duration at the last speed set, seconds.
    #[getter]
    fn planned_duration_s(&self) -> f64 {
        self.handle.planned_duration().as_secs_f64()
    }

    fn __repr__(&self) -> String {
        format!(
            "Move(target={:?}, done={})",
            self.target(),
            py_bool(self.done())
        )
    }
}

/// A stream in progress (`Robot.stream(..., wait=False)`). Dropping it cancels the stream.
#[pyclass(module = "fs020n", frozen)]
#[derive(Debug)]
pub struct Stream {
    handle: client::StreamHandle,
    report: Mutex<Option<StreamReport>>,
    robot: Py<Robot>,
}

#[pymethods]
impl Stream {
    /// Waits for the end of the stream and returns its `StreamReport` (`outcome` is
    /// `"cancelled"` after `cancel()`). Raises `MotionError` when the controller stopped it.
    fn wait(&self, py: Python<'_>) -> PyResult<StreamReport> {
        if let Some(r) = lock(&self.report).clone() {
            return Ok(r);
        }
        let handle = self.handle.clone();
        let interrupt = OnInterrupt::CancelAndClose(self.robot.get().client(py)?);
        let out = block(py, async move { handle.wait().await }, interrupt)?;
        let report = StreamReport::of(&out.map_err(|e| client_error(py, &e))?);
        *lock(&self.report) = Some(report.clone());
        Ok(report)
    }

    /// Cancels the stream and returns once it has ended: no further sample is sent, command 5
    /// brakes the robot and command 2 ends the program (`robot.start()` again to move).
    fn cancel(&self, py: Python<'_>) -> PyResult<()> {
        let handle = self.handle.clone();
        block(
            py,
            async move { handle.cancel().await },
            OnInterrupt::Nothing,
        )?
        .map_err(|e| client_error(py, &e))
    }

    /// `True` once the stream has ended.
    fn done(&self) -> bool {
        self.handle.is_finished()
    }

    /// Fraction of the trajectory streamed, 0–1.
    #[getter]
    fn progress(&self) -> f64 {
        self.handle.progress().fraction
    }
}

/// An online servo (`Robot.servo()`): push samples at your own rate. Use it as a context
/// manager (leaving it stops the servo) or call `stop()`.
///
/// ```python
/// with robot.servo() as servo:
///     for q, qd in source:            # e.g. 125 Hz from a leader arm or a camera loop
///         servo.push(q, qd)
///         time.sleep(0.008)
/// ```
#[pyclass(module = "fs020n", frozen)]
#[derive(Debug)]
pub struct Servo {
    handle: Mutex<Option<client::ServoHandle>>,
    report: Mutex<Option<Ended>>,
    robot: Py<Robot>,
}

/// The end of a servo, kept for repeated `stop()` calls.
#[derive(Clone, Debug)]
struct Ended {
    outcome: &'static str,
    stats: client::ServoStats,
    final_joints: Option<Vec<f64>>,
    duration_s: f64,
}

fn joints_opt(v: Option<&Bound<'_, PyAny>>, what: &str) -> PyResult<Option<JointsDeg>> {
    v.filter(|v| !v.is_none())
        .map(|v| six(v, what).map(JointsDeg::new))
        .transpose()
}

impl Servo {
    fn report_object(&self, py: Python<'_>) -> PyResult<Option<ServoReport>> {
        let Some(end) = lock(&self.report).clone() else {
            return Ok(None);
        };
        Ok(Some(ServoReport {
            outcome: end.outcome.into(),
            stats: servo_stats(py, &end.stats)?.unbind(),
            final_joints: end.final_joints,
            duration_s: end.duration_s,
        }))
    }
}

#[pymethods]
impl Servo {
    /// Pushes a sample: joint positions `q` (degrees), optionally velocities `qd` (deg/s;
    /// estimated from the last two pushes when absent) and accelerations `qdd` (deg/s²).
    /// Returns at once (it never waits for the network). Raises `LimitError` for a sample
    /// that is refused (nothing sent; the previous one stays in force), `MotionError` once
    /// the servo has ended (watchdog, stop, cancel, a fault), `LinkLostError` after a lost
    /// link.
    #[pyo3(signature = (q, qd=None, qdd=None))]
    fn push(
        &self,
        py: Python<'_>,
        q: &Bound<'_, PyAny>,
        qd: Option<&Bound<'_, PyAny>>,
        qdd: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<()> {
        let sample = ServoSample {
            position: JointsDeg::new(six(q, "q")?),
            velocity: joints_opt(qd, "qd")?,
            acceleration: joints_opt(qdd, "qdd")?,
        };
        let guard = lock(&self.handle);
        let Some(h) = guard.as_ref() else {
            return Err(base_error(py, "the servo was stopped; open a new one"));
        };
        match h.push(sample) {
            Ok(()) => Ok(()),
            Err(e @ ClientError::Cancelled(_)) => Err(motion_error(py, &e)),
            Err(e) => Err(client_error(py, &e)),
        }
    }

    /// Stops the servo (no further sample is sent; commands 5 then 2 stop the arm for sure and
    /// end the program: `robot.start()` again to move), waits for its end and returns
    /// the `ServoReport`. If it had already ended by a fault, raises that fault. Calling it
    /// again returns the same report.
    fn stop(&self, py: Python<'_>) -> PyResult<ServoReport> {
        if let Some(r) = self.report_object(py)? {
            return Ok(r);
        }
        let Some(handle) = lock(&self.handle).take() else {
            return Err(base_error(py, "this servo already ended with an error"));
        };
        let interrupt = OnInterrupt::CancelAndClose(self.robot.get().client(py)?);
        let out = block(py, async move { handle.finish().await }, interrupt)?;
        let r = out.map_err(|e| client_error(py, &e))?;
        let outcome = match r.outcome {
            client::ServoOutcome::Stopped => "stopped",
            client::ServoOutcome::Cancelled => "cancelled",
            client::ServoOutcome::Watchdog => "watchdog",
        };
        *lock(&self.report) = Some(Ended {
            outcome,
            stats: r.stats,
            final_joints: r.final_joints.map(|j| j.values().to_vec()),
            duration_s: r.duration.as_secs_f64(),
        });
        self.report_object(py)?
            .ok_or_else(|| base_error(py, "the servo report is missing"))
    }

    /// The figures so far as a dict: pushes, refused, sent, coalesced, push intervals,
    /// push-to-send latency and round trips (seconds), tracking error (degrees).
    fn stats<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        if let Some(end) = lock(&self.report).as_ref() {
            return servo_stats(py, &end.stats);
        }
        match lock(&self.handle).as_ref() {
            Some(h) => servo_stats(py, &h.stats()),
            None => servo_stats(py, &client::ServoStats::default()),
        }
    }

    /// `True` once the servo has ended (stopped, cancelled, watchdog or fault).
    fn done(&self) -> bool {
        lock(&self.handle)
            .as_ref()
            .is_none_or(client::ServoHandle::is_finished)
    }

    fn __enter__(slf: Bound<'_, Self>) -> Bound<'_, Self> {
        slf
    }

    fn __exit__(
        &self,
        py: Python<'_>,
        ty: Option<&Bound<'_, PyAny>>,
        _value: Option<&Bound<'_, PyAny>>,
        _tb: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<bool> {
        let stopped = self.stop(py);
        if ty.is_none() {
            stopped?;
        }
        Ok(false)
    }

    fn __repr__(&self) -> String {
        format!("Servo(done={})", py_bool(self.done()))
    }
}
