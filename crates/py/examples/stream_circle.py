"""A horizontal circle of the flange (inverse kinematics per point), streamed with command 7.

    python crates/py/examples/stream_circle.py [--radius 50] [--seconds 4] [--robot HOST:PORT]
"""

import argparse
import contextlib
import math

import fs020n


def circle(radius_mm: float, seconds: float, dt: float = 0.05):
    """Times and joint positions of a circle through the home pose's flange position."""
    x0, y0, z0, o, a, t = fs020n.fk(fs020n.HOME)
    times, joints = [], []
    q = list(fs020n.HOME)
    n = int(round(seconds / dt))
    for k in range(n + 1):
        s = k / n
        # Smooth start and stop: the angle follows a cosine ramp.
        phi = 2 * math.pi * (0.5 - 0.5 * math.cos(math.pi * s))
        pose = (x0 - radius_mm + radius_mm * math.cos(phi), y0 + radius_mm * math.sin(phi), z0, o, a, t)
        q = fs020n.ik(pose, near=q)[0]
        times.append(k * dt)
        joints.append(q)
    return times, joints


def run(address: str, radius: float, seconds: float) -> None:
    times, joints = circle(radius, seconds)
    with fs020n.Robot(address) as robot:
        robot.preflight()
        robot.set_speed(100)
        robot.start()
        robot.move_joints(joints[0])
        report = robot.stream(times, joints, mode="cmd7", rate=50)
        print(f"{report.samples_sent} samples, tracking error max {report.tracking_error_max_deg:.3f} deg, "
              f"RMS {report.tracking_error_rms_deg:.3f} deg, final error {report.final_error_deg:.3f} deg, "
              f"outcome {report.outcome}")


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--radius", type=float, default=50.0, help="mm")
    p.add_argument("--seconds", type=float, default=4.0)
    p.add_argument("--robot", help="HOST:PORT of a real controller (default: embedded emulator)")
    args = p.parse_args()
    with contextlib.ExitStack() as stack:
        address = args.robot or stack.enter_context(fs020n.Emulator()).address
        run(address, args.radius, args.seconds)


if __name__ == "__main__":
    main()
