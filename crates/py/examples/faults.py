"""What faults look like from Python: HOLD and E-stop mid-move, a lost link, and recovery.
Runs on the embedded emulator (it operates the emulated panel)."""

import time

import fs020n

TARGET = [40, 0, -90, 0, -90, 0]


def main() -> None:
    with fs020n.Emulator() as emu, fs020n.Robot(emu.address) as robot:
        robot.set_speed(10)
        robot.start()

        move = robot.move_joints(TARGET, wait=False)
        time.sleep(0.5)
        emu.set_panel(run=False)  # someone switches RUN/HOLD to HOLD
        try:
            move.wait()
        except fs020n.MotionError as e:
            print(f"HOLD:   {e}\n        remedy: {e.remedy}")
        emu.set_panel(run=True)
        robot.preflight()  # a fresh status: nothing blocks any more
        robot.start()  # the failed wait stopped the program (a sure stop: 5 then 2)

        move = robot.move_joints(TARGET, wait=False)
        time.sleep(0.5)
        emu.press_estop()
        try:
            move.wait()
        except fs020n.MotionError as e:
            print(f"E-stop: {e.code_name} ({e.code}) -> {e.remedy}")
        emu.release_estop()
        emu.reset_error()
        emu.set_panel(power=True)
        robot.preflight()
        robot.start()
        print("recovered: program running =", robot.status().program_running)

        emu.drop_connection()  # a cable is pulled
        try:
            robot.status()
        except fs020n.LinkLostError as e:
            print(f"link:   {e}")
        robot.reconnect()
        time.sleep(0.3)  # a new session stops the program (signal 2007 acts after 50 ms)
        print("reconnected: program running =", robot.status().program_running,
              "(nothing resumes by itself)")


if __name__ == "__main__":
    main()
