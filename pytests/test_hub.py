"""`fs020n hub` end to end: an emulator (`fs020n sim`) behind it, raw protocol-1040 clients
and an independent Foxglove WebSocket client in front of it, all real processes on loopback.

The timing of the stops is asserted on virtual time in crates/web/tests/hub.rs; here the stop
must come from the hub (command 2, the hub's session kept), long before the controller's own
5 s timeout could have acted.
"""

import asyncio
import json
import math
import struct
import subprocess
import sys
import textwrap
import time

import pytest
import websockets

from webtools import Raw, http_json, start_hub, start_sim, wait_until

FENCE = """
speed_cap_percent = 50
[joints]
min_deg = [-45, -30, -150, -180, -120, -360]
max_deg = [ 45,  80,  -10,  180,  -10,  360]
[workspace]
min_mm = [ 300, -900,  300]
max_mm = [1500,  900, 1900]
"""


@pytest.fixture
def rig(tmp_path):
    sim = start_sim()
    fence = tmp_path / "fence.toml"
    fence.write_text(FENCE)
    record = tmp_path / "session.jsonl"
    hub = start_hub(
        sim.info["listen"],
        "--fence", str(fence),
        "--record", str(record),
        "--foxglove", "127.0.0.1:0",
    )
    yield sim, hub, record
    hub.stop()
    sim.stop()


def sim_state(sim):
    return http_json(sim.info["pendant"], "/state")


def hub_state(hub):
    return http_json(hub.info["http"], "/state")


def newest(sim):
    c = sim_state(sim)["session"]["newest_command"]
    return c and c["number"]


def test_a_raw_client_moves_the_arm_through_the_hub(rig):
    sim, hub, record = rig
    assert sim_state(sim)["monitor_speed_percent"] == 50.0, "the fence's cap, set on connect"
    a = Raw(hub.info["listen"])
    reply = a.request("1040 3 1 40")
    assert reply[0] == 1040
    reply = a.request("1040 1 0")
    assert reply[6] == -1, "program running, in the controller's own reply"
    a.request("1040 6 9 0 0 0 20 10 -80 0 -90 0")

    def arrived():
        r = a.request("0 0 0")
        return abs(r[8] - 20.0) < 1e-3 and r

    reply = wait_until(arrived, every=0.1, what="JT1 at 20 through the hub")
    assert a.joints(reply) == [20.0, 10.0, -80.0, 0.0, -90.0, 0.0]
    assert sim_state(sim)["joints_deg"][:3] == [20.0, 10.0, -80.0]
    a.close()
    # Everything that passed through is in the recording.
    lines = [json.loads(l) for l in record.read_text().splitlines()]
    sent = [l["text"] for l in lines if l["dir"] == "tx"]
    assert "1040 6 9 0 0 0 20 10 -80 0 -90 0" in sent
    assert "1040 3 1 40" in sent and "1040 3 1 50" in sent


def test_a_second_clients_motion_and_a_fence_violation_are_refused(rig):
    sim, hub, _ = rig
    a = Raw(hub.info["listen"])
    b = Raw(hub.info["listen"])
    a.request("1040 1 0")
    assert newest(sim) == 1
    before = sim_state(sim)["counters"]["effective_requests"]
    reply = b.request("1040 6 9 0 0 0 30 0 -90 0 -90 0")
    assert reply is not None and reply[0] == 1040, "answered with the current status"
    # Outside the fence's JT1 range [-45, 45].
    reply = a.request("1040 6 9 0 0 0 60 0 -90 0 -90 0")
    assert reply is not None and reply[8] == 0.0
    # Above the cap.
    a.request("1040 3 1 90")
    assert sim_state(sim)["counters"]["effective_requests"] == before, "none reached the robot"
    assert newest(sim) == 1
    assert sim_state(sim)["monitor_speed_percent"] == 50.0
    events = hub_state(hub)["events"]
    refusals = [e for e in events if e["kind"] == "refused"]
    assert [e["refusal"] for e in refusals] == ["no_control", "fence", "fence"], refusals
    controller = hub_state(hub)["controller"]
    assert refusals[0]["client"] != controller and "holds control" in refusals[0]["message"]
    assert refusals[1]["client"] == controller
    assert "JT1 target 60.000 deg is outside the fence's range" in refusals[1]["message"]
    assert "cap of 50 %" in refusals[2]["message"]
    a.close()
    b.close()


CLIENT = textwrap.dedent(
    """
    import socket, sys, time
    s = socket.create_connection(("{host}", {port}))
    s.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
    def req(t):
        s.sendall(t.encode())
        b = b""
        while len(b.split()) < 14:
            b += s.recv(1024)
    req("1040 3 1 30"); req("1040 1 0"); req("1040 6 9 0 0 0 -44 0 -90 0 -90 0")
    print("moving", flush=True)
    while True:
        req("0 0 0"); time.sleep(0.1)
    """
)


def test_a_killed_controlling_client_stops_the_arm_at_once(rig):
    sim, hub, _ = rig
    host, port = hub.info["listen"].rsplit(":", 1)
    session = sim_state(sim)["session"]["id"]
    client = subprocess.Popen([sys.executable, "-c", CLIENT.format(host=host, port=port)],
                              stdout=subprocess.PIPE, text=True)
    try:
        assert client.stdout.readline().strip() == "moving"
        wait_until(lambda: abs(sim_state(sim)["velocities_deg_s"][0]) > 10.0, what="the arm moving")
        client.kill()  # mid-move, without a word
        killed = time.monotonic()
        state = wait_until(
            lambda: (s := sim_state(sim)) and max(map(abs, s["velocities_deg_s"])) == 0.0 and s,
            timeout=10, every=0.02, what="the arm standing still")
        assert time.monotonic() - killed < 3.0, "long before the controller's own 5 s"
    finally:
        client.kill()
        client.wait()
    assert state["session"]["newest_command"]["number"] == 2, "stopped by command 2"
    assert state["task"] == "not_running"
    assert state["session"]["id"] == session, "the hub's session with the controller goes on"
    assert state["joints_deg"][0] > -44.0, "stopped part-way"
    h = hub_state(hub)
    assert h["controller"] is None and h["counters"]["stops_on_client_end"] == 1
    assert any("disconnected: stopping the robot (command 2)" in e["message"] for e in h["events"])


async def foxglove_messages(url, counts):
    """An independent Foxglove WebSocket client: subscribes to the topics of `counts`, returns
    the advertised channels and the first `counts[topic]` messages of each (decoded JSON)."""
    topics = list(counts)
    async with websockets.connect(url, subprotocols=["foxglove.sdk.v1"], max_size=None) as ws:
        assert ws.subprotocol == "foxglove.sdk.v1"
        channels = {}
        while not all(t in channels for t in topics):
            msg = json.loads(await asyncio.wait_for(ws.recv(), 10))
            if msg["op"] == "advertise":
                for c in msg["channels"]:
                    channels[c["topic"]] = c
        subs = {i + 1: t for i, t in enumerate(topics)}
        await ws.send(json.dumps({"op": "subscribe", "subscriptions": [
            {"id": i, "channelId": channels[t]["id"]} for i, t in subs.items()]}))
        got = {t: [] for t in topics}
        while any(len(got[t]) < counts[t] for t in topics):
            data = await asyncio.wait_for(ws.recv(), 10)
            if isinstance(data, str):
                continue
            assert data[0] == 1, "MessageData"
            sub, _log_time = struct.unpack_from("<IQ", data, 1)
            if len(got[subs[sub]]) < counts[subs[sub]]:
                got[subs[sub]].append(json.loads(data[13:]))
        return channels, got


def test_an_independent_foxglove_client_receives_joint_states(rig):
    sim, hub, _ = rig
    url = hub.info["foxglove"]
    assert url.startswith("ws://127.0.0.1:")
    a = Raw(hub.info["listen"])
    a.request("1040 1 0")
    a.request("1040 6 9 0 0 0 15 5 -85 0 -90 0")
    # Until the reply reads 15.000: the arm has arrived (14.999 is still on its way).
    wait_until(lambda: abs(a.request("0 0 0")[8] - 15.0) < 5e-4, every=0.1, what="the move")
    channels, got = asyncio.run(foxglove_messages(url, {"/joint_states": 3, "/robot_description": 1}))
    js = channels["/joint_states"]
    assert js["encoding"] == "json" and js["schemaName"] == "sensor_msgs/msg/JointState"
    assert channels["/tf"]["schemaName"] == "foxglove.FrameTransforms"
    for m in got["/joint_states"]:
        assert m["name"] == [f"joint_{i}" for i in range(1, 7)]
        expected = [15.0, 5.0, -85.0, 0.0, -90.0, 0.0]
        # Within the replies' 0.001° (a hub poll answered just before the test's last one may
        # still arrive after the subscription).
        assert all(abs(p - e * 3.141592653589793 / 180) < 1.1e-3 * 3.141592653589793 / 180
                   for p, e in zip(m["position"], expected)), m
        assert m["header"]["stamp"]["sec"] > 1_700_000_000
    urdf = got["/robot_description"][0]["data"]
    assert '<joint name="joint_6" type="revolute">' in urdf
    a.close()


def test_the_hub_records_everything_that_passes_through_to_mcap(tmp_path):
    """`hub --record FILE.mcap`: the face client's requests and the replies, the joint states and
    the commanded targets, read back by the Python `mcap` reader and `mcap-ros2-support`."""
    from mcap.reader import make_reader
    from mcap_ros2.decoder import DecoderFactory

    sim = start_sim()
    record = tmp_path / "hub.mcap"
    hub = start_hub(sim.info["listen"], "--record", str(record))
    try:
        a = Raw(hub.info["listen"])
        a.request("1040 1 0")
        a.request("1040 6 9 0 0 0 12 0 -90 0 -90 0")
        wait_until(lambda: abs(a.request("0 0 0")[8] - 12.0) < 1e-3, every=0.1, what="the move")
        a.request("1040 2 0")
        a.close()
    finally:
        hub.stop()  # SIGTERM: a clean end writes the summary
        sim.stop()
    assert hub.proc.returncode == 0, hub.stderr()
    with open(record, "rb") as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        summary = reader.get_summary()
        assert summary is not None, "a clean end writes the summary"
        topics = {c.topic for c in summary.channels.values()}
        assert {"/joint_states", "/fs020n/commanded", "/fs020n/exchange", "/fs020n/status"} <= topics
        exchanges = [json.loads(m.data) for _, _, m in reader.iter_messages(topics=["/fs020n/exchange"])]
        requests = [e["request"] for e in exchanges]
        for forwarded in ("1040 1 0", "1040 6 9 0 0 0 12 0 -90 0 -90 0", "1040 2 0"):
            assert forwarded in requests, requests[-20:]
        assert all(e["reply"] for e in exchanges if e["request"] == "1040 6 9 0 0 0 12 0 -90 0 -90 0")
        f.seek(0)
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        commanded = [m for _, _, _, m in reader.iter_decoded_messages(topics=["/fs020n/commanded"])]
        assert any(abs(c.position[0] - 12.0 * 3.141592653589793 / 180) < 1e-9 for c in commanded)
        f.seek(0)
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        states = [m for _, _, _, m in reader.iter_decoded_messages(topics=["/joint_states"])]
        assert list(states[-1].name) == [f"joint_{i}" for i in range(1, 7)]
        # The replies carry 3 decimals of a degree; the wait above allowed 0.001°.
        assert abs(states[-1].position[0] - 12.0 * 3.141592653589793 / 180) < math.radians(1.5e-3)
