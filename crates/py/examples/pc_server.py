"""The PC as the server and the robot as its client, with nothing but the standard library on
the PC side (no fs020n code): the cell software a user already has.

The robot program crates/as/programs/examples/pick_place_client.as connects to the cell PC
(192.168.0.10, port 48200), says READY, moves one part for every PICK line it receives and
answers "PLACED n"; QUIT ends with BYE. Run the robot in the emulator, the PC's address mapped
to this machine, then this server:

    fs020n sim --as-program crates/as/programs/examples/pick_place_client.as \\
        --host 192.168.0.10=127.0.0.1 --monitor-speed 100
    python pc_server.py --parts 3

(or in Python: fs020n.Emulator(as_program=..., hosts={"192.168.0.10": "127.0.0.1"})). The
robot tries again every second until this server listens, so either may start first.
"""

import argparse
import socket
import sys


class Lines:
    """CR LF terminated lines from a socket."""

    def __init__(self, sock: socket.socket) -> None:
        self.sock = sock
        self.buf = b""

    def read(self) -> str:
        while b"\r\n" not in self.buf:
            chunk = self.sock.recv(1024)
            if not chunk:
                raise ConnectionError("the robot closed the connection")
            self.buf += chunk
        line, self.buf = self.buf.split(b"\r\n", 1)
        return line.decode("ascii")


def serve(port: int, parts: int, timeout_s: float) -> None:
    with socket.create_server(("127.0.0.1", port)) as server:
        server.settimeout(timeout_s)
        print(f"waiting for the robot on port {port}", flush=True)
        conn, peer = server.accept()
        with conn:
            conn.settimeout(timeout_s)
            lines = Lines(conn)
            hello = lines.read()
            print(f"robot at {peer[0]} says {hello}", flush=True)
            if hello != "READY":
                raise ValueError(f"expected READY, got {hello!r}")
            for n in range(1, parts + 1):
                conn.sendall(b"PICK\r\n")
                answer = lines.read()
                print(f"part {n}: {answer}", flush=True)
                if answer != f"PLACED {n}":
                    raise ValueError(f"expected PLACED {n}, got {answer!r}")
            conn.sendall(b"QUIT\r\n")
            print(f"robot says {lines.read()}", flush=True)


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--port", type=int, default=48200, help="the port the robot connects to")
    p.add_argument("--parts", type=int, default=3, help="parts to move")
    p.add_argument("--timeout", type=float, default=60.0, help="seconds to wait for the robot")
    args = p.parse_args()
    try:
        serve(args.port, args.parts, args.timeout)
    except (OSError, ValueError) as e:
        print(f"error: {e}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
