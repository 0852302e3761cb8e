"""Drive a Kawasaki FS020N arm over protocol 1040 from Python.

The package wraps the Rust crates of the fs020n project:

* :class:`Robot` -- the client: status, preflight with remedies, speed, start/stop/cancel,
  joint and pose moves, trajectory streaming (command 7 on the estimated controller clock),
  online servoing (:meth:`Robot.servo`), statistics and recording. It fails closed: every
  value is checked before it is sent, and every fault is raised with what to do about it.
* :class:`Emulator` -- an emulated controller in this process on a free loopback port, rule
  for rule, with panel switches and fault injection: your tests need no robot.
* :func:`fk` / :func:`ik` -- the FS020N kinematics (mm and degrees, AS X, Y, Z, O, A, T).
* :mod:`fs020n.aio` -- the same client for asyncio.

Blocking calls release the GIL; Ctrl-C during one cancels the motion, closes the session and
re-raises ``KeyboardInterrupt``. Lists, tuples and numpy arrays are accepted wherever joints
or poses are expected. See docs/PYTHON.md.

>>> import fs020n
>>> with fs020n.Emulator() as emu, fs020n.Robot(emu.address) as robot:
...     robot.set_speed(50)
...     robot.start()
...     robot.move_joints([0, 10, -80, 0, -90, 0]).reached
True
"""

from ._fs020n import (
    HOME,
    Emulator,
    Move,
    MoveReport,
    Robot,
    Servo,
    ServoReport,
    Status,
    Stream,
    StreamReport,
    __version__,
    fk,
    ik,
    joint_limits,
)
from .errors import (
    BusyError,
    ConnectError,
    Error,
    LimitError,
    LinkLostError,
    MotionError,
    MoveTimeoutError,
    NotReadyError,
)
from . import aio

__all__ = [
    "HOME",
    "Emulator",
    "Move",
    "MoveReport",
    "Robot",
    "Servo",
    "ServoReport",
    "Status",
    "Stream",
    "StreamReport",
    "__version__",
    "fk",
    "ik",
    "joint_limits",
    "Error",
    "LimitError",
    "NotReadyError",
    "ConnectError",
    "LinkLostError",
    "MotionError",
    "MoveTimeoutError",
    "BusyError",
    "aio",
]
