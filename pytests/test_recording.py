"""MCAP recordings of the fs020n binary read by independent readers: the Python ``mcap``
library and ``mcap-ros2-support`` (the ROS 2 CDR decoder Foxglove's tooling uses).

The binary is ``$FS020N_BIN`` (scripts/test-all builds it)."""

import json
import math
import os
import signal
import subprocess
import time

import pytest
from mcap.reader import NonSeekingReader, make_reader
from mcap_ros2.decoder import DecoderFactory
from mcap_ros2.writer import Writer as Ros2Writer

BIN = os.environ.get("FS020N_BIN")
pytestmark = pytest.mark.skipif(not BIN, reason="FS020N_BIN is not set (run scripts/test-all)")

JOINT_NAMES = [f"joint_{i}" for i in range(1, 7)]

# sensor_msgs/msg/JointState with its dependencies, as ROS 2 tools write it.
JOINT_STATE_MSGDEF = """std_msgs/Header header
string[] name
float64[] position
float64[] velocity
float64[] effort
================================================================================
MSG: std_msgs/Header
builtin_interfaces/Time stamp
string frame_id
================================================================================
MSG: builtin_interfaces/Time
int32 sec
uint32 nanosec
"""


def run(*args, timeout=120):
    env = {k: v for k, v in os.environ.items() if k != "FS020N_ROBOT"}
    out = subprocess.run(
        [BIN, *args], capture_output=True, text=True, timeout=timeout, env=env
    )
    assert out.returncode == 0, f"{args}: {out.returncode}\n{out.stdout}\n{out.stderr}"
    return out.stdout


def reply_joints_deg(reply):
    """Fields 9-14 of a reply: the joints, degrees."""
    return [float(f) for f in reply.split()[8:14]]


@pytest.fixture(scope="module")
def demo_recording(tmp_path_factory):
    """The demo (moves and a stream on the embedded emulator) recorded to MCAP."""
    path = tmp_path_factory.mktemp("demo") / "demo.mcap"
    run("--record", str(path), "demo", timeout=300)
    return path


def test_joint_states_decode_as_ros2_messages(demo_recording):
    with open(demo_recording, "rb") as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        summary = reader.get_summary()
        assert summary is not None, "a clean end writes the summary"
        channels = {c.topic: c for c in summary.channels.values()}
        for topic in ("/joint_states", "/fs020n/commanded"):
            ch = channels[topic]
            schema = summary.schemas[ch.schema_id]
            assert ch.message_encoding == "cdr"
            assert schema.name == "sensor_msgs/msg/JointState"
            assert schema.encoding == "ros2msg"
        for topic in ("/fs020n/status", "/fs020n/exchange", "/fs020n/event"):
            assert channels[topic].message_encoding == "json"
            assert summary.schemas[channels[topic].schema_id].encoding == "jsonschema"

        states = list(reader.iter_decoded_messages(topics=["/joint_states"]))
    assert len(states) > 300
    last_time = 0
    for _schema, _channel, message, msg in states:
        assert list(msg.name) == JOINT_NAMES
        assert len(msg.position) == 6
        stamp = msg.header.stamp.sec * 1_000_000_000 + msg.header.stamp.nanosec
        assert stamp == message.log_time, "stamped with the PC receive time"
        assert message.log_time >= last_time
        last_time = message.log_time
    # The demo ends at the home pose: radians, as ROS expects.
    home = [0.0, 0.0, -math.pi / 2, 0.0, -math.pi / 2, 0.0]
    assert all(abs(a - b) < 1e-4 for a, b in zip(states[-1][3].position, home))


def test_joint_states_match_the_raw_replies(demo_recording):
    """Every JointState carries the joints of the reply text recorded beside it."""
    with open(demo_recording, "rb") as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        positions = [
            list(m.position) for _, _, _, m in reader.iter_decoded_messages(topics=["/joint_states"])
        ]
    with open(demo_recording, "rb") as f:
        exchanges = [
            json.loads(m.data)
            for _, _, m in make_reader(f).iter_messages(topics=["/fs020n/exchange"])
        ]
    replies = [e["reply"] for e in exchanges if e["reply"] is not None]
    assert len(replies) == len(positions)
    for reply, position in zip(replies, positions):
        degrees = reply_joints_deg(reply)
        assert all(abs(math.degrees(r) - d) < 1e-9 for r, d in zip(position, degrees))
    kinds = {e["kind"] for e in exchanges}
    assert {"poll", "command", "motion", "close"} <= kinds
    assert all(e["rtt_ms"] is not None and e["rtt_ms"] >= 0 for e in exchanges)
    assert exchanges[-1]["request"] == "1040 255 0"


def test_commanded_status_and_events(demo_recording):
    with open(demo_recording, "rb") as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        commanded = [
            m for _, _, _, m in reader.iter_decoded_messages(topics=["/fs020n/commanded"])
        ]
    # Four joint-move targets (no velocity), then the streamed circle (with velocities).
    assert len(commanded) > 100
    assert len(commanded[0].velocity) == 0
    assert sum(1 for m in commanded if len(m.velocity) == 6) > 100
    first_target = [math.degrees(p) for p in commanded[0].position]
    assert all(abs(a - b) < 1e-9 for a, b in zip(first_target, [20, 10, -80, 0, -80, 0]))

    with open(demo_recording, "rb") as f:
        reader = make_reader(f)
        status = [json.loads(m.data) for _, _, m in reader.iter_messages(topics=["/fs020n/status"])]
        events = [json.loads(m.data) for _, _, m in reader.iter_messages(topics=["/fs020n/event"])]
        metadata = {m.name: m.metadata for m in reader.iter_metadata()}
    assert set(status[0]) == {
        "session", "error_code", "error", "run", "repeat", "teach_lock", "power",
        "program_running", "timer_s",
    }
    assert any(s["program_running"] for s in status)
    assert all(s["error_code"] == 0 and s["error"] == "" for s in status)
    assert [e["event"] for e in events] == ["start", "connect", "end"]
    assert events[1]["text"].startswith("127.0.0.1:")
    info = metadata["fs020n"]
    assert info["client"].startswith("fs020n-client ")
    assert info["started_utc"].endswith("Z")
    assert json.loads(events[0]["text"])["started_unix_ns"] == int(info["started_unix_ns"])


def start_sim():
    proc = subprocess.Popen(
        [BIN, "--json", "sim", "--listen", "127.0.0.1:0"],
        stdout=subprocess.PIPE,
        stderr=subprocess.DEVNULL,
        text=True,
    )
    line = proc.stdout.readline()
    return proc, json.loads(line)["listen"]


def test_a_killed_recorder_leaves_a_file_every_reader_opens(tmp_path):
    sim, addr = start_sim()
    try:
        path = tmp_path / "killed.mcap"
        rec = subprocess.Popen(
            [BIN, "--robot", addr, "record", str(path), "--rate", "50"],
            stdout=subprocess.DEVNULL,
            stderr=subprocess.DEVNULL,
        )
        # Chunks close every second: wait for a few, then kill without warning.
        sizes = []
        deadline = time.monotonic() + 60
        while len(sizes) < 4 and time.monotonic() < deadline:
            time.sleep(0.2)
            size = path.stat().st_size if path.exists() else 0
            if not sizes or sizes[-1] != size:
                sizes.append(size)
        killed_at = time.time_ns()
        rec.send_signal(signal.SIGKILL)
        rec.wait(timeout=30)
        assert len(sizes) >= 4, sizes
    finally:
        sim.kill()
        sim.wait()

    # The seeking reader (what make_reader gives for a file) opens it: no summary, so it reads
    # the file from the start up to its footer.
    with open(path, "rb") as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        assert reader.get_summary() is None
        states = [m for _, _, m, _ in reader.iter_decoded_messages(topics=["/joint_states"])]
    assert len(states) >= 50
    # At most the last chunk (about a second) is lost.
    assert killed_at - states[-1].log_time < 3_000_000_000
    with open(path, "rb") as f:
        records = list(NonSeekingReader(f).iter_messages())
    assert len(records) > len(states)


def test_plot_reads_a_file_written_by_another_mcap_writer(tmp_path):
    """A ROS 2 bag-like MCAP from mcap-ros2-support's writer (joint states only) plots."""
    path = tmp_path / "foreign.mcap"
    with open(path, "wb") as f:
        writer = Ros2Writer(f)
        schema = writer.register_msgdef("sensor_msgs/msg/JointState", JOINT_STATE_MSGDEF)
        t0 = 1_700_000_000_000_000_000
        for k in range(200):
            t = t0 + k * 10_000_000
            writer.write_message(
                "/joint_states",
                schema,
                {
                    "header": {"stamp": {"sec": t // 10**9, "nanosec": t % 10**9}, "frame_id": ""},
                    # Another order than ours: names tell which is which.
                    "name": list(reversed(JOINT_NAMES)),
                    "position": [0.0, -1.5707963, 0.0, -1.5707963, 0.0, math.sin(k / 30)],
                    "velocity": [],
                    "effort": [],
                },
                log_time=t,
            )
        writer.finish()
    svg = tmp_path / "foreign.svg"
    out = json.loads(run("--json", "plot", str(path), "-o", str(svg)))
    assert out["summary"]["states"] == 200
    assert out["summary"]["round_trips"] == 0
    text = svg.read_text()
    assert sum(1 for l in text.splitlines() if l.startswith("joint ")) == 6
