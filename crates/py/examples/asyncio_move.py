"""The asyncio flavour: moves as coroutines, watched by another task; cancelling the waiting
coroutine cancels the motion on the robot."""

import asyncio

import fs020n


async def watch(robot: fs020n.aio.Robot, stop: asyncio.Event) -> None:
    while not stop.is_set():
        s = await robot.status(fresh=False)
        print(f"  JT1 = {s.joints[0]:7.3f} deg")
        await asyncio.sleep(0.25)


async def main() -> None:
    with fs020n.Emulator() as emu:
        async with fs020n.aio.Robot(emu.address) as robot:
            await robot.set_speed(20)
            await robot.start()
            stop = asyncio.Event()
            watcher = asyncio.create_task(watch(robot, stop))
            report = await robot.move_joints([20, 0, -90, 0, -90, 0])
            print(f"reached={report.reached} in {report.duration_s:.2f} s")
            move = asyncio.create_task(robot.move_joints(fs020n.HOME))
            await asyncio.sleep(0.5)
            move.cancel()  # cancels the motion on the robot (command 5)
            try:
                await move
            except asyncio.CancelledError:
                print(f"cancelled at JT1 = {emu.joints[0]:.3f} deg")
            stop.set()
            await watcher


if __name__ == "__main__":
    asyncio.run(main())
