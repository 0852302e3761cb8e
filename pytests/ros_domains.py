"""ROS domain ids for the tests of one run: each node a test starts gets a domain no other node
of the run uses. Drawn at random, two nodes could share one (1 in 131 per pair) and answer each
other's requests: a goal became "unknown", another was refused."""

import random

_FREE = list(range(100, 231))
random.shuffle(_FREE)


def fresh_domain() -> int:
    """A ROS domain id (100-230) not given out before in this test run."""
    if not _FREE:
        raise RuntimeError("every ROS domain id 100-230 is used in this test run")
    return _FREE.pop()
