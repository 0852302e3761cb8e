"""The ROS 2 node (`fs020n ros2`) seen from a client on eProsima Fast DDS, the library under
rmw_fastrtps_cpp (ROS 2's default middleware): the node's default request/reply mapping
("enhanced": the request identity travels in the DDS sample's related-sample-identity, not in
the payload) checked against the real library rather than against our own reading of it.

The client is a small C++ program (pytests/fastdds_peer/peer.cpp) on Debian's libfastrtps-dev and
libfastcdr-dev, built here with g++ into target/fastdds_peer/ (scripts/setup-system installs the
packages). It behaves as an action client on rmw_fastrtps does: one reply reader and one request
writer per action service, each request written with its reply reader's GUID in the
related-sample-identity, each reply matched by the related-sample-identity the node sends back.
The tests drive it over a line protocol on stdin/stdout (documented in peer.cpp).

DDS stays on 127.0.0.1: the node runs with --localhost-only, the peer has a UDPv4 transport
restricted to 127.0.0.1 with 127.0.0.1 as its initial peer; each test has its own random domain.
"""

import json
import os
import shutil
import subprocess
import threading
import time
import uuid
from pathlib import Path

import pytest

from ros_domains import fresh_domain

from test_ros2 import HOME_RAD, TIMEOUT, Node, wait_until

ROOT = Path(__file__).resolve().parent.parent
SOURCE = ROOT / "pytests" / "fastdds_peer" / "peer.cpp"
BINARY = ROOT / "target" / "fastdds_peer" / "fastdds_peer"
ACTION = "fs020n_controller/follow_joint_trajectory"

STATUS_UNKNOWN, STATUS_SUCCEEDED, STATUS_CANCELED = 0, 4, 5
CANCEL_ERROR_NONE, CANCEL_REJECTED, CANCEL_UNKNOWN_GOAL_ID, CANCEL_GOAL_TERMINATED = 0, 1, 2, 3


@pytest.fixture(scope="session")
def peer_binary():
    """The peer, built with g++ when its source is newer than the binary (about 5 s)."""
    header = Path("/usr/include/fastdds/dds/domain/DomainParticipantFactory.hpp")
    cxx = os.environ.get("CXX", "g++")
    missing = [what for what, ok in (
        ("libfastrtps-dev", header.exists()),
        ("libfastcdr-dev", Path("/usr/include/fastcdr/Cdr.h").exists()),
        ("g++", shutil.which(cxx) is not None),
    ) if not ok]
    assert not missing, (
        f"the Fast DDS peer needs {', '.join(missing)}: run scripts/setup-system "
        f"(or apt-get install -y {' '.join(missing)})")
    if not BINARY.exists() or BINARY.stat().st_mtime < SOURCE.stat().st_mtime:
        BINARY.parent.mkdir(parents=True, exist_ok=True)
        started = time.monotonic()
        built = subprocess.run(
            [cxx, "-std=c++17", "-O1", "-Wall", "-Wextra", "-Werror", "-o", str(BINARY), str(SOURCE),
             "-lfastrtps", "-lfastcdr"],
            capture_output=True, text=True)
        assert built.returncode == 0, f"the Fast DDS peer did not build:\n{built.stderr}"
        print(f"built {BINARY} in {time.monotonic() - started:.1f} s")
    return str(BINARY)


class FastDdsPeer:
    """One `fastdds_peer` process: one Fast DDS participant, one action client."""

    def __init__(self, binary, domain, *extra):
        self.proc = subprocess.Popen([binary, str(domain), ACTION, *extra], stdin=subprocess.PIPE,
                                     stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        self.events = []
        self.stderr = []
        self.cond = threading.Condition()
        threading.Thread(target=self._read, daemon=True).start()
        threading.Thread(target=lambda: self.stderr.extend(self.proc.stderr), daemon=True).start()
        self.identity = self.wait_for("the peer to start", lambda e: e["event"] == "ready")

    def _read(self):
        for line in self.proc.stdout:
            with self.cond:
                self.events.append(json.loads(line))
                self.cond.notify_all()

    def command(self, line):
        self.proc.stdin.write(line + "\n")
        self.proc.stdin.flush()

    def wait_for(self, what, predicate, timeout=TIMEOUT):
        deadline = time.monotonic() + timeout
        with self.cond:
            while True:
                found = [e for e in self.events if predicate(e)]
                if found:
                    return found[0]
                left = deadline - time.monotonic()
                if left <= 0 or self.proc.poll() is not None:
                    raise AssertionError(f"timed out waiting for {what}; events {self.events}; "
                                         f"stderr {''.join(self.stderr)}")
                self.cond.wait(min(left, 0.5))

    def wait_matched(self):
        self.command(f"wait_matched {TIMEOUT}")
        event = self.wait_for("discovery", lambda e: e["event"] in ("matched", "timeout"), TIMEOUT + 10)
        assert event["event"] == "matched", "the node's action services were not discovered"

    def reply(self, tag, timeout=TIMEOUT):
        return self.wait_for(f"the reply to {tag}", lambda e: e["event"] == "reply" and e["tag"] == tag, timeout)

    def of(self, kind):
        with self.cond:
            return [e for e in self.events if e["event"] == kind]

    def forget(self):
        """Drops the events seen so far (the warm-up's), keeping the identity."""
        with self.cond:
            self.events.clear()

    def last_seq(self, service):
        sent = [e["seq"] for e in self.of("sent") if e["service"] == service]
        return max(sent, default=0)

    def warm_up(self, service, tries=6, settle=10.0):
        """One answered request on `service` that changes nothing (a goal the node rejects, the
        result or a cancel of an id it never saw), sent again until answered: a request written
        the moment this client's endpoints match can be lost while the node has not yet matched
        them in turn (a discovery race of DDS volatile endpoints, as between any two ROS 2
        participants), and a test about correlation should not depend on it."""
        for attempt in range(tries):
            tag = f"warm-{service}-{len(self.of('sent'))}"
            line = {
                "send_goal": lambda: goal_line("send_goal", tag, new_id(), jt1(3.0), 4.0),
                "get_result": lambda: f"get_result {tag} {new_id()}",
                "cancel_goal": lambda: f"cancel {tag} {new_id()} 0 0",
            }[service]()
            self.command(line)
            try:
                self.reply(tag, timeout=settle)
                return
            except AssertionError:
                if self.proc.poll() is not None:
                    raise
        raise AssertionError(f"no reply on {service} in {tries} tries")

    def close(self):
        if self.proc.poll() is None:
            self.command("quit")
            try:
                self.proc.wait(TIMEOUT)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait(TIMEOUT)
        self.proc.stdin.close()
        return self.proc.returncode


def goal_line(command, tag, goal_id, target_rad, seconds, steps=4, tolerance=0.0):
    """A goal from home to `target_rad`; its first point at seconds/steps (the node prepends
    where the arm is at time 0)."""
    words = [command, tag, goal_id, repr(tolerance)]
    for k in range(1, steps + 1):
        f = k / steps
        words.append(repr(seconds * f))
        words.extend(repr(a + (b - a) * f) for a, b in zip(HOME_RAD, target_rad))
    return " ".join(words)


def jt1(rad):
    target = list(HOME_RAD)
    target[0] = rad
    return target


def new_id():
    return uuid.uuid4().hex


@pytest.fixture
def domain():
    return fresh_domain()


@pytest.fixture
def node(domain):
    # --auto-start: goals start the motion program (the ~/start service is Cyclone's tests').
    n = Node(domain, extra=("--auto-start",))
    try:
        yield n
    finally:
        code = n.stop()
        assert code == 0, f"the node exited {code}; stderr: {''.join(n.stderr)}"


@pytest.fixture
def peers(peer_binary, domain):
    started = []

    def start(*extra):
        p = FastDdsPeer(peer_binary, domain, *extra)
        started.append(p)
        return p

    yield start
    for p in started:
        assert p.close() == 0, f"the peer exited badly; stderr: {''.join(p.stderr)}"


def test_a_goal_sent_through_fast_dds_is_accepted_and_its_result_comes_through_get_result(node, peers):
    peer = peers()
    peer.wait_matched()
    peer.warm_up("send_goal")
    peer.warm_up("get_result")
    goal = new_id()
    peer.command(goal_line("send_goal", "goal", goal, jt1(0.2), 2.0, tolerance=0.01))
    reply = peer.reply("goal")
    assert reply["accepted"] and reply["stamp_sec"] > 1_600_000_000, reply
    # The node answers as an rmw_fastrtps server does: the reply's related-sample-identity is
    # the reply reader's GUID (which the request carried) with the request's sequence number.
    sent = peer.wait_for("the sent goal", lambda e: e["event"] == "sent" and e["tag"] == "goal")
    assert reply["addressed_to"] == "reply_reader" and reply["seq"] == sent["seq"]
    peer.command(f"get_result result {goal}")
    result = peer.reply("result")
    assert result["status"] == STATUS_SUCCEEDED and result["error_code"] == 0, result
    assert peer.of("stray") == [] and peer.of("foreign") == [] and peer.of("error") == []


def test_two_fast_dds_clients_at_once_each_get_exactly_their_own_replies(node, peers):
    """Two participants, each an action client, send different requests at the same moment:
    one goal the node rejects and one it accepts, then result requests, then cancels. Their
    requests on each service carry the same sequence numbers, so only the GUID in the
    related-sample-identity tells the replies apart. Each client gets exactly one reply per
    request, with the content its own request asked for; the other client's replies reach its
    reader too (one reply topic) and are recognised as foreign."""
    a, b = peers(), peers()
    a.wait_matched()
    b.wait_matched()
    services = ("send_goal", "get_result", "cancel_goal")
    # Both clients' endpoints known to the node on each service (answered warm-ups), and their
    # sequence numbers brought level, before the requests that matter.
    for service in services:
        a.warm_up(service)
        b.warm_up(service)
        while a.last_seq(service) != b.last_seq(service):
            (a if a.last_seq(service) < b.last_seq(service) else b).warm_up(service)
    seq = {service: a.last_seq(service) + 1 for service in services}
    for me, other in ((a, b), (b, a)):
        wait_until("the warm-up replies seen by both", lambda: len(me.of("foreign")) >= len(other.of("reply")))
    a.forget()
    b.forget()
    bad, good = new_id(), new_id()
    a.command(goal_line("send_goal", "goal", bad, jt1(3.0), 4.0))  # beyond JT1's range
    b.command(goal_line("send_goal", "goal", good, jt1(0.2), 2.0, tolerance=0.01))
    assert a.reply("goal")["accepted"] is False
    assert b.reply("goal")["accepted"] is True
    a.command(f"get_result result {bad}")
    b.command(f"get_result result {good}")
    ra, rb = a.reply("result"), b.reply("result")
    assert ra["status"] == STATUS_UNKNOWN, ra
    assert rb["status"] == STATUS_SUCCEEDED and rb["error_code"] == 0, rb
    a.command(f"cancel cancel {new_id()} 0 0")  # an id the node never saw
    b.command(f"cancel cancel {good} 0 0")  # a goal that has ended
    ca, cb = a.reply("cancel"), b.reply("cancel")
    assert ca["return_code"] == CANCEL_UNKNOWN_GOAL_ID and ca["goals_canceling"] == [], ca
    assert cb["return_code"] == CANCEL_GOAL_TERMINATED and cb["goals_canceling"] == [], cb
    for me, other in ((a, b), (b, a)):
        sent = {(e["service"], e["seq"]) for e in me.of("sent")}
        mine = me.of("reply")
        assert sorted((e["service"], e["seq"]) for e in mine) == sorted(sent), mine
        assert {e["service"]: e["seq"] for e in mine} == seq
        assert me.of("stray") == [], "a reply named this client but no request of it"
        # Every reply of the other client reached this one's readers and was not taken as its own.
        wait_until("the other client's replies seen as foreign", lambda: len(me.of("foreign")) >= 3)
        foreign = me.of("foreign")
        assert len(foreign) == 3, foreign
        others = {e["service"]: {k: v for k, v in e.items() if k not in ("event", "guid", "tag", "addressed_to")}
                  for e in foreign}
        theirs = {e["service"]: {k: v for k, v in e.items() if k not in ("event", "tag", "addressed_to")}
                  for e in other.of("reply")}
        assert others == theirs
        reply_readers = {other.identity[s]["reply_reader"] for s in ("send_goal", "get_result", "cancel_goal")}
        assert {e["guid"] for e in foreign} == reply_readers


def test_cancel_return_codes_through_fast_dds(node, peers):
    peer = peers()
    peer.wait_matched()
    for service in ("send_goal", "get_result", "cancel_goal"):
        peer.warm_up(service)
    peer.command(f"cancel unknown {new_id()} 0 0")
    reply = peer.reply("unknown")
    assert reply["return_code"] == CANCEL_UNKNOWN_GOAL_ID and reply["goals_canceling"] == [], reply
    peer.command("cancel nothing " + "0" * 32 + " 0 0")  # cancel all, nothing running
    assert peer.reply("nothing")["return_code"] == CANCEL_REJECTED
    running = new_id()
    peer.command(goal_line("send_goal", "goal", running, jt1(0.6), 6.0, steps=6))
    assert peer.reply("goal")["accepted"] is True
    time.sleep(0.5)
    peer.command(f"cancel running {running} 0 0")
    reply = peer.reply("running")
    assert reply["return_code"] == CANCEL_ERROR_NONE, reply
    assert [g["goal_id"] for g in reply["goals_canceling"]] == [running]
    peer.command(f"get_result result {running}")
    assert peer.reply("result")["status"] == STATUS_CANCELED
    peer.command(f"cancel again {running} 0 0")
    assert peer.reply("again")["return_code"] == CANCEL_GOAL_TERMINATED
    assert peer.of("stray") == [] and peer.of("error") == []


def test_a_reply_waits_until_the_requesters_reply_reader_is_matched(node, peers):
    """rmw_fastrtps answers only once the client's reply reader (named in the request's
    related-sample-identity) is matched, so that a call right after discovery is not lost. Here
    the reply reader comes up a second after the request was written: the reply, sent to a
    volatile reader, arrives only if the node held it until it matched that reader."""
    peer = peers("1.0")
    assert peer.identity["send_goal"]["reply_reader"] != "0" * 24 + ".00000000"
    peer.command(goal_line("send_goal_on_match", "goal", new_id(), jt1(3.0), 4.0))  # rejected at once
    reply = peer.reply("goal")
    assert reply["accepted"] is False and reply["addressed_to"] == "reply_reader"
    kinds = [e["event"] for e in peer.events]
    assert kinds.index("reader_enabled") < kinds.index("reply")
    assert peer.of("stray") == [] and peer.of("error") == []
