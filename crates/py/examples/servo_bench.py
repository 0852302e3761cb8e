"""Benchmark of an online servo loop from Python: what rate and jitter a `servo.push` loop
achieves against the embedded emulator (the Rust twin is
`cargo run --release -p fs020n-client --example servo_bench`).

    python crates/py/examples/servo_bench.py --rate 125 --rate 500 --rate 1000 --seconds 10

For each rate the loop sleeps until the next tick (time.sleep), computes a sine sample and
pushes it. Reported: the achieved push rate, the lateness of each push against its tick
(mean, p99, max), the standard deviation of the intervals, the cost of one push() call, and
the servo's own figures (samples sent, coalesced, push-to-send latency, round trips).
"""

import argparse
import contextlib
import json
import math
import statistics
import time

import fs020n


def percentile(values, q):
    s = sorted(values)
    return s[min(len(s) - 1, max(0, math.ceil(q * len(s)) - 1))]


def run(address: str, rate: float, seconds: float) -> dict:
    period = 1.0 / rate
    n = int(round(seconds * rate))
    w = 2 * math.pi / 4.0  # a 4 s sine of 5 degrees on JT1
    with fs020n.Robot(address) as robot:
        robot.set_speed(100)
        robot.start()
        home = robot.status().joints
        stamps, lateness, costs = [], [], []
        with robot.servo(watchdog=0.5) as servo:
            t0 = time.perf_counter() + 0.01
            for k in range(n):
                tick = t0 + k * period
                now = time.perf_counter()
                if tick > now:
                    time.sleep(tick - now)
                t = time.perf_counter()
                x = t - t0
                q = list(home)
                q[0] += 5.0 * math.sin(w * x)
                qd = [5.0 * w * math.cos(w * x), 0.0, 0.0, 0.0, 0.0, 0.0]
                servo.push(q, qd)
                done = time.perf_counter()
                stamps.append(t)
                lateness.append(t - tick)
                costs.append(done - t)
        st = servo.stop().stats
    intervals = [b - a for a, b in zip(stamps, stamps[1:])]
    us = 1e6
    return {
        "client": "python",
        "target_hz": rate,
        "pushes": n,
        "achieved_hz": round((n - 1) / (stamps[-1] - stamps[0]), 1),
        "late_mean_us": round(statistics.mean(lateness) * us, 1),
        "late_p99_us": round(percentile(lateness, 0.99) * us, 1),
        "late_max_us": round(max(lateness) * us, 1),
        "interval_sd_us": round(statistics.pstdev(intervals) * us, 1),
        "push_mean_us": round(statistics.mean(costs) * us, 2),
        "push_p99_us": round(percentile(costs, 0.99) * us, 2),
        "sent": st["sent"],
        "coalesced": st["coalesced"],
        "unsent": st["unsent"],
        "push_to_send_mean_us": round(st["push_to_send_mean_s"] * us, 1),
        "push_to_send_max_us": round(st["push_to_send_max_s"] * us, 1),
        "rtt_mean_us": round(st["rtt_mean_s"] * us, 1),
        "tracking_rms_deg": round(st["tracking_error_rms_deg"], 4),
    }


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--rate", type=float, action="append", help="pushes per second (repeatable)")
    p.add_argument("--seconds", type=float, default=10.0)
    p.add_argument("--robot", help="HOST:PORT of a real controller (default: embedded emulator)")
    args = p.parse_args()
    with contextlib.ExitStack() as stack:
        address = args.robot or stack.enter_context(fs020n.Emulator()).address
        for rate in args.rate or [125.0, 500.0, 1000.0]:
            print(json.dumps(run(address, rate, args.seconds)), flush=True)
            # Let the stopped program end before the next session starts it again.
            time.sleep(0.3)


if __name__ == "__main__":
    main()
