//! `fs020n.Emulator`: an emulated FS020N controller in this process, on real time, serving
//! protocol 1040 on a free loopback port.

use std::collections::HashMap;
use std::net::SocketAddr;
use std::sync::Mutex;
use std::time::Duration;

use fs020n_proto::{ErrorCode, JointsDeg};
use fs020n_sim::{
    run_robot, Network, Panel, PanelChange, PortMap, ProgramStart, RunningRobot, SimOptions,
};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyString};

use crate::errors::{base_error, limit_error};
use crate::{block, json_to_py, py_to_json, six, OnInterrupt};

/// An emulated FS020N controller running in this process (real time), serving protocol 1040
/// on a free port of 127.0.0.1 — the same emulator as `fs020n sim`, rule for rule. Use it as
/// the robot of your own tests: no robot and no extra process needed.
///
/// ```python
/// with fs020n.Emulator() as emu:
///     with fs020n.Robot(emu.address) as robot:
///         ...
///     emu.set_panel(run=False)        # operate the panel like a person at the pendant
///     emu.press_estop(); emu.release_estop(); emu.reset_error()
///     emu.raise_error("E1130")       # inject a controller error
///     emu.inject("delay_replies", count=1, delay_ms=400)   # and network faults
/// ```
///
/// By default the controller is ready (power on, RUN, REPEAT, teach lock off, no error) at
/// the home pose [0, 0, -90, 0, -90, 0] with the monitor speed at 10 %.
#[pyclass(module = "fs020n", frozen)]
#[derive(Debug)]
pub struct Emulator {
    running: Mutex<Option<RunningRobot>>,
    emulator: fs020n_sim::Emulator,
    addr: SocketAddr,
    pendant: Option<SocketAddr>,
    terminal: Option<SocketAddr>,
}

fn error_name(code: ErrorCode) -> Option<String> {
    (!code.is_none()).then(|| code.to_string())
}

fn parse_code(py: Python<'_>, code: &Bound<'_, PyAny>) -> PyResult<ErrorCode> {
    let parsed = if let Ok(s) = code.cast::<PyString>() {
        s.extract::<String>()?
            .parse::<ErrorCode>()
            .map_err(|e| PyValueError::new_err(e.to_string()))?
    } else {
        let raw: i32 = code.extract().map_err(|_| {
            PyValueError::new_err("an error code is a name such as \"E1130\" or its wire number")
        })?;
        ErrorCode(raw)
    };
    if parsed.is_none() {
        return Err(limit_error(
            py,
            "an error code must not be 0; to clear an error use reset_error()",
        ));
    }
    Ok(parsed)
}

/// The controller's address and host map from the constructor's arguments.
fn network(address: Option<String>, hosts: Option<HashMap<String, String>>) -> PyResult<Network> {
    let mut n = Network::default();
    if let Some(a) = address {
        n.address = a.parse().map_err(|e| {
            PyValueError::new_err(format!(
                "address {a:?}: {e} (the controller's IPv4 address, e.g. \"192.168.0.2\")"
            ))
        })?;
    }
    for (cell, real) in hosts.unwrap_or_default() {
        let (cell, real) = Network::parse_host(&format!("{cell}={real}"))
            .map_err(|e| PyValueError::new_err(format!("hosts: {e}")))?;
        n.hosts.insert(cell, real);
    }
    Ok(n)
}

/// The port map from the constructor's argument (program port → host port, 0: a free one).
fn ports(port_map: Option<HashMap<u16, u16>>) -> PyResult<PortMap> {
    let mut map = PortMap::same();
    for (p, h) in port_map.unwrap_or_default() {
        if p == 0 {
            return Err(PyValueError::new_err(
                "port_map: a program's port is 1 to 65535 (the host port may be 0: a free one)",
            ));
        }
        map.ports.insert(p, h);
    }
    Ok(map)
}

impl Emulator {
    fn with<R>(&self, f: impl FnOnce(&mut fs020n_sim::Controller) -> R) -> R {
        self.emulator.with(f)
    }
}

#[pymethods]
impl Emulator {
    /// Starts the emulator. `port=0` picks a free port (see `address`); `pendant=True` also
    /// serves the HTTP pendant API on another free loopback port (`pendant_address`). The
    /// panel switches, the joints (degrees), the monitor speed (%) and an initial error
    /// (`"E1088"`) can be chosen. `terminal=True` serves the controller's AS monitor terminal
    /// (telnet, login `as`) on another free loopback port (`terminal_address`); `bare=True`
    /// starts a new controller with nothing loaded (no protocol port answers until a program
    /// is loaded through the terminal and started). `as_program="file.as"` runs that AS file
    /// (your own server program, in any code page) instead of the native server, as
    /// `fs020n sim --as-program`; `stubs=["GUNON"]` declares instructions no-ops for it (and
    /// for every program loaded into a bare controller).
    ///
    /// The network of an AS program: `address="192.168.0.2"` is the controller's own address
    /// (default 192.168.0.2); `hosts={"192.168.0.10": "127.0.0.1"}` maps the cell's hosts to
    /// real ones (a `TCP_CONNECT`/`UDP_SENDTO` to an address not mapped gets E4023); every port
    /// the program listens on is served on 127.0.0.1 at the same number, or where
    /// `port_map={9111: 19111}` says (0: a free port; see `program_ports`, `wait_port`).
    ///
    /// What runs: the file's autostart programs (`autostart.pc` …); `pcexecute=["2: comm"]`
    /// and `execute="main"` start others as the monitor's `PCEXECUTE`/`EXECUTE` do (a
    /// refusal such as P1038 raises); each has run to its first wait, its ports served,
    /// when the constructor returns. `signals={1001: True}` sets input signals before any
    /// program step runs.
    #[new]
    #[pyo3(signature = (*, port=0, joints=None, monitor_speed=None, power=true, run=true, repeat=true, teach_lock=false, error=None, pendant=false, terminal=false, bare=false, as_program=None, stubs=Vec::new(), address=None, hosts=None, port_map=None, pcexecute=Vec::new(), execute=None, signals=None))]
    #[allow(clippy::too_many_arguments)]
    fn new(
        py: Python<'_>,
        port: u16,
        joints: Option<&Bound<'_, PyAny>>,
        monitor_speed: Option<f64>,
        power: bool,
        run: bool,
        repeat: bool,
        teach_lock: bool,
        error: Option<&Bound<'_, PyAny>>,
        pendant: bool,
        terminal: bool,
        bare: bool,
        as_program: Option<std::path::PathBuf>,
        stubs: Vec<String>,
        address: Option<String>,
        hosts: Option<HashMap<String, String>>,
        port_map: Option<HashMap<u16, u16>>,
        pcexecute: Vec<String>,
        execute: Option<String>,
        signals: Option<HashMap<i32, bool>>,
    ) -> PyResult<Emulator> {
        let loopback = |port| SocketAddr::from(([127, 0, 0, 1], port));
        let mut opts = SimOptions::default().listen(loopback(port)).panel(Panel {
            power,
            run,
            repeat,
            teach_lock,
            estop: false,
        });
        if pendant {
            opts = opts.pendant(loopback(0));
        }
        if terminal {
            opts = opts.terminal(loopback(0));
        }
        if bare {
            opts = opts.bare();
        }
        if let Some(path) = as_program {
            opts = opts.program(path);
        }
        if !stubs.is_empty() && opts.program.is_none() && !opts.bare {
            return Err(pyo3::exceptions::PyValueError::new_err(
                "stubs apply to AS programs: give them with as_program=… or bare=True",
            ));
        }
        opts.program_load = (stubs.iter()).fold(fs020n_as::LoadOptions::new(), |o, s| o.stub(s));
        if let Some(j) = joints {
            opts = opts.joints(JointsDeg::new(six(j, "joints")?));
        }
        if let Some(p) = monitor_speed {
            opts = opts.monitor_speed(p);
        }
        if let Some(code) = error {
            opts = opts.error(parse_code(py, code)?);
        }
        opts = opts
            .network(network(address, hosts)?)
            .ports(ports(port_map)?);
        for spec in &pcexecute {
            let start = ProgramStart::pc(spec).map_err(|e| PyValueError::new_err(e.to_string()))?;
            opts.start.push(start);
        }
        if let Some(spec) = &execute {
            let start =
                ProgramStart::robot(spec).map_err(|e| PyValueError::new_err(e.to_string()))?;
            opts.start.push(start);
        }
        for (n, on) in signals.unwrap_or_default() {
            if !(1001..=1999).contains(&n) {
                return Err(PyValueError::new_err(format!(
                    "signals: {n} is no input signal (1001–1999)"
                )));
            }
            opts.inputs.push((n, on));
        }
        if opts.program.is_none() && !opts.inputs.is_empty() {
            return Err(PyValueError::new_err(
                "signals are read by AS programs: give them with as_program=…",
            ));
        }
        let running = block(py, run_robot(opts), OnInterrupt::Nothing)?
            .map_err(|e| base_error(py, &format!("cannot start the emulator: {e}")))?;
        Ok(Emulator {
            emulator: running.emulator().clone(),
            addr: running.robot_addr(),
            pendant: running.pendant_addr(),
            terminal: running.terminal_addr(),
            running: Mutex::new(Some(running)),
        })
    }

    /// `"127.0.0.1:PORT"`: give it to `fs020n.Robot`.
    #[getter]
    fn address(&self) -> String {
        self.addr.to_string()
    }

    /// The port of the protocol server.
    #[getter]
    fn port(&self) -> u16 {
        self.addr.port()
    }

    /// Where each port the AS program has listened on is served: `{program_port: host_port}`
    /// (empty for the native server).
    #[getter]
    fn program_ports(&self) -> HashMap<u16, u16> {
        (self.emulator.program_ports().into_iter())
            .map(|(p, a)| (p, a.port()))
            .collect()
    }

    /// Waits until the AS program listens on `port` and it is served (at most `timeout`
    /// seconds): the host port to connect to on 127.0.0.1. `TimeoutError` when it is not
    /// served by then (the program does not listen there, or the host port is taken: map it
    /// with `port_map`).
    #[pyo3(signature = (port, timeout=5.0))]
    fn wait_port(&self, py: Python<'_>, port: u16, timeout: f64) -> PyResult<u16> {
        if !(timeout.is_finite() && timeout >= 0.0) {
            return Err(PyValueError::new_err("timeout is seconds, 0 or more"));
        }
        let emu = self.emulator.clone();
        let wait = Duration::from_secs_f64(timeout.min(3600.0));
        let got = block(
            py,
            async move { emu.wait_program_port(port, wait).await },
            OnInterrupt::Nothing,
        )?;
        got.map(|a| a.port()).ok_or_else(|| {
            pyo3::exceptions::PyTimeoutError::new_err(format!(
                "the AS program's port {port} is not served after {timeout} s: does the \
                 program listen on it? If the host port is taken, map it: port_map={{{port}: 0}}"
            ))
        })
    }

    /// The controller's network: `{"address": "192.168.0.2", "hosts": {"192.168.0.10":
    /// "127.0.0.1"}}`.
    #[getter]
    fn network<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let n = self.with(|c| c.network().clone());
        let d = PyDict::new(py);
        d.set_item("address", n.address.to_string())?;
        let hosts = PyDict::new(py);
        for (cell, real) in &n.hosts {
            hosts.set_item(cell.to_string(), real.to_string())?;
        }
        d.set_item("hosts", hosts)?;
        Ok(d)
    }

    /// `"127.0.0.1:PORT"` of the HTTP pendant API, or `None` (start with `pendant=True`).
    #[getter]
    fn pendant_address(&self) -> Option<String> {
        self.pendant.map(|a| a.to_string())
    }

    /// `"127.0.0.1:PORT"` of the AS monitor terminal, or `None` (start with `terminal=True`).
    #[getter]
    fn terminal_address(&self) -> Option<String> {
        self.terminal.map(|a| a.to_string())
    }

    /// Switches the controller off and on: tasks stop, sockets close, the error is cleared,
    /// motor power is off; loaded programs and switches stay, and `autostart.pc` (…) starts
    /// when its AUTOSTART switch is ON. Returns the programs started as `(task, name)`.
    fn power_cycle(&self) -> Vec<(u8, String)> {
        self.with(|c| c.power_cycle()).started
    }

    /// The programs in the controller's memory (loaded through the terminal or given at start).
    #[getter]
    fn programs(&self) -> Vec<String> {
        self.with(|c| c.memory().programs())
    }

    /// The emulated encoders: six joint angles, degrees.
    #[getter]
    fn joints(&self) -> Vec<f64> {
        self.with(|c| c.joints()).values().to_vec()
    }

    /// The panel switches: a dict with `power`, `run`, `repeat`, `teach_lock`, `estop`.
    #[getter]
    fn panel<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let p = self.with(|c| c.panel());
        let d = PyDict::new(py);
        d.set_item("power", p.power)?;
        d.set_item("run", p.run)?;
        d.set_item("repeat", p.repeat)?;
        d.set_item("teach_lock", p.teach_lock)?;
        d.set_item("estop", p.estop)?;
        Ok(d)
    }

    /// Changes panel switches like a person at the controller: `power`, `run` (False = HOLD),
    /// `repeat` (False = TEACH), `teach_lock`; the ones not given stay. HOLD pauses the motion
    /// (RUN resumes it); TEACH, the lock and power off stop the program. Power on is refused
    /// while the emergency stop is pressed.
    #[pyo3(signature = (*, power=None, run=None, repeat=None, teach_lock=None))]
    fn set_panel(
        &self,
        py: Python<'_>,
        power: Option<bool>,
        run: Option<bool>,
        repeat: Option<bool>,
        teach_lock: Option<bool>,
    ) -> PyResult<()> {
        let change = PanelChange {
            power,
            run,
            repeat,
            teach_lock,
        };
        self.with(|c| c.apply_panel(change))
            .map_err(|e| base_error(py, &e.to_string()))
    }

    /// Presses the emergency stop: motor power is cut, the robot stops dead, the program
    /// ends and error E3808 is raised.
    fn press_estop(&self) {
        self.with(|c| c.set_estop(true));
    }

    /// Releases the emergency stop (the error stays until `reset_error()`, power stays off
    /// until `set_panel(power=True)`).
    fn release_estop(&self) {
        self.with(|c| c.set_estop(false));
    }

    /// Raises a controller error, e.g. `"E1130"` (or its wire number, -31130): the robot
    /// brakes and the program stops.
    fn raise_error(&self, py: Python<'_>, code: &Bound<'_, PyAny>) -> PyResult<()> {
        let code = parse_code(py, code)?;
        self.with(|c| c.inject(fs020n_sim::Fault::RaiseError { code }));
        Ok(())
    }

    /// Resets the error (ERESET at the pendant). Refused while the emergency stop is pressed.
    fn reset_error(&self, py: Python<'_>) -> PyResult<()> {
        self.with(|c| c.reset_error())
            .map_err(|e| base_error(py, &e.to_string()))
    }

    /// The current error as on the wire (0: none; E1130 is -31130).
    #[getter]
    fn error(&self) -> i32 {
        self.with(|c| c.error()).raw()
    }

    /// The current error's name (`"E1130"`), or `None`.
    #[getter]
    fn error_name(&self) -> Option<String> {
        error_name(self.with(|c| c.error()))
    }

    /// The monitor speed, percent.
    #[getter]
    fn monitor_speed(&self) -> f64 {
        self.with(|c| c.monitor_speed())
    }

    /// Sets the monitor speed at the pendant (0 < percent <= 100).
    fn set_monitor_speed(&self, py: Python<'_>, percent: f64) -> PyResult<()> {
        self.with(|c| c.set_monitor_speed(percent))
            .map_err(|e| limit_error(py, &e.to_string()))
    }

    /// `True` while the motion program runs (paused by HOLD counts as not running, as in
    /// reply field 7).
    #[getter]
    fn program_running(&self) -> bool {
        self.with(|c| c.task()) == fs020n_sim::MotionTaskState::Running
    }

    /// `True` while a client holds the session.
    #[getter]
    fn session_open(&self) -> bool {
        self.with(|c| c.native().session().is_some())
    }

    /// The number of the newest command the controller acts on (the motion program reads
    /// only that one, spec §2.2): 1 start, 2 stop, 3 speed, 5 cancel, 6 joint move,
    /// 7 streamed move, 255 end of session, 0 right after a session was accepted; `None`
    /// before the first session.
    #[getter]
    fn newest_command(&self) -> Option<f64> {
        self.with(|c| c.native().newest_command().map(|cmd| cmd.number()))
    }

    /// How the latest session ended: `"end_command"` (the client sent 255),
    /// `"receive_timeout"` (no request for 5 s), `"send_timeout"`, `"disconnected"` (the
    /// client dropped the connection), `"fault"` (injected); `None` before any ended.
    #[getter]
    fn last_session_end(&self, py: Python<'_>) -> PyResult<Option<String>> {
        let Some((_, end)) = self.with(|c| c.native().last_session_end()) else {
            return Ok(None);
        };
        let v = serde_json::to_value(end)
            .map_err(|e| base_error(py, &format!("cannot describe the session end: {e}")))?;
        Ok(v.as_str().map(str::to_owned))
    }

    /// Counters of the controller (requests, effective requests, sessions, …) as a dict.
    #[getter]
    fn counters(&self, py: Python<'_>) -> PyResult<Py<PyAny>> {
        let c = self.with(|c| c.counters());
        let v = serde_json::to_value(c)
            .map_err(|e| base_error(py, &format!("cannot describe the counters: {e}")))?;
        json_to_py(py, &v)
    }

    /// What the AS program's interface panel shows (`IFPWPRINT` …) as a dict: `windows` (a
    /// list of 8, each with `rows`, `row`, `column`, `background`, `label_colour`), `labels` by
    /// icon position, `titles` by page; `None` when the emulator runs the native server.
    fn interface_panel(&self, py: Python<'_>) -> PyResult<Option<Py<PyAny>>> {
        let Some(panel) = self.with(|c| c.program().interface_panel().cloned()) else {
            return Ok(None);
        };
        let v = serde_json::to_value(panel)
            .map_err(|e| base_error(py, &format!("cannot describe the interface panel: {e}")))?;
        json_to_py(py, &v).map(Some)
    }

    /// The whole state as a dict (what the pendant API's GET /state returns).
    fn snapshot(&self, py: Python<'_>) -> PyResult<Py<PyAny>> {
        let v = serde_json::to_value(self.emulator.snapshot())
            .map_err(|e| base_error(py, &format!("cannot describe the emulator: {e}")))?;
        json_to_py(py, &v)
    }

    /// Injects a fault, by kind with its parameters: `"delay_replies"` (count, delay_ms),
    /// `"withhold_replies"` (count), `"garbage_reply"` (text), `"split_reply"` (parts,
    /// gap_ms), `"close_connection"`, `"stop_reading"` (duration_ms), `"raise_error"` (code).
    ///
    /// ```python
    /// emu.inject("delay_replies", count=1, delay_ms=400)
    /// ```
    #[pyo3(signature = (kind, **params))]
    fn inject(
        &self,
        py: Python<'_>,
        kind: &str,
        params: Option<&Bound<'_, PyDict>>,
    ) -> PyResult<()> {
        let mut obj = serde_json::Map::new();
        obj.insert("kind".into(), serde_json::Value::from(kind));
        if let Some(p) = params {
            for (k, v) in p.iter() {
                obj.insert(k.extract::<String>()?, py_to_json(&v)?);
            }
        }
        let fault = fs020n_sim::parse_fault(serde_json::Value::Object(obj)).map_err(|e| {
            limit_error(
                py,
                &format!(
                    "not a fault: {e}; kinds: delay_replies(count, delay_ms), \
                         withhold_replies(count), garbage_reply(text), split_reply(parts, gap_ms), \
                         close_connection(), stop_reading(duration_ms), raise_error(code)"
                ),
            )
        })?;
        self.with(|c| c.inject(fault));
        Ok(())
    }

    /// Drops the client's connection at once (a lost link, as a cut cable would be).
    fn drop_connection(&self) {
        self.with(|c| c.inject(fs020n_sim::Fault::CloseConnection));
    }

    /// Stops the servers (an open session is dropped). Idempotent.
    fn stop(&self) {
        let running = self
            .running
            .lock()
            .unwrap_or_else(|p| p.into_inner())
            .take();
        if let Some(r) = running {
            // Aborting the tasks needs the runtime's context.
            if let Ok(rt) = crate::runtime() {
                let _guard = rt.enter();
                r.stop();
            }
        }
    }

    /// `True` until `stop()`.
    #[getter]
    fn running(&self) -> bool {
        self.running
            .lock()
            .unwrap_or_else(|p| p.into_inner())
            .is_some()
    }

    fn __enter__(slf: Bound<'_, Self>) -> Bound<'_, Self> {
        slf
    }

    fn __exit__(
        &self,
        _ty: Option<&Bound<'_, PyAny>>,
        _value: Option<&Bound<'_, PyAny>>,
        _tb: Option<&Bound<'_, PyAny>>,
    ) -> bool {
        self.stop();
        false
    }

    fn __repr__(&self) -> String {
        format!(
            "Emulator(address={:?}, running={})",
            self.address(),
            self.running()
        )
    }
}

impl Drop for Emulator {
    fn drop(&mut self) {
        self.stop();
    }
}
