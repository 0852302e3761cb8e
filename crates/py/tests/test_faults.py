"""Faults while moving: HOLD, E-stop, a controller error, a lost link, a dead address."""

import threading
import time

import pytest

import fs020n
from conftest import HOME

TARGET = [40.0, 0.0, -90.0, 0.0, -90.0, 0.0]


def test_hold_mid_move_raises_motion_error_and_the_move_does_not_resume(robot, emu):
    robot.set_speed(10)
    move = robot.move_joints(TARGET, wait=False)
    time.sleep(0.4)
    emu.set_panel(run=False)
    with pytest.raises(fs020n.MotionError) as e:
        move.wait()
    err = e.value
    assert err.blockers == [("RUN/HOLD is on HOLD", "switch RUN/HOLD to RUN")]
    assert err.remedy == "switch RUN/HOLD to RUN"
    assert err.code is None and err.code_name is None
    assert "switch RUN/HOLD to RUN" in str(err)
    # The wait stopped the move for sure (5 then 2): back on RUN, the arm stays where it is.
    assert emu.newest_command == 2
    time.sleep(0.5)  # HOLD decelerates the arm to a pause
    held = emu.joints
    emu.set_panel(run=True)
    time.sleep(1.0)
    assert emu.joints == pytest.approx(held, abs=0.05)
    assert abs(emu.joints[0] - TARGET[0]) > 10


def test_with_a_hold_timeout_the_wait_waits_out_hold(robot, emu):
    robot.set_speed(20)
    hold = threading.Timer(0.3, lambda: emu.set_panel(run=False))
    run = threading.Timer(1.0, lambda: emu.set_panel(run=True))
    hold.start()
    run.start()
    report = robot.move_joints([20, 0, -90, 0, -90, 0], hold_timeout=5.0)
    hold.join()
    run.join()
    assert report.reached and report.duration_s > 1.0
    # Held for longer than the hold timeout: the move is stopped and the wait fails.
    hold = threading.Timer(0.3, lambda: emu.set_panel(run=False))
    hold.start()
    with pytest.raises(fs020n.MoveTimeoutError, match="HOLD"):
        robot.move_joints([0, 0, -90, 0, -90, 0], hold_timeout=0.5)
    hold.join()
    emu.set_panel(run=True)


def test_estop_mid_move_raises_e3808_with_its_remedy(robot, emu):
    robot.set_speed(10)
    move = robot.move_joints(TARGET, wait=False)
    time.sleep(0.4)
    emu.press_estop()
    with pytest.raises(fs020n.MotionError) as e:
        move.wait()
    err = e.value
    assert err.code == -33808 and err.code_name == "E3808"
    assert err.remedy == "release the emergency stop, reset the error and turn motor power on"
    assert ("motor power is OFF", "turn motor power on") in err.blockers
    assert 0.0 < emu.joints[0] < TARGET[0]
    # Recovering as the remedies say.
    emu.release_estop()
    emu.reset_error()
    emu.set_panel(power=True)
    robot.preflight()
    robot.start()
    assert robot.move_joints(HOME).reached


def test_a_controller_error_mid_stream_names_the_code(robot, emu):
    times = [k * 0.05 for k in range(61)]
    positions = [[20.0 * k / 60, 0, -90, 0, -90, 0] for k in range(61)]
    stream = robot.stream(times, positions, wait=False)
    time.sleep(0.5)
    emu.raise_error("E1130")
    with pytest.raises(fs020n.MotionError) as e:
        stream.wait()
    assert e.value.code_name == "E1130" and e.value.code == -31130
    assert "reset error E1130" in e.value.remedy
    assert "Collision" in str(e.value)


def test_a_timeout_raises_move_timeout_error(robot, emu):
    robot.set_speed(1)
    with pytest.raises(fs020n.MoveTimeoutError) as e:
        robot.move_joints(TARGET, timeout=0.5)
    assert isinstance(e.value, TimeoutError) and isinstance(e.value, fs020n.MotionError)
    assert emu.newest_command == 2


def test_a_lost_link_raises_link_lost_error_and_reconnect_resumes_nothing(robot, emu):
    robot.set_speed(10)
    move = robot.move_joints(TARGET, wait=False)
    time.sleep(0.3)
    emu.drop_connection()
    with pytest.raises(fs020n.LinkLostError) as e:
        move.wait()
    assert isinstance(e.value, ConnectionError)
    assert "robot.reconnect()" in str(e.value) and "never" in str(e.value)
    with pytest.raises(fs020n.LinkLostError):
        robot.status()
    assert not robot.is_connected and "closed the connection" in robot.link_error
    time.sleep(0.5)  # the controller stops the arm (with its deceleration)
    where = emu.joints
    robot.reconnect()
    assert robot.is_connected
    time.sleep(0.3)  # a new session stops the program (signal 2007 acts after 50 ms)
    s = robot.status()
    assert s.program_running is False
    time.sleep(0.5)
    assert emu.joints == pytest.approx(where, abs=0.01), "nothing resumed"
    assert robot.stats()["reconnects"] == 1 and robot.stats()["links_lost"] == 1


def test_nobody_listening_is_a_connect_error():
    with fs020n.Emulator() as emu:
        address = emu.address
    with pytest.raises(fs020n.ConnectError) as e:
        fs020n.Robot(address, connect_timeout=0.3)
    assert isinstance(e.value, ConnectionError)
    assert "AS server program" in str(e.value)


def test_a_second_client_is_refused(emu):
    with fs020n.Robot(emu.address):
        with pytest.raises(fs020n.ConnectError, match="no other client"):
            fs020n.Robot(emu.address, connect_timeout=0.5)
