"""Every example runs (against the embedded emulator, with short durations)."""

import json
import pathlib
import subprocess
import sys

import pytest

EXAMPLES = pathlib.Path(__file__).resolve().parent.parent / "examples"


def run(name, *args, timeout=120):
    p = subprocess.run(
        [sys.executable, str(EXAMPLES / name), *args],
        capture_output=True, text=True, timeout=timeout,
    )
    assert p.returncode == 0, p.stderr
    return p.stdout


def test_every_example_is_tested():
    # pc_server.py and two_ports_client.py run in test_network.py (with an emulated cell).
    tested = {"quickstart.py", "stream_circle.py", "faults.py", "asyncio_move.py",
              "servo_loop.py", "servo_bench.py", "pc_server.py", "two_ports_client.py"}
    assert {p.name for p in EXAMPLES.glob("*.py")} == tested


def test_quickstart():
    out = run("quickstart.py")
    assert out.count("reached=True") == 3 and "round trips:" in out


def test_stream_circle():
    out = run("stream_circle.py", "--seconds", "2", "--radius", "30")
    assert "outcome completed" in out


def test_faults():
    out = run("faults.py")
    assert "switch RUN/HOLD to RUN" in out
    assert "E3808 (-33808)" in out
    assert "reconnected: program running = False" in out


def test_asyncio_move():
    out = run("asyncio_move.py")
    assert "reached=True" in out and "cancelled at JT1" in out


def test_servo_loop():
    out = run("servo_loop.py", "--seconds", "1", "--rate", "100")
    assert out.startswith("stopped:") and "sent" in out


def test_servo_bench():
    out = run("servo_bench.py", "--rate", "200", "--seconds", "0.5")
    figures = json.loads(out.strip().splitlines()[-1])
    assert figures["client"] == "python" and figures["pushes"] == 100
    # The stop may find the last push still waiting for the previous reply: it is not sent.
    assert figures["sent"] + figures["coalesced"] + figures["unsent"] == 100
    assert figures["unsent"] <= 1
    assert figures["achieved_hz"] > 0 and figures["push_mean_us"] > 0
