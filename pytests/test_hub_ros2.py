"""`fs020n hub --ros2`: the ROS 2 node as a face of the hub, seen from an independent DDS
participant (Cyclone DDS, as in test_ros2.py) while raw protocol-1040 clients use the hub's TCP
face, in front of an emulator (`fs020n sim`). All real processes on loopback.

The node shares the hub's one session: it holds the hub's control while it acts (a goal, a
start), a face client holding control makes it refuse, and its goals pass the hub's fence before
anything moves.
"""

import json
import math
import time

import pytest

from ros_domains import fresh_domain

from test_ros2 import (  # the DDS participant and the ROS 2 types
    RELIABLE,
    STATUS_SUCCEEDED,
    DataWriter,
    Float64MultiArray,
    GetResultRequest,
    Peer,
    Topic,
    TriggerRequest,
    diagnostics_value,
    goal_to,
    stream_commands,
    wait_until,
    with_jt1,
)
from webtools import Raw, http_json, start_hub, start_sim

FENCE = """
speed_cap_percent = 60
[joints]
min_deg = [-45, -30, -150, -180, -120, -360]
max_deg = [ 45,  80,  -10,  180,  -10,  360]
"""


@pytest.fixture(scope="module")
def rig(tmp_path_factory):
    domain = fresh_domain()
    sim = start_sim()
    fence = tmp_path_factory.mktemp("hub-ros2") / "fence.toml"
    fence.write_text(FENCE)
    hub = start_hub(
        sim.info["listen"],
        "--fence", str(fence),
        "--ros2", "--localhost-only", "--domain-id", str(domain),
        timeout=60.0,
    )
    peer = Peer(domain)
    try:
        yield sim, hub, peer
    finally:
        hub.stop()
        sim.stop()
        assert hub.proc.returncode == 0, hub.stderr()


def sim_state(sim):
    return http_json(sim.info["pendant"], "/state")


def hub_state(hub):
    return http_json(hub.info["http"], "/state")


def controller(hub):
    return hub_state(hub)["controller"]


def test_the_hub_announces_the_node_and_it_publishes_the_shared_session(rig):
    sim, hub, peer = rig
    assert hub.info["ros2"]["node"] == "/fs020n"
    assert hub.info["ros2"]["action"] == "/fs020n_controller/follow_joint_trajectory"
    joints = peer.joints()
    assert [round(math.degrees(q), 6) for q in joints] == sim_state(sim)["joints_deg"]


def test_a_goal_moves_the_arm_through_the_hub_and_gives_control_back(rig):
    sim, hub, peer = rig
    reply = peer.call(peer.start, TriggerRequest())
    assert reply.success, reply.message
    assert controller(hub) is None, "a start holds control only while it runs"
    request = goal_to(with_jt1(0.3), 2.0, tolerance=0.01, start=peer.settled_joints())
    assert peer.call(peer.send_goal, request).accepted
    result = peer.call(peer.get_result, GetResultRequest(goal_id=request.goal_id))
    assert result.status == STATUS_SUCCEEDED, result.result.error_string
    assert abs(sim_state(sim)["joints_deg"][0] - math.degrees(0.3)) < 0.6
    # The goal is over: control is back, and a face client can act.
    wait_until("control released", lambda: controller(hub) is None, timeout=10)
    messages = [e["message"] for e in hub_state(hub)["events"] if e["kind"] == "control"]
    assert any("ROS 2 node" in m and "takes control" in m for m in messages), messages
    assert any("ROS 2 node" in m and "releases control" in m for m in messages), messages
    a = Raw(hub.info["listen"])
    a.request("1040 3 1 40")
    assert sim_state(sim)["monitor_speed_percent"] == 40.0
    a.close()  # it held control: the hub stops the robot (command 2)
    wait_until("the face client's control released", lambda: controller(hub) is None, timeout=10)


def test_a_goal_beyond_the_fence_is_rejected_before_anything_moves(rig):
    sim, hub, peer = rig
    reply = peer.call(peer.start, TriggerRequest())
    assert reply.success, json.dumps([reply.message, sim_state(sim), hub_state(hub)["events"][-8:]], indent=1)
    before = peer.settled_joints()
    # JT1 to 1.0 rad = 57 deg: inside the controller's range (160), outside the fence's (45).
    request = goal_to(with_jt1(1.0), 3.0, start=before)
    assert not peer.call(peer.send_goal, request).accepted
    time.sleep(0.5)
    assert peer.joints() == pytest.approx(before, abs=1e-6)
    refusals = [e for e in hub_state(hub)["events"] if e["kind"] == "refused"]
    assert refusals and refusals[-1]["refusal"] == "fence", refusals
    assert "JT1" in refusals[-1]["message"] and "fence" in refusals[-1]["message"]
    assert controller(hub) is None


def test_while_a_face_client_holds_control_the_node_is_refused(rig):
    sim, hub, peer = rig
    a = Raw(hub.info["listen"])
    a.request("1040 1 0")  # takes control (and starts the program)
    holder = controller(hub)
    assert holder is not None
    reply = peer.call(peer.start, TriggerRequest())
    assert not reply.success and "holds control" in reply.message, reply.message
    request = goal_to(with_jt1(0.2), 2.0, start=peer.settled_joints())
    assert not peer.call(peer.send_goal, request).accepted
    assert controller(hub) == holder
    a.close()
    wait_until("control released", lambda: controller(hub) is None, timeout=10)
    # Free again: the node may act.
    assert peer.call(peer.start, TriggerRequest()).success


def test_commands_pass_the_fence_sample_by_sample_and_hold_control_while_servoing(rig):
    """~/commands through the hub: the servo holds the hub's control while it runs, every
    sample is checked against the fence (a command past it is refused and never sent), and the
    watchdog ends the servo when the commands stop, giving control back."""
    sim, hub, peer = rig
    assert peer.call(peer.start, TriggerRequest()).success
    writer = DataWriter(peer.dp, Topic(peer.dp, "rt/fs020n/commands", Float64MultiArray), qos=RELIABLE)
    wait_until("~/commands discovered", lambda: writer.get_matched_subscriptions())
    here = peer.settled_joints()
    inside = list(here)
    inside[0] = math.radians(43.0)  # the fence's JT1 limit is 45 deg
    stream_commands(writer, here, inside, 2.0, 100)
    stream_commands(writer, inside, inside, 0.5, 100)  # holding there: the arm catches up
    assert controller(hub) is not None, "the servo holds control while it runs"
    # 46 deg: inside the controller's range, a small step, but past the fence.
    past = list(inside)
    past[0] = math.radians(46.0)
    writer.write(Float64MultiArray(data=past))
    wait_until("the fence's refusal", lambda: "fence" in diagnostics_value(peer, "last_command_refused"))
    refusals = [e for e in hub_state(hub)["events"] if e["kind"] == "refused"]
    assert refusals and refusals[-1]["refusal"] == "fence", refusals
    wait_until("control released after the watchdog", lambda: controller(hub) is None, timeout=10)
    joints = sim_state(sim)["joints_deg"]
    assert abs(joints[0] - 43.0) < 0.1, joints
