"""The fs020n client for asyncio: the methods of :class:`fs020n.Robot` as coroutines.

>>> async def main(address):
...     async with fs020n.aio.Robot(address) as robot:
...         await robot.start()
...         await robot.move_joints([0, 10, -80, 0, -90, 0])

Each coroutine runs the blocking call in the event loop's default executor (a thread): the
Rust client releases the GIL while it waits, so the event loop keeps running. This costs one
thread hop per call (tens of microseconds) and no extra dependency, which is why the flavour
is built this way rather than on native Rust futures. Cancelling a coroutine that waits for a
motion (``move_joints``, ``move_pose``, ``stream``, ``Move.wait``, ``Stream.wait``) cancels
the motion on the robot (commands 5 then 2, as ``Robot.cancel``) before ``CancelledError``
propagates. ``Servo.push``
never blocks and stays a plain method.
"""

from __future__ import annotations

import asyncio
import functools
from typing import Any, Callable, Optional, Sequence, TypeVar, Union

from . import _fs020n

__all__ = ["Robot", "Move", "Stream", "Servo", "connect"]

T = TypeVar("T")


async def _run(fn: Callable[..., T], *args: Any, **kwargs: Any) -> T:
    loop = asyncio.get_running_loop()
    return await loop.run_in_executor(None, functools.partial(fn, *args, **kwargs))


async def _motion(
    robot: "_fs020n.Robot", fn: Callable[..., T], *args: Any, **kwargs: Any
) -> T:
    """Runs a blocking motion call; a cancelled coroutine cancels the motion (5 then 2)."""
    loop = asyncio.get_running_loop()
    fut = loop.run_in_executor(None, functools.partial(fn, *args, **kwargs))
    try:
        return await asyncio.shield(fut)
    except asyncio.CancelledError:
        try:
            await loop.run_in_executor(None, robot.cancel)
        finally:
            raise


class Move:
    """A joint move in progress; see :class:`fs020n.Move`."""

    def __init__(self, robot: "_fs020n.Robot", move: "_fs020n.Move"):
        self._robot = robot
        self._move = move

    async def wait(self, timeout: Optional[float] = None) -> "_fs020n.MoveReport":
        return await _motion(self._robot, self._move.wait, timeout)

    async def cancel(self) -> None:
        await _run(self._move.cancel)

    def done(self) -> bool:
        return self._move.done()

    @property
    def progress(self) -> Optional[float]:
        return self._move.progress

    @property
    def target(self) -> list:
        return self._move.target


class Stream:
    """A stream in progress; see :class:`fs020n.Stream`."""

    def __init__(self, robot: "_fs020n.Robot", stream: "_fs020n.Stream"):
        self._robot = robot
        self._stream = stream

    async def wait(self) -> "_fs020n.StreamReport":
        return await _motion(self._robot, self._stream.wait)

    async def cancel(self) -> None:
        await _run(self._stream.cancel)

    def done(self) -> bool:
        return self._stream.done()

    @property
    def progress(self) -> float:
        return self._stream.progress


class Servo:
    """An online servo; ``push`` is a plain (non-blocking) method, ``stop`` a coroutine.
    ``async with`` stops it on exit."""

    def __init__(self, servo: "_fs020n.Servo"):
        self._servo = servo

    def push(self, q: Any, qd: Any = None, qdd: Any = None) -> None:
        self._servo.push(q, qd, qdd)

    async def stop(self) -> "_fs020n.ServoReport":
        return await _run(self._servo.stop)

    def stats(self) -> dict:
        return self._servo.stats()

    def done(self) -> bool:
        return self._servo.done()

    async def __aenter__(self) -> "Servo":
        return self

    async def __aexit__(self, ty: Any, value: Any, tb: Any) -> bool:
        try:
            await self.stop()
        except Exception:
            if ty is None:
                raise
        return False


class Robot:
    """:class:`fs020n.Robot` for asyncio. ``Robot(address, **options)`` connects on
    ``async with`` (or ``await robot.connect()``); the options are those of
    :class:`fs020n.Robot`. ``await fs020n.aio.connect(address)`` does both."""

    def __init__(self, address: str, **options: Any):
        self._address = address
        self._options = options
        self._robot: Optional[_fs020n.Robot] = None

    async def connect(self) -> "Robot":
        if self._robot is None:
            self._robot = await _run(_fs020n.Robot, self._address, **self._options)
        return self

    @property
    def sync(self) -> "_fs020n.Robot":
        """The blocking :class:`fs020n.Robot` underneath (connect first)."""
        if self._robot is None:
            raise RuntimeError("not connected: use `async with` or `await robot.connect()`")
        return self._robot

    async def __aenter__(self) -> "Robot":
        return await self.connect()

    async def __aexit__(self, ty: Any, value: Any, tb: Any) -> bool:
        if self._robot is not None:
            try:
                await self.close()
            except Exception:
                if ty is None:
                    raise
        return False

    @property
    def address(self) -> str:
        return self._address

    @property
    def is_connected(self) -> bool:
        return self._robot is not None and self._robot.is_connected

    async def status(self, fresh: bool = True) -> "_fs020n.Status":
        return await _run(self.sync.status, fresh)

    async def preflight(self) -> None:
        await _run(self.sync.preflight)

    async def set_speed(self, percent: float) -> "_fs020n.Status":
        return await _run(self.sync.set_speed, percent)

    async def start(self) -> None:
        await _run(self.sync.start)

    async def stop(self) -> "_fs020n.Status":
        return await _run(self.sync.stop)

    async def cancel(self) -> "_fs020n.Status":
        return await _run(self.sync.cancel)

    async def move_joints(
        self, target: Sequence[float], *, wait: bool = True, **options: Any
    ) -> Union["_fs020n.MoveReport", Move]:
        r = self.sync
        if wait:
            return await _motion(r, r.move_joints, target, wait=True, **options)
        return Move(r, await _run(r.move_joints, target, wait=False, **options))

    async def move_pose(
        self, *pose: Any, wait: bool = True, **options: Any
    ) -> Union["_fs020n.MoveReport", Move]:
        r = self.sync
        if wait:
            return await _motion(r, r.move_pose, *pose, wait=True, **options)
        return Move(r, await _run(r.move_pose, *pose, wait=False, **options))

    async def stream(
        self,
        times: Sequence[float],
        positions: Any,
        velocities: Any = None,
        accelerations: Any = None,
        *,
        wait: bool = True,
        **options: Any,
    ) -> Union["_fs020n.StreamReport", Stream]:
        r = self.sync
        if wait:
            return await _motion(
                r, r.stream, times, positions, velocities, accelerations, wait=True, **options
            )
        s = await _run(r.stream, times, positions, velocities, accelerations, wait=False, **options)
        return Stream(r, s)

    async def servo(self, **options: Any) -> Servo:
        return Servo(await _run(self.sync.servo, **options))

    async def send_raw(self, text: str, *, allow_motion: bool = False) -> str:
        return await _run(self.sync.send_raw, text, allow_motion=allow_motion)

    def stats(self) -> dict:
        return self.sync.stats()

    def server_time(self) -> Optional[float]:
        return self.sync.server_time()

    async def reconnect(self) -> None:
        await _run(self.sync.reconnect)

    async def close(self) -> None:
        await _run(self.sync.close)


async def connect(address: str, **options: Any) -> Robot:
    """Connects and returns an :class:`fs020n.aio.Robot`."""
    return await Robot(address, **options).connect()
