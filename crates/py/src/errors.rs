//! Client errors as the exceptions of `fs020n/errors.py`.

use fs020n_client::{Blocker, ClientError, ErrorKind};
use pyo3::prelude::*;

/// Rust API names in the client's messages, and what a Python user calls instead.
const PYTHON_NAMES: &[(&str, &str)] = &[
    (
        "(Robot::start; in the fs020n shell: `start`)",
        "(robot.start())",
    ),
    (
        "StreamHandle::cancel or Robot::cancel",
        "stream.cancel() or robot.cancel()",
    ),
    (
        "ServoHandle::stop or Robot::cancel",
        "servo.stop() or robot.cancel()",
    ),
    ("ServoHandle::stop", "servo.stop()"),
    ("ServoHandle::wait", "servo.stop()"),
    ("StreamOptions::max_step_deg", "the max_step_deg argument"),
    ("StreamMode::Waypoints", "mode=\"cmd6\""),
    ("Robot::reconnect", "robot.reconnect()"),
    ("Robot::start", "robot.start()"),
    ("Robot::cancel", "robot.cancel()"),
    ("Robot::close", "robot.close()"),
];

/// The client's message with its remedies naming the Python API.
pub(crate) fn message(e: &ClientError) -> String {
    pythonize(&e.to_string())
}

/// A client text (message, remedy) naming the Python API instead of the Rust one.
pub(crate) fn pythonize(text: &str) -> String {
    let mut text = text.to_owned();
    for (rust, python) in PYTHON_NAMES {
        if text.contains(rust) {
            text = text.replace(rust, python);
        }
    }
    text
}

pub(crate) fn blocker_pairs(blockers: &[Blocker]) -> Vec<(String, String)> {
    blockers
        .iter()
        .map(|b| (b.condition(), pythonize(&b.remedy())))
        .collect()
}

/// The exception class (in `fs020n.errors`) of a client error: the client's one
/// classification ([`ErrorKind`]), named as this package names it.
fn class_of(e: &ClientError) -> &'static str {
    match e.kind() {
        ErrorKind::Refused => "LimitError",
        ErrorKind::NotReady => "NotReadyError",
        ErrorKind::Connect => "ConnectError",
        ErrorKind::LinkLost => "LinkLostError",
        ErrorKind::Motion => "MotionError",
        ErrorKind::MoveTimeout => "MoveTimeoutError",
        ErrorKind::Busy => "BusyError",
        _ => "Error",
    }
}

/// A Python exception for a client error.
pub(crate) fn client_error(py: Python<'_>, e: &ClientError) -> PyErr {
    build(py, class_of(e), &message(e), e.blockers()).unwrap_or_else(|err| err)
}

/// A `MotionError` with the client's message (e.g. a servo ended by its watchdog).
pub(crate) fn motion_error(py: Python<'_>, e: &ClientError) -> PyErr {
    build(py, "MotionError", &message(e), e.blockers()).unwrap_or_else(|err| err)
}

/// A `LimitError` with this message.
pub(crate) fn limit_error(py: Python<'_>, msg: &str) -> PyErr {
    build(py, "LimitError", msg, &[]).unwrap_or_else(|err| err)
}

/// The base `Error` with this message.
pub(crate) fn base_error(py: Python<'_>, msg: &str) -> PyErr {
    build(py, "Error", msg, &[]).unwrap_or_else(|err| err)
}

fn build(py: Python<'_>, class: &str, msg: &str, blockers: &[Blocker]) -> PyResult<PyErr> {
    let module = py.import("fs020n.errors")?;
    let exc = module.getattr(class)?.call1((msg,))?;
    if matches!(class, "NotReadyError" | "MotionError" | "MoveTimeoutError") {
        exc.setattr("blockers", blocker_pairs(blockers))?;
    }
    if matches!(class, "MotionError" | "MoveTimeoutError") {
        let code = blockers.iter().find_map(|b| match b {
            Blocker::ControllerError(c) => Some(*c),
            _ => None,
        });
        exc.setattr("code", code.map(|c| c.raw()))?;
        exc.setattr("code_name", code.map(|c| c.to_string()))?;
        let remedy = match code {
            Some(c) => Some(Blocker::ControllerError(c).remedy()),
            None => blockers.first().map(|b| pythonize(&b.remedy())),
        };
        exc.setattr("remedy", remedy)?;
    }
    Ok(PyErr::from_value(exc))
}
