"""A plain client of an AS program with two servers: commands on one port, the state on
another (the standard library only, no fs020n code).

The robot program crates/as/programs/examples/two_ports.as answers one command a line on port
9111 ("OUT n", "OFF n", "SPEED n", "COUNT") and sends "STATE count sig1 sig2" (the commands
so far, outputs 1 and 2: -1 ON, 0 OFF) every 0.1 s on port 9112. Run it in the emulator (every port it listens on is served at the same number),
then this client:

    fs020n sim --as-program crates/as/programs/examples/two_ports.as
    python two_ports_client.py

(--port-map 9111=19111 serves a port elsewhere; in Python port_map={9111: 19111}.)
"""

import argparse
import socket
import sys


def line(sock: socket.socket) -> str:
    buf = b""
    while not buf.endswith(b"\r\n"):
        chunk = sock.recv(1)
        if not chunk:
            raise ConnectionError("the robot closed the connection")
        buf += chunk
    return buf[:-2].decode("ascii")


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--host", default="127.0.0.1")
    p.add_argument("--commands", type=int, default=9111, help="the command port")
    p.add_argument("--state", type=int, default=9112, help="the state port")
    args = p.parse_args()
    try:
        with socket.create_connection((args.host, args.commands), timeout=10) as cmd:
            for c in ("OUT 5", "SPEED 30", "OFF 5", "OUT 2", "COUNT"):
                cmd.sendall(c.encode("ascii") + b"\r\n")
                print(f"{c} -> {line(cmd)}", flush=True)
            # The second server, while the first connection stays open.
            with socket.create_connection((args.host, args.state), timeout=10) as state:
                for _ in range(2):
                    print(f"state: {line(state)}", flush=True)
    except OSError as e:
        print(f"error: {e}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
