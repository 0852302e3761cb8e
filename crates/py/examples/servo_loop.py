"""Online servoing (teleoperation style): push a moving target at your own rate.

    python crates/py/examples/servo_loop.py [--rate 125] [--seconds 4] [--robot HOST:PORT]

The samples here come from a sine; in a real setup they come from a leader arm, a space
mouse or a visual-servoing loop. Stop pushing and the watchdog stops the program.
"""

import argparse
import contextlib
import math
import time

import fs020n


def run(address: str, rate: float, seconds: float) -> None:
    with fs020n.Robot(address) as robot:
        robot.preflight()
        robot.set_speed(100)
        robot.start()
        start = robot.status().joints
        with robot.servo(watchdog=0.2) as servo:
            t0 = time.monotonic()
            k = 0
            while (t := time.monotonic() - t0) < seconds:
                q = list(start)
                q[0] += 10.0 * math.sin(2 * math.pi * t / seconds)
                qd = [10.0 * 2 * math.pi / seconds * math.cos(2 * math.pi * t / seconds), 0, 0, 0, 0, 0]
                servo.push(q, qd)
                k += 1
                time.sleep(max(0.0, t0 + k / rate - time.monotonic()))
        report = servo.stop()
        st = report.stats
        print(f"{report.outcome}: {st['pushes']} pushes, {st['sent']} sent, {st['coalesced']} coalesced, "
              f"{st['unsent']} unsent, "
              f"tracking RMS {st['tracking_error_rms_deg']:.3f} deg, "
              f"push-to-send mean {st['push_to_send_mean_s'] * 1e6:.0f} us")


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--rate", type=float, default=125.0)
    p.add_argument("--seconds", type=float, default=4.0)
    p.add_argument("--robot", help="HOST:PORT of a real controller (default: embedded emulator)")
    args = p.parse_args()
    with contextlib.ExitStack() as stack:
        address = args.robot or stack.enter_context(fs020n.Emulator()).address
        run(address, args.rate, args.seconds)


if __name__ == "__main__":
    main()
