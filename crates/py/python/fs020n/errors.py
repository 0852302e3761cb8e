"""Exceptions of the fs020n package.

Every message is the Rust client's, with what to do about it. Catch :class:`Error` for any
of them, or the standard base each one also derives from (``ValueError``,
``ConnectionError``, ``TimeoutError``).
"""

from __future__ import annotations

from typing import List, Optional, Tuple

__all__ = [
    "Error",
    "LimitError",
    "NotReadyError",
    "ConnectError",
    "LinkLostError",
    "MotionError",
    "MoveTimeoutError",
    "BusyError",
]


class Error(Exception):
    """Base class of every fs020n error."""


class LimitError(Error, ValueError):
    """A value refused before anything was sent: a non-finite or out-of-range target, speed,
    trajectory, pose or servo sample, a raw request the client will not send, or an invalid
    option. Nothing reached the robot."""


class NotReadyError(Error):
    """The controller's state blocks starting the program or moving.

    ``blockers`` lists each condition with its remedy, e.g.
    ``[("RUN/HOLD is on HOLD", "switch RUN/HOLD to RUN")]``.
    """

    blockers: List[Tuple[str, str]]

    def __init__(self, message: str, blockers: Optional[List[Tuple[str, str]]] = None):
        super().__init__(message)
        self.blockers = list(blockers or [])


class ConnectError(Error, ConnectionError):
    """No session could be opened within the connect timeout (the message says what to
    check)."""


class LinkLostError(Error, ConnectionError):
    """The link to the controller was lost or closed. The controller stops the robot and ends
    the program; nothing is resumed. Call ``robot.reconnect()`` and ``robot.start()`` again."""


class MotionError(Error):
    """A motion was stopped by the robot: the controller raised an error, HOLD, E-stop, TEACH,
    the lock or power off interrupted it, it did not finish in time, a stream underran, or a
    servo's watchdog fired. The motion was cancelled.

    ``code`` is the AS error code as on the wire (e.g. -31130) or ``None``, ``code_name`` its
    name (``"E1130"``), ``remedy`` what to do, ``blockers`` every blocking condition with its
    remedy.
    """

    code: Optional[int]
    code_name: Optional[str]
    remedy: Optional[str]
    blockers: List[Tuple[str, str]]

    def __init__(
        self,
        message: str,
        code: Optional[int] = None,
        code_name: Optional[str] = None,
        remedy: Optional[str] = None,
        blockers: Optional[List[Tuple[str, str]]] = None,
    ):
        super().__init__(message)
        self.code = code
        self.code_name = code_name
        self.remedy = remedy
        self.blockers = list(blockers or [])


class MoveTimeoutError(MotionError, TimeoutError):
    """A move did not reach its target in time; it was stopped (commands 5 then 2)."""


class BusyError(Error):
    """Another motion source (a stream or a servo) holds the robot: stop it first."""
