"""Blocking calls release the GIL; Ctrl-C cancels, closes and re-raises; the keep-alive runs
while Python is busy."""

import signal
import threading
import time

import pytest

import fs020n
from conftest import HOME


@pytest.fixture(autouse=True)
def ctrl_c_raises():
    """A process started in the background by a non-interactive shell inherits SIGINT ignored,
    and Python then leaves it ignored: Ctrl-C is what these tests are about, so they install
    Python's own handler for their duration (as an interactive session has it)."""
    before = signal.signal(signal.SIGINT, signal.default_int_handler)
    yield
    signal.signal(signal.SIGINT, before)


def test_ctrl_c_during_a_wait_cancels_the_motion_closes_and_reraises(robot, emu):
    robot.set_speed(10)
    timer = threading.Timer(0.5, signal.raise_signal, args=(signal.SIGINT,))
    timer.start()
    started = time.monotonic()
    with pytest.raises(KeyboardInterrupt):
        robot.move_joints([60, 0, -90, 0, -90, 0])
    timer.join()
    assert time.monotonic() - started < 5.0
    assert not robot.is_connected
    assert emu.last_session_end == "end_command", "closed with 255"
    time.sleep(0.3)
    stopped = emu.joints[0]
    assert 0.5 < stopped < 30.0
    time.sleep(0.5)
    assert emu.joints[0] == pytest.approx(stopped, abs=0.01), "the arm stays still"


def test_ctrl_c_during_a_stream_wait(robot, emu):
    times = [k * 0.05 for k in range(61)]
    positions = [[20.0 * k / 60, 0, -90, 0, -90, 0] for k in range(61)]
    timer = threading.Timer(0.5, signal.raise_signal, args=(signal.SIGINT,))
    timer.start()
    with pytest.raises(KeyboardInterrupt):
        robot.stream(times, positions)
    timer.join()
    assert not robot.is_connected
    assert emu.last_session_end == "end_command"
    assert emu.joints[0] < 19.0


def test_blocking_calls_release_the_gil(robot):
    robot.set_speed(20)
    count = 0
    stop = threading.Event()

    def spin():
        nonlocal count
        while not stop.is_set():
            count += 1

    t = threading.Thread(target=spin)
    t.start()
    try:
        before = count
        report = robot.move_joints([15, 0, -90, 0, -90, 0])
        during = count - before
    finally:
        stop.set()
        t.join()
    assert report.reached
    # With the GIL held for the whole wait, the other thread could not count at all.
    assert during > 1000, during


def test_keep_alive_runs_while_python_is_busy(robot, emu):
    # Pure Python for longer than the controller's 5 s receive timeout, holding the GIL
    # except at the interpreter's switch points.
    deadline = time.monotonic() + 5.5
    x = 0
    while time.monotonic() < deadline:
        x += 1
    s = robot.status()
    assert s.program_running and robot.is_connected
    assert emu.counters["receive_timeouts"] == 0
    assert robot.stats()["keepalive_polls"] >= 30
    assert robot.move_joints(HOME).reached
