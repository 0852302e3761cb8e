"""The emulated controller on a network, as users drive it: a PC server written with the
socket module and the robot as its client, an AS program with two servers driven by a plain
client, the host map's checks, and an unmapped address refused with E4023."""

import pathlib
import socket
import subprocess
import sys
import time

import pytest

import fs020n

ROOT = pathlib.Path(__file__).resolve().parents[3]
AS_EXAMPLES = ROOT / "crates" / "as" / "programs" / "examples"
PY_EXAMPLES = pathlib.Path(__file__).resolve().parent.parent / "examples"
PC = {"192.168.0.10": "127.0.0.1"}


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def example(name, *args, timeout=120):
    p = subprocess.run(
        [sys.executable, str(PY_EXAMPLES / name), *args],
        capture_output=True, text=True, timeout=timeout,
    )
    assert p.returncode == 0, p.stdout + p.stderr
    return p.stdout


def test_the_pick_and_place_robot_connects_to_a_plain_python_pc_server_and_reports_each_part(
        tmp_path):
    # The program hard-codes its cell's PC at 192.168.0.10:48200; this test's PC listens on a
    # free port, written into a copy of the program (a user keeps 48200).
    port = free_port()
    text = (AS_EXAMPLES / "pick_place_client.as").read_text().replace("48200", str(port))
    program = tmp_path / "pick_place_client.as"
    program.write_text(text)
    with fs020n.Emulator(as_program=str(program), hosts=PC, monitor_speed=100) as emu:
        out = example("pc_server.py", "--port", str(port), "--parts", "2", "--timeout", "30")
        assert emu.network["hosts"] == PC
        assert emu.network["address"] == "192.168.0.2"
    lines = out.splitlines()
    # The robot is seen at its real address (loopback): the PC side is plain sockets.
    assert lines[1] == "robot at 127.0.0.1 says READY"
    assert lines[2:] == ["part 1: PLACED 1", "part 2: PLACED 2", "robot says BYE"]


def test_a_program_with_two_servers_is_driven_by_a_plain_client_on_both_ports():
    program = AS_EXAMPLES / "two_ports.as"
    with fs020n.Emulator(as_program=str(program), port_map={9111: 0, 9112: 0}) as emu:
        commands = emu.wait_port(9111)
        state = emu.wait_port(9112)
        assert emu.program_ports == {9111: commands, 9112: state}
        out = example("two_ports_client.py", "--commands", str(commands), "--state", str(state))
        assert emu.monitor_speed == 30
    lines = out.splitlines()
    assert lines[:5] == [
        "OUT 5 -> OK", "SPEED 30 -> OK", "OFF 5 -> OK", "OUT 2 -> OK", "COUNT -> OK 5",
    ]
    assert lines[5].split() == ["state:", "STATE", "5", "0", "-1"]


def test_an_unmapped_address_is_not_reached_and_the_program_sees_e4023():
    program = AS_EXAMPLES / "pick_place_client.as"
    with fs020n.Emulator(as_program=str(program)) as emu:
        text = ""
        for _ in range(200):
            terminal = emu.snapshot()["program"]["terminal"]
            text = " ".join(str(line) for line in terminal)
            if "-34023" in text:
                break
            time.sleep(0.01)
        assert "-34023" in text, text


def test_host_map_and_port_map_entries_are_checked():
    with pytest.raises(ValueError, match="not an IPv4"):
        fs020n.Emulator(hosts={"pc": "127.0.0.1"})
    with pytest.raises(ValueError, match="not an IP address"):
        fs020n.Emulator(hosts={"192.168.0.10": "localhost"})
    with pytest.raises(ValueError, match="192.168.0.2"):
        fs020n.Emulator(address="robot")
    with pytest.raises(ValueError, match="program's port"):
        fs020n.Emulator(port_map={0: 5000})


def test_a_port_the_program_never_listens_on_times_out():
    with fs020n.Emulator(as_program=str(AS_EXAMPLES / "two_ports.as"),
                         port_map={9111: 0, 9112: 0}) as emu:
        with pytest.raises(TimeoutError, match="port 9999"):
            emu.wait_port(9999, timeout=0.2)


GREETER = """\
.PROGRAM srv() ; greets every client on port 9200
  TCP_LISTEN .ret, 9200
  WHILE TRUE DO
    TCP_ACCEPT .sock, 9200, 60
    IF .sock >= 0 THEN
      .$out[1] = "OFF" + $CHR(13) + $CHR(10)
      IF SIG(1001) THEN
        .$out[1] = "ON" + $CHR(13) + $CHR(10)
      END
      TCP_SEND .ret, .sock, .$out[1], 1, 5
      TCP_CLOSE .ret, .sock
    END
  END
.END
"""


def test_a_program_that_is_no_autostart_program_is_started_with_pcexecute(tmp_path):
    program = tmp_path / "greeter.as"
    program.write_text(GREETER)
    with fs020n.Emulator(as_program=str(program), port_map={9200: 0},
                         pcexecute=["2: srv, -1"], signals={1001: True}) as emu:
        # Served when the constructor returns: no wait_port, one connection.
        port = emu.program_ports[9200]
        with socket.create_connection(("127.0.0.1", port), timeout=10) as s:
            got = s.makefile("rb").readline()
    assert got == b"ON\r\n"


def test_a_start_the_controller_refuses_raises_with_its_error(tmp_path):
    program = tmp_path / "greeter.as"
    program.write_text(GREETER)
    with pytest.raises(Exception, match=r"PCEXECUTE 1: sv: \(P1038\)"):
        fs020n.Emulator(as_program=str(program), pcexecute=["sv"])
    with pytest.raises(ValueError, match="PC task"):
        fs020n.Emulator(as_program=str(program), pcexecute=["7: srv"])
