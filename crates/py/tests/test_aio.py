"""The asyncio flavour."""

import asyncio
import time

import pytest

import fs020n
from conftest import HOME


def test_the_asyncio_robot(emu):
    async def main():
        async with fs020n.aio.Robot(emu.address, connect_timeout=5.0) as robot:
            assert robot.is_connected
            await robot.preflight()
            await robot.set_speed(100)
            await robot.start()
            s = await robot.status()
            assert s.program_running
            report = await robot.move_joints([5, 0, -90, 0, -90, 0])
            assert report.reached
            move = await robot.move_joints(HOME, wait=False)
            assert (await move.wait()).reached
            times = [k * 0.05 for k in range(21)]
            positions = [[5.0 * k / 20, 0, -90, 0, -90, 0] for k in range(21)]
            r = await robot.stream(times, positions)
            assert r.outcome == "completed"
            async with await robot.servo(watchdog=0.5) as servo:
                for _ in range(10):
                    servo.push(emu.joints)
                    await asyncio.sleep(0.01)
            assert robot.stats()["stream_samples"] > 0
            reply = await robot.send_raw("0 0 0")
            assert reply.startswith(" 1040")
        assert emu.last_session_end == "end_command"

    asyncio.run(main())


def test_cancelling_a_waiting_coroutine_cancels_the_motion(emu):
    async def main():
        robot = await fs020n.aio.connect(emu.address)
        await robot.set_speed(10)
        await robot.start()
        task = asyncio.ensure_future(robot.move_joints([50, 0, -90, 0, -90, 0]))
        await asyncio.sleep(0.5)
        task.cancel()
        with pytest.raises(asyncio.CancelledError):
            await task
        assert emu.newest_command == 2  # robot.cancel(): 5 then 2
        await asyncio.sleep(0.5)
        j = emu.joints[0]
        assert 0.5 < j < 30
        await robot.close()

    asyncio.run(main())


def test_errors_are_the_same_exceptions(emu):
    async def main():
        async with fs020n.aio.Robot(emu.address) as robot:
            with pytest.raises(fs020n.NotReadyError):
                await robot.move_joints(HOME)
            with pytest.raises(fs020n.LimitError):
                await robot.set_speed(0)

    asyncio.run(main())
