"""Fixtures: a fresh embedded emulator (real time, free loopback port) per test, and a robot
connected to it, speed set and program started."""

import pytest

import fs020n

HOME = [0.0, 0.0, -90.0, 0.0, -90.0, 0.0]


@pytest.fixture
def emu():
    with fs020n.Emulator() as e:
        yield e


@pytest.fixture
def robot(emu):
    with fs020n.Robot(emu.address, connect_timeout=10.0) as r:
        r.set_speed(100)
        r.start()
        yield r


def effective(emu):
    """Requests the controller acted on (version 1040); keep-alive polls do not count."""
    return emu.counters["effective_requests"]
