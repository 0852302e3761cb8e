"""Online servoing from Python."""

import math
import time

import pytest

import fs020n
from conftest import HOME, effective


def sine(t, amplitude=5.0, period=2.0):
    w = 2 * math.pi / period
    return ([amplitude * math.sin(w * t), 0, -90, 0, -90, 0],
            [amplitude * w * math.cos(w * t), 0, 0, 0, 0, 0])


def test_a_push_loop_is_followed_and_stop_reports(robot, emu):
    period = 0.01
    with robot.servo(watchdog=0.5) as servo:
        t0 = time.monotonic()
        k = 0
        while True:
            t = time.monotonic() - t0
            if t > 1.0:
                break
            q, qd = sine(t)
            servo.push(q, qd)
            k += 1
            time.sleep(max(0.0, t0 + k * period - time.monotonic()))
        live = servo.stats()
        assert live["pushes"] == k
    report = servo.stop()
    assert report.outcome == "stopped"
    st = report.stats
    assert st["pushes"] == k and st["refused"] == 0
    # Every accepted push is accounted for; only the newest can be left unsent by the stop.
    assert st["sent"] + st["coalesced"] + st["unsent"] == st["pushes"]
    assert st["unsent"] <= 1
    assert st["sent"] >= 20
    assert st["tracking_samples"] > 0 and st["tracking_error_rms_deg"] < 2.0
    assert 0 < st["push_interval_mean_s"] < 0.1
    assert report.final_joints is not None and report.duration_s >= 1.0
    assert emu.newest_command == 2  # a sure stop: 5 then 2
    assert servo.done() and servo.stop() is not None  # stop twice: same report
    assert abs(emu.joints[0] - sine(1.0)[0][0]) < 3.0


def test_numpy_samples_and_estimated_velocity(robot, emu):
    np = pytest.importorskip("numpy")
    servo = robot.servo(watchdog=0.5)
    for k in range(50):
        servo.push(np.array(HOME) + np.array([0.05 * k, 0, 0, 0, 0, 0]))
        time.sleep(0.01)
    report = servo.stop()
    assert report.stats["pushes"] == 50
    time.sleep(0.1)
    assert not emu.program_running
    assert emu.joints[0] == pytest.approx(2.45, abs=1.0)


def test_refused_pushes_send_nothing(robot, emu):
    with robot.servo(watchdog=0.5) as servo:
        before = effective(emu)
        with pytest.raises(fs020n.LimitError, match="move to its first point"):
            servo.push([10, 0, -90, 0, -90, 0])
        with pytest.raises(fs020n.LimitError, match="JT1"):
            servo.push([500, 0, -90, 0, -90, 0])
        with pytest.raises(fs020n.LimitError, match="velocity"):
            servo.push(HOME, [1000, 0, 0, 0, 0, 0])
        with pytest.raises(ValueError, match="6 values"):
            servo.push([0, 0])
        time.sleep(0.05)
        assert effective(emu) == before
        assert servo.stats()["refused"] == 3
        servo.push(HOME)
        with pytest.raises(fs020n.BusyError):
            robot.move_joints(HOME)
    robot.start()
    with pytest.raises(fs020n.LimitError, match="watchdog"):
        robot.servo(watchdog=2.0)
    with pytest.raises(fs020n.LimitError, match="on_watchdog"):
        robot.servo(on_watchdog="ignore")


def test_the_watchdog_stops_the_program_when_pushes_stop(robot, emu):
    servo = robot.servo(watchdog=0.1)
    for k in range(20):
        servo.push([0.02 * k, 0, -90, 0, -90, 0])
        time.sleep(0.01)
    time.sleep(0.6)
    assert servo.done()
    with pytest.raises(fs020n.MotionError, match="watchdog") as e:
        servo.push(HOME)
    assert "robot.start()" in str(e.value)
    report = servo.stop()
    assert report.outcome == "watchdog"
    assert emu.newest_command == 2 and not emu.program_running
    robot.start()
    with robot.servo(on_watchdog="brake", watchdog=0.1) as servo:
        servo.push(emu.joints)
        time.sleep(0.6)
        assert servo.done()
    assert emu.newest_command == 5 and emu.program_running


def test_hold_while_servoing_is_a_motion_error(robot, emu):
    servo = robot.servo(watchdog=0.5)
    servo.push(HOME)
    time.sleep(0.05)
    emu.set_panel(run=False)
    with pytest.raises(fs020n.MotionError) as e:
        for _ in range(100):
            servo.push(HOME)
            time.sleep(0.01)
    assert e.value.blockers == [("RUN/HOLD is on HOLD", "switch RUN/HOLD to RUN")]
    with pytest.raises(fs020n.MotionError):
        servo.stop()
