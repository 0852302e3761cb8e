import re
import time

import pytest

import fs020n


def test_address_is_a_free_loopback_port_and_stop_frees_it():
    with fs020n.Emulator() as a, fs020n.Emulator() as b:
        assert re.fullmatch(r"127\.0\.0\.1:\d+", a.address)
        assert a.address != b.address
        assert a.port == int(a.address.rsplit(":", 1)[1])
        assert a.running
    assert not a.running
    with pytest.raises(fs020n.ConnectError):
        fs020n.Robot(a.address, connect_timeout=0.3)


def test_panel_estop_and_errors(emu):
    assert emu.joints == [0.0, 0.0, -90.0, 0.0, -90.0, 0.0]
    assert emu.panel == {"power": True, "run": True, "repeat": True, "teach_lock": False, "estop": False}
    emu.set_panel(run=False, teach_lock=True)
    assert emu.panel["run"] is False and emu.panel["teach_lock"] is True
    assert emu.panel["power"] is True  # not given: unchanged
    emu.set_panel(run=True, teach_lock=False)

    emu.press_estop()
    assert emu.error == -33808 and emu.error_name == "E3808"
    assert emu.panel["estop"] and not emu.panel["power"]
    with pytest.raises(fs020n.Error, match="emergency stop"):
        emu.set_panel(power=True)
    with pytest.raises(fs020n.Error, match="emergency stop"):
        emu.reset_error()
    emu.release_estop()
    emu.reset_error()
    emu.set_panel(power=True)
    assert emu.error == 0 and emu.error_name is None

    emu.raise_error("E1130")
    assert emu.error == -31130
    emu.reset_error()
    emu.raise_error(-31088)
    assert emu.error_name == "E1088"
    with pytest.raises(ValueError):
        emu.raise_error("Z12")
    with pytest.raises(fs020n.LimitError):
        emu.raise_error(0)


def test_options_snapshot_counters_and_faults():
    with fs020n.Emulator(joints=[10, 0, -90, 0, -90, 0], monitor_speed=30, run=False,
                         error="E1088", pendant=True) as emu:
        assert emu.joints[0] == 10.0
        assert emu.monitor_speed == 30.0
        assert emu.panel["run"] is False
        assert emu.error_name == "E1088"
        assert re.fullmatch(r"127\.0\.0\.1:\d+", emu.pendant_address)
        snap = emu.snapshot()
        assert snap["joints_deg"][0] == 10.0 and snap["error"]["name"] == "E1088"
        assert emu.counters["sessions"] == 0
        assert emu.session_open is False and emu.newest_command is None
        emu.set_monitor_speed(55)
        assert emu.monitor_speed == 55.0
        with pytest.raises(fs020n.LimitError):
            emu.set_monitor_speed(150)
        emu.inject("delay_replies", count=2, delay_ms=10)
        assert emu.snapshot()["pending_faults"] >= 1
        with pytest.raises(fs020n.LimitError, match="kinds"):
            emu.inject("melt_down")
        with pytest.raises(fs020n.LimitError):
            emu.inject("delay_replies", count="many")
    with pytest.raises(fs020n.Error, match="cannot start the emulator"):
        fs020n.Emulator(joints=[500, 0, 0, 0, 0, 0])


def test_a_bare_emulator_serves_its_terminal_and_nothing_else_until_a_program_runs():
    import socket

    with fs020n.Emulator(bare=True, terminal=True) as emu:
        host, port = emu.terminal_address.rsplit(":", 1)
        with socket.create_connection((host, int(port)), timeout=5) as s:
            data = b""
            while b"login:" not in data:
                data += s.recv(1024)
            s.sendall(b"as\r\n")
            while not data.endswith(b">"):
                data += s.recv(1024)
            assert b'"AUX1"' in data
        assert emu.programs == []
        assert emu.power_cycle() == []
        with pytest.raises(fs020n.ConnectError):
            fs020n.Robot(emu.address, connect_timeout=0.3)


SERVER_AS = __import__("pathlib").Path(__file__).resolve().parents[2] / "as" / "programs" / "server1040.as"


def test_an_as_program_file_runs_as_the_controller_and_a_robot_drives_it(tmp_path):
    # The project's server text plus one instruction of an application the emulator does not
    # model. It loads as not emulated: autostart.pc stops there with E0199 (-30199, the
    # emulator's own code). Declared a no-op, the program runs and serves protocol 1040.
    text = SERVER_AS.read_bytes().replace(
        b".PROGRAM autostart.pc()", b".PROGRAM autostart.pc()\r\n  GUNON 1", 1
    )
    assert b"GUNON 1" in text
    path = tmp_path / "welding_cell.as"
    path.write_bytes(text)
    with fs020n.Emulator(as_program=path) as emu:
        deadline = time.monotonic() + 10
        while emu.error != -30199 and time.monotonic() < deadline:
            time.sleep(0.01)
        assert emu.error == -30199
    with fs020n.Emulator(as_program=path, stubs=["GUNON"]) as emu:
        assert "autostart.pc" in emu.programs
        with fs020n.Robot(emu.address, connect_timeout=10) as robot:
            status = robot.status()
            assert len(status.joints) == 6


def test_stubs_need_an_as_program_or_a_bare_controller():
    with pytest.raises(ValueError, match="stubs apply to AS programs"):
        fs020n.Emulator(stubs=["GUNON"])


def test_interface_panel_shows_what_the_program_wrote(tmp_path):
    # A cell's status on its interface panel, as a pytest of the AS program reads it.
    path = tmp_path / "panel.as"
    path.write_text(
        ".PROGRAM autostart.pc()\n"
        "  IFPWPRINT 1 = \"Cell ready\", \"parts: 0\"\n"
        "  IFPLABEL 3, \"Start\"\n"
        ".END\n"
    )
    with fs020n.Emulator(as_program=path) as emu:
        deadline = time.monotonic() + 10
        panel = emu.interface_panel()
        while panel["labels"].get("3") is None and time.monotonic() < deadline:
            time.sleep(0.01)
            panel = emu.interface_panel()
        assert panel["windows"][0]["rows"] == ["Cell ready", "parts: 0", "", ""]
        assert panel["labels"]["3"][0] == "Start"
    with fs020n.Emulator() as emu:
        assert emu.interface_panel() is None
