import csv
import json
import math
import time

import pytest

import fs020n
from conftest import HOME, effective


def test_status_has_the_documented_fields(emu):
    with fs020n.Robot(emu.address) as robot:
        s = robot.status()
        assert s.error == 0 and s.error_name is None and s.error_message is None
        assert (s.run, s.repeat, s.teach_lock, s.power) == (True, True, False, True)
        assert s.program_running is False
        assert isinstance(s.timer, float) and 0.0 <= s.timer < 10.0
        assert s.joints == HOME
        assert s.pose == pytest.approx((850.0, 0.0, 1153.5, 0.0, 180.0, 0.0), abs=1e-6)
        assert s.blockers == [("the motion program is not running",
                               "start the motion program first (robot.start())")]
        assert not s.ready
        cached = robot.status(fresh=False)
        assert cached.joints == HOME and cached.age_s >= 0.0
        assert "Status(" in repr(s)
        assert robot.address == emu.address and robot.is_connected


def test_preflight_names_every_blocker_with_its_remedy(emu):
    emu.set_panel(run=False, repeat=False, teach_lock=True)
    with fs020n.Robot(emu.address) as robot:
        with pytest.raises(fs020n.NotReadyError) as e:
            robot.preflight()
        remedies = dict(e.value.blockers)
        assert remedies == {
            "TEACH/REPEAT is on TEACH": "switch TEACH/REPEAT to REPEAT",
            "TEACH LOCK is ON": "turn TEACH LOCK off",
            "RUN/HOLD is on HOLD": "switch RUN/HOLD to RUN",
        }
        assert "switch RUN/HOLD to RUN" in str(e.value)
        with pytest.raises(fs020n.NotReadyError):
            robot.start()
        assert emu.program_running is False
        emu.set_panel(run=True, repeat=True, teach_lock=False)
        robot.preflight()
        robot.start()
        assert robot.status().program_running and emu.program_running


def test_speed_is_checked_and_set(emu):
    with fs020n.Robot(emu.address) as robot:
        before = effective(emu)
        for bad in [0, 101, math.nan, -5]:
            with pytest.raises(fs020n.LimitError) as e:
                robot.set_speed(bad)
            assert isinstance(e.value, ValueError)
            assert "1 to 100" in str(e.value)
        assert effective(emu) == before
        robot.set_speed(42)
        assert emu.monitor_speed == 42.0


def test_move_joints_waits_and_reports(robot, emu):
    report = robot.move_joints([0, 10, -80, 0, -90, 0])
    assert report.reached is True
    assert report.error_deg <= 0.1
    assert 0.0 < report.duration_s < 10.0
    assert report.target == [0.0, 10.0, -80.0, 0.0, -90.0, 0.0]
    assert emu.joints == pytest.approx(report.target, abs=0.1)
    assert emu.newest_command == 6
    assert "reached=True" in repr(report)


def test_move_joints_accepts_numpy_and_refuses_bad_targets_before_sending(robot, emu):
    np = pytest.importorskip("numpy")
    report = robot.move_joints(np.array([5, 0, -90, 0, -90, 0], dtype=np.float32))
    assert report.reached and emu.joints[0] == pytest.approx(5.0, abs=0.1)
    before = effective(emu)
    with pytest.raises(fs020n.LimitError, match="JT1") as e:
        robot.move_joints([500, 0, -90, 0, -90, 0])
    assert isinstance(e.value, ValueError)
    with pytest.raises(fs020n.LimitError, match="not a finite number"):
        robot.move_joints(np.array([0, math.nan, -90, 0, -90, 0]))
    with pytest.raises(ValueError, match="6 values"):
        robot.move_joints([0, 0, -90])
    with pytest.raises(fs020n.LimitError, match="tolerance"):
        robot.move_joints(HOME, tolerance=0)
    assert effective(emu) == before, "nothing was sent"
    assert robot.stats()["refused_before_sending"] == 2  # range and NaN


def test_move_without_waiting_then_wait_cancel_and_done(robot, emu):
    robot.set_speed(10)
    move = robot.move_joints([40, 0, -90, 0, -90, 0], wait=False)
    assert isinstance(move, fs020n.Move)
    assert move.target[0] == 40.0 and move.planned_duration_s > 0.5
    time.sleep(0.3)
    assert not move.done()
    assert 0.0 < move.progress < 1.0 and move.remaining_deg > 1.0
    move.cancel()
    report = move.wait()
    assert report.reached is False and report.error_deg > 1.0
    assert emu.newest_command == 2, "a sure stop: 5 then 2"
    robot.set_speed(100)
    robot.start()
    move = robot.move_joints(HOME, wait=False)
    report = move.wait(timeout=20)
    assert report.reached and move.done()
    assert move.wait() is not None  # a second wait returns the same report


def test_move_pose_through_ik(robot, emu):
    report = robot.move_pose(850, 0, 1153.5, 0, 180, 0)
    assert report.reached
    q = [8.0, 4.0, -86.0, 2.0, -85.0, 1.0]
    pose = fs020n.fk(q)
    report = robot.move_pose(pose)  # one sequence works too
    assert report.target == pytest.approx(q, abs=1e-6)
    assert emu.joints == pytest.approx(q, abs=0.1)
    before = effective(emu)
    with pytest.raises(fs020n.LimitError, match="no joint solution"):
        robot.move_pose(5000, 0, 0, 0, 180, 0)
    assert effective(emu) == before


def ramp(amplitude=10.0, seconds=1.0, n=21):
    times = [seconds * k / (n - 1) for k in range(n)]
    positions = [
        [amplitude * (0.5 - 0.5 * math.cos(math.pi * t / seconds)), 0, -90, 0, -90, 0]
        for t in times
    ]
    return times, positions


def test_stream_command_7_tracks(robot, emu):
    times, positions = ramp()
    report = robot.stream(times, positions, mode="cmd7", rate=50.0)
    assert report.outcome == "completed"
    assert report.settled
    assert 10 <= report.samples_sent <= 60  # 50 Hz for 1 s, lock-step on a busy machine
    assert report.tracking_error_rms_deg < 1.0
    assert report.tracking_error_max_deg < 2.0
    assert report.final_error_deg <= 0.5
    assert emu.joints[0] == pytest.approx(10.0, abs=0.5)
    assert robot.stats()["stream_samples"] == report.samples_sent
    assert report.lag_s is None or -0.5 < report.lag_s < 0.5
    assert 0.0 <= report.lead_s <= 0.3


def test_stream_lag_compensation_choices(robot, emu):
    times, positions = ramp()
    back = [times, positions[::-1]]
    assert robot.stream(times, positions, lag_compensation="off").lead_s == 0.0
    assert robot.stream(*back, lag_compensation=0.1).lead_s == pytest.approx(0.1)
    for bad in ["sometimes", 0.6, -0.1, math.nan]:
        with pytest.raises(fs020n.LimitError, match="lag_compensation"):
            robot.stream(times, positions, lag_compensation=bad)


def test_stream_numpy_command_6_and_velocities(robot, emu):
    np = pytest.importorskip("numpy")
    times, positions = ramp(-8.0, 1.0)
    t = np.array(times)
    q = np.array(positions)
    qd = np.gradient(q, t, axis=0)
    qd[0] = 0
    qd[-1] = 0
    report = robot.stream(t, q, qd, rate=50.0)
    assert report.outcome == "completed" and report.settled
    report = robot.stream(t[::-1] * 0 + t, q[::-1], mode="cmd6", rate=20.0)
    assert report.outcome == "completed"
    assert emu.joints[0] == pytest.approx(0.0, abs=0.5)


def test_stream_refusals_and_cancel(robot, emu):
    before = effective(emu)
    times, positions = ramp(20.0, 0.2)  # 100 deg/s peaks, 2 deg per 20 ms cycle: too coarse
    with pytest.raises(fs020n.LimitError, match="steps"):
        robot.stream(times, positions)
    far = [[30, 0, -90, 0, -90, 0], [31, 0, -90, 0, -90, 0]]
    with pytest.raises(fs020n.LimitError, match="move to its first point"):
        robot.stream([0, 1], far)
    with pytest.raises(fs020n.LimitError, match="times has 3"):
        robot.stream([0, 1, 2], far)
    with pytest.raises(fs020n.LimitError, match="cmd7"):
        robot.stream([0, 1], [HOME, HOME], mode="fast")
    assert effective(emu) == before
    times, positions = ramp(20.0, 3.0, 61)
    stream = robot.stream(times, positions, wait=False)
    assert isinstance(stream, fs020n.Stream)
    with pytest.raises(fs020n.BusyError):
        robot.move_joints(HOME)
    time.sleep(0.5)
    assert 0.0 < stream.progress < 1.0 and not stream.done()
    stream.cancel()
    report = stream.wait()
    assert report.outcome == "cancelled"
    assert stream.done()
    assert emu.newest_command == 2
    assert 0.5 < emu.joints[0] < 19.0


def test_stop_and_cancel(robot, emu):
    s = robot.cancel()
    assert isinstance(s, fs020n.Status) and emu.newest_command == 2  # 5 then 2
    time.sleep(0.1)
    assert emu.program_running is False
    robot.start()
    s = robot.stop()
    assert emu.newest_command == 2
    time.sleep(0.1)  # the program ends once signal 2007 has been stable for 50 ms
    assert robot.status().program_running is False
    with pytest.raises(fs020n.NotReadyError, match="robot.start"):
        robot.move_joints(HOME)
    robot.start()
    assert robot.status().program_running


def test_stats_raw_clock_and_close(emu):
    robot = fs020n.Robot(emu.address)
    reply = robot.send_raw("0 0 0")
    assert reply.startswith(" 1040 ") and len(reply.split()) == 14
    with pytest.raises(fs020n.LimitError, match="allow_motion"):
        robot.send_raw("1040 6 9 0 0 0 0 0 -90 0 -90 0")
    t = robot.server_time()
    assert isinstance(t, float) and t >= 0
    for _ in range(20):
        robot.status()
    st = robot.stats()
    assert st["requests"] >= 22 and st["replies"] == st["requests"]
    assert st["rtt"]["count"] == st["replies"]
    assert 0 < st["rtt"]["min_s"] <= st["rtt"]["mean_s"] <= st["rtt"]["max_s"] < 1.0
    assert set(st) >= {"keepalive_polls", "late_replies", "links_lost", "stream_samples"}
    robot.close()
    robot.close()  # twice is fine
    assert not robot.is_connected
    assert emu.last_session_end == "end_command" and not emu.session_open
    with pytest.raises(fs020n.LinkLostError) as e:
        robot.status()
    assert isinstance(e.value, ConnectionError)
    assert "reconnect" in str(e.value)


@pytest.mark.parametrize("suffix, fmt", [(".csv", "csv"), (".jsonl", "jsonl")])
def test_recording(emu, tmp_path, suffix, fmt):
    path = tmp_path / f"run{suffix}"
    with fs020n.Robot(emu.address, record=path) as robot:
        robot.set_speed(30)
    lines = path.read_text().splitlines()
    if fmt == "csv":
        rows = list(csv.DictReader(lines))
        texts = [r["text"] for r in rows]
        dirs = {r["dir"] for r in rows}
    else:
        rows = [json.loads(line) for line in lines]
        texts = [r["text"] for r in rows]
        dirs = {r["dir"] for r in rows}
    assert "1040 3 1 30" in " ".join(texts)
    assert "1040 255 0" in texts
    assert dirs == {"tx", "rx", "event"}
    with pytest.raises(fs020n.LimitError, match="record_format"):
        fs020n.Robot(emu.address, record=path, record_format="xml")


def test_stream_pacing_held_sends_targets_without_velocity(emu, tmp_path):
    """`pacing="held"` (default) sends points of the trajectory with zero velocity, each kept
    for a span; `"extrapolated"` sends the trajectory's velocity with every sample."""
    times, positions = ramp()
    velocities = {}
    for pacing, path in [("held", tmp_path / "held.jsonl"),
                         ("extrapolated", tmp_path / "extrapolated.jsonl")]:
        with fs020n.Robot(emu.address, record=path) as robot:
            robot.set_speed(100)
            robot.start()
            if pacing == "extrapolated":
                positions = positions[::-1]
            report = robot.stream(times, positions, pacing=pacing)
            assert report.outcome == "completed"
        samples = [r["text"].split() for r in map(json.loads, path.read_text().splitlines())
                   if r["dir"] == "tx" and r["text"].startswith("1040 7 ")]
        # 1040 7 n t step q1..q6 v1..v6 a1..a6: the velocities are fields 11-16.
        velocities[pacing] = [float(v) for s in samples for v in s[11:17]]
        assert samples, pacing
    assert all(v == 0.0 for v in velocities["held"])
    assert any(v != 0.0 for v in velocities["extrapolated"])
    with fs020n.Robot(emu.address) as robot:
        with pytest.raises(ValueError, match="held"):
            robot.stream(times, positions, pacing="sometimes")
