"""The tour: connect, preflight, speed, start, joint and pose moves, status and statistics.

    python crates/py/examples/quickstart.py                     # against the embedded emulator
    python crates/py/examples/quickstart.py --robot 192.168.0.2:10050   # a real FS020N (it moves!)
"""

import argparse
import contextlib

import fs020n


def tour(address: str) -> None:
    with fs020n.Robot(address, connect_timeout=10.0) as robot:
        s = robot.status()
        print(f"connected to {address}: error={s.error_name or 'none'} joints={s.joints}")
        try:
            robot.preflight()
        except fs020n.NotReadyError as e:
            for what, remedy in e.blockers:
                print(f"  blocked: {what} -> {remedy}")
            raise SystemExit(2)
        robot.set_speed(50)
        robot.start()
        for target in ([0, 10, -80, 0, -90, 0], [20, 0, -90, 10, -80, 0], fs020n.HOME):
            report = robot.move_joints(target)
            print(f"move to {target}: reached={report.reached} in {report.duration_s:.2f} s, "
                  f"error {report.error_deg:.3f} deg")
        x, y, z, o, a, t = fs020n.fk(fs020n.HOME)
        report = robot.move_pose(x, y - 100, z - 50, o, a, t)
        print(f"pose move: joints {[round(v, 2) for v in report.final_joints]}")
        robot.move_joints(fs020n.HOME)
        rtt = robot.stats()["rtt"]
        print(f"round trips: {rtt['count']}, mean {rtt['mean_s'] * 1e3:.3f} ms, "
              f"p99 {rtt['p99_s'] * 1e3:.3f} ms")


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--robot", help="HOST:PORT of a real controller (default: embedded emulator)")
    args = p.parse_args()
    with contextlib.ExitStack() as stack:
        address = args.robot or stack.enter_context(fs020n.Emulator()).address
        tour(address)


if __name__ == "__main__":
    main()
