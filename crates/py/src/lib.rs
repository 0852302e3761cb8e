//! # fs020n-py
//!
//! The native part (`fs020n._fs020n`) of the `fs020n` Python package, built with PyO3 and
//! maturin (`pip install ./crates/py`): the client ([`robot`]), the kinematics ([`kin`]) and
//! the emulator ([`emulator`]) of the Rust crates, with Python exceptions
//! (`fs020n/errors.py`), the GIL released in every blocking call, and Ctrl-C turned into a
//! cancel of the motion and a clean close. The Python side is documented in `docs/PYTHON.md`.
//!
//! One tokio runtime with two worker threads serves every [`robot::Robot`] and
//! [`emulator::Emulator`] of the process: the keep-alive polls, the servo and stream tasks and
//! the emulated controller run there, whatever the Python threads do.
// PyO3's macros expand to `unsafe` code (FFI glue), so `forbid` cannot be used: `deny` keeps
// hand-written unsafe code out while allowing the macros' own (they carry their own allow).
#![deny(unsafe_code)]
#![warn(missing_docs)]

use std::future::Future;
use std::sync::{Arc, OnceLock};
use std::time::Duration;

use pyo3::exceptions::{PyRuntimeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};
use pyo3::IntoPyObjectExt;
use tokio::runtime::Runtime;

pub mod emulator;
pub mod errors;
pub mod kin;
pub mod robot;

/// How often a blocking call looks for a pending signal (Ctrl-C) while it waits.
const SIGNAL_POLL: Duration = Duration::from_millis(50);

/// Longest a cancel or close after Ctrl-C may take before the interrupt is re-raised anyway.
const INTERRUPT_CLEANUP: Duration = Duration::from_secs(3);

static RUNTIME: OnceLock<Runtime> = OnceLock::new();

/// The process-wide runtime (created on first use).
pub(crate) fn runtime() -> PyResult<&'static Runtime> {
    if let Some(rt) = RUNTIME.get() {
        return Ok(rt);
    }
    let rt = tokio::runtime::Builder::new_multi_thread()
        .worker_threads(2)
        .thread_name("fs020n")
        .enable_all()
        .build()
        .map_err(|e| PyRuntimeError::new_err(format!("cannot start the fs020n runtime: {e}")))?;
    // Another thread may have won the race: use whichever is stored.
    Ok(RUNTIME.get_or_init(|| rt))
}

/// What a blocking call does when Ctrl-C (or another signal whose handler raises) arrives
/// while it waits.
#[derive(Clone, Default)]
pub(crate) enum OnInterrupt {
    /// Nothing but abandoning the wait.
    #[default]
    Nothing,
    /// Stop the motion for sure (commands 5 then 2) and close the session (255), then
    /// re-raise.
    CancelAndClose(Arc<fs020n_client::Robot>),
}

/// Runs `fut` on the runtime and waits for it with the GIL released, looking for signals
/// every [`SIGNAL_POLL`]. When a signal handler raises (Ctrl-C: `KeyboardInterrupt`), the
/// wait is abandoned, `on_interrupt` runs, and the exception is returned.
pub(crate) fn block<R, F>(py: Python<'_>, fut: F, on_interrupt: OnInterrupt) -> PyResult<R>
where
    F: Future<Output = R> + Send + 'static,
    R: Send + 'static,
{
    let rt = runtime()?;
    let mut task = rt.spawn(fut);
    loop {
        let done =
            py.detach(|| rt.block_on(async { tokio::time::timeout(SIGNAL_POLL, &mut task).await }));
        match done {
            Ok(Ok(r)) => return Ok(r),
            Ok(Err(e)) => {
                return Err(PyRuntimeError::new_err(format!(
                    "an fs020n task failed: {e}"
                )))
            }
            Err(_) => {
                if let Err(signal) = py.check_signals() {
                    task.abort();
                    interrupted(py, rt, on_interrupt);
                    return Err(signal);
                }
            }
        }
    }
}

/// After a signal: cancel and close (bounded), with the GIL released.
fn interrupted(py: Python<'_>, rt: &'static Runtime, on_interrupt: OnInterrupt) {
    let OnInterrupt::CancelAndClose(robot) = on_interrupt else {
        return;
    };
    py.detach(|| {
        rt.block_on(async move {
            let _ = tokio::time::timeout(INTERRUPT_CLEANUP, robot.cancel()).await;
            let _ = tokio::time::timeout(INTERRUPT_CLEANUP, close(&robot)).await;
        })
    });
}

/// Closes the session (255) and waits until the session task has ended, so that
/// `is_connected` is false as soon as this returns (`Robot::close` answers once the controller
/// closed the connection, a moment before the session task records the end).
pub(crate) async fn close(robot: &fs020n_client::Robot) -> Result<(), fs020n_client::ClientError> {
    let mut ended = robot.subscribe();
    robot.close().await?;
    while ended.changed().await.is_ok() {}
    // The session's end is recorded as the session task ends: on disk before `close` returns.
    robot.flush_recording().await
}

/// Reads six numbers (a list, tuple, numpy array or any iterable of numbers).
pub(crate) fn six(obj: &Bound<'_, PyAny>, what: &str) -> PyResult<[f64; 6]> {
    let mut out = [0.0; 6];
    let mut n = 0usize;
    let iter = obj.try_iter().map_err(|_| {
        PyValueError::new_err(format!(
            "{what} must be a sequence of 6 numbers, got {}",
            type_name(obj)
        ))
    })?;
    for item in iter {
        let item = item?;
        let v: f64 = item.extract().map_err(|_| {
            PyValueError::new_err(format!(
                "{what}[{n}] must be a number, got {}",
                type_name(&item)
            ))
        })?;
        if n < 6 {
            out[n] = v;
        }
        n += 1;
    }
    if n != 6 {
        return Err(PyValueError::new_err(format!(
            "{what} must have 6 values (JT1..JT6 or X, Y, Z, O, A, T), got {n}"
        )));
    }
    Ok(out)
}

/// Reads a sequence of numbers.
pub(crate) fn numbers(obj: &Bound<'_, PyAny>, what: &str) -> PyResult<Vec<f64>> {
    let iter = obj.try_iter().map_err(|_| {
        PyValueError::new_err(format!(
            "{what} must be a sequence of numbers, got {}",
            type_name(obj)
        ))
    })?;
    iter.enumerate()
        .map(|(i, item)| {
            let item = item?;
            item.extract::<f64>().map_err(|_| {
                PyValueError::new_err(format!(
                    "{what}[{i}] must be a number, got {}",
                    type_name(&item)
                ))
            })
        })
        .collect()
}

/// Reads a sequence of 6-number rows (a list of lists, an N×6 numpy array, …).
pub(crate) fn rows(obj: &Bound<'_, PyAny>, what: &str) -> PyResult<Vec<[f64; 6]>> {
    let iter = obj.try_iter().map_err(|_| {
        PyValueError::new_err(format!(
            "{what} must be a sequence of rows of 6 numbers (N x 6), got {}",
            type_name(obj)
        ))
    })?;
    iter.enumerate()
        .map(|(i, row)| six(&row?, &format!("{what}[{i}]")))
        .collect()
}

fn type_name(obj: &Bound<'_, PyAny>) -> String {
    obj.get_type()
        .name()
        .map(|n| n.to_string())
        .unwrap_or_else(|_| "an object".into())
}

/// A duration from seconds given by the user: finite, at least 0, at most a day.
pub(crate) fn seconds(py: Python<'_>, what: &str, s: f64) -> PyResult<Duration> {
    if !(s.is_finite() && (0.0..=86_400.0).contains(&s)) {
        return Err(errors::limit_error(
            py,
            &format!("{what} {s} s must be a number of seconds from 0 to 86400"),
        ));
    }
    Ok(Duration::from_secs_f64(s))
}

/// A JSON value as Python objects (dicts, lists, str, int, float, bool, None).
pub(crate) fn json_to_py(py: Python<'_>, v: &serde_json::Value) -> PyResult<Py<PyAny>> {
    use serde_json::Value;
    Ok(match v {
        Value::Null => py.None(),
        Value::Bool(b) => b.into_py_any(py)?,
        Value::Number(n) => match (n.as_i64(), n.as_u64()) {
            (Some(i), _) => i.into_py_any(py)?,
            (None, Some(u)) => u.into_py_any(py)?,
            _ => n.as_f64().unwrap_or(f64::NAN).into_py_any(py)?,
        },
        Value::String(s) => s.into_py_any(py)?,
        Value::Array(a) => {
            let items = a
                .iter()
                .map(|x| json_to_py(py, x))
                .collect::<PyResult<Vec<_>>>()?;
            PyList::new(py, items)?.into_any().unbind()
        }
        Value::Object(o) => {
            let d = PyDict::new(py);
            for (k, x) in o {
                d.set_item(k, json_to_py(py, x)?)?;
            }
            d.into_any().unbind()
        }
    })
}

/// A plain Python value (None, bool, int, float, str) as JSON.
pub(crate) fn py_to_json(v: &Bound<'_, PyAny>) -> PyResult<serde_json::Value> {
    use serde_json::Value;
    if v.is_none() {
        return Ok(Value::Null);
    }
    if let Ok(b) = v.cast::<pyo3::types::PyBool>() {
        return Ok(Value::Bool(b.is_true()));
    }
    if let Ok(i) = v.extract::<i64>() {
        return Ok(Value::from(i));
    }
    if let Ok(f) = v.extract::<f64>() {
        return Ok(Value::from(f));
    }
    if let Ok(s) = v.extract::<String>() {
        return Ok(Value::from(s));
    }
    Err(PyValueError::new_err(format!(
        "expected None, a bool, a number or a string, got {}",
        type_name(v)
    )))
}

/// The native module `fs020n._fs020n`; `fs020n/__init__.py` re-exports it.
#[pymodule]
fn _fs020n(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    m.add_class::<emulator::Emulator>()?;
    m.add_class::<robot::Robot>()?;
    m.add_class::<robot::Status>()?;
    m.add_class::<robot::MoveReport>()?;
    m.add_class::<robot::Move>()?;
    m.add_class::<robot::StreamReport>()?;
    m.add_class::<robot::Stream>()?;
    m.add_class::<robot::Servo>()?;
    m.add_class::<robot::ServoReport>()?;
    m.add_function(wrap_pyfunction!(kin::fk, m)?)?;
    m.add_function(wrap_pyfunction!(kin::ik, m)?)?;
    m.add_function(wrap_pyfunction!(kin::joint_limits, m)?)?;
    m.add(
        "HOME",
        fs020n_kin::RobotModel::fs020n().home.values().to_vec(),
    )?;
    Ok(())
}
