"""A telnet upload-and-start as users script it in Python, against the emulated controller.

No fs020n code on the PC side: a raw socket (the way ``telnetlib`` scripts talk to the AS
monitor terminal), the LOAD block transfer written out by hand, the controller's texts matched
as such scripts match them (``0) `` with its trailing blank, ``Confirm !`` after the end of
file when the controller asks it, ``Program completed.No = 1``). The controller is ``fs020n
sim --bare --terminal``; the binary is ``$FS020N_BIN`` (scripts/test-all builds it)."""

import json
import os
import socket
import subprocess
import time

import pytest

BIN = os.environ.get("FS020N_BIN")
pytestmark = pytest.mark.skipif(not BIN, reason="FS020N_BIN is not set (run scripts/test-all)")

IAC = 0xFF
ENQ, STX, ETB, SUB = b"\x05", b"\x02", b"\x17", b"\x1a"

# A user's server: answers every line it receives with "echo: " and the line, on port 48950.
ECHO_AS = b""".PROGRAM echo.pc()
  .port = 48950
  TCP_LISTEN .ret, .port
  WHILE TRUE DO
    TCP_ACCEPT .sock, .port, 10
    IF .sock >= 0 THEN
      .n = 0
      TCP_RECV .ret, .sock, $in[1], .n, 10, 255
      IF .ret >= 0 AND .n > 0 THEN
        $out[1] = "echo: " + $in[1]
        TCP_SEND .ret, .sock, $out[1], 1, 10
      END
      TCP_CLOSE .ret, .sock
    END
  END
.END
.PROGRAM wave()
  TWAIT 0.2
.END
"""


def strip_telnet(data: bytes) -> bytes:
    """The data bytes of a telnet stream (the controller's option commands left out)."""
    out = bytearray()
    i = 0
    while i < len(data):
        b = data[i]
        if b == IAC and i + 1 < len(data):
            cmd = data[i + 1]
            if cmd == 0xFA:  # SB … IAC SE
                end = data.find(bytes([IAC, 0xF0]), i + 2)
                i = len(data) if end < 0 else end + 2
            elif cmd in (0xFB, 0xFC, 0xFD, 0xFE):
                i += 3
            else:
                i += 2
            continue
        out.append(b)
        i += 1
    return bytes(out)


class Terminal:
    """The AS monitor terminal over a raw socket, as a telnet script drives it."""

    def __init__(self, addr):
        host, port = addr.rsplit(":", 1)
        self.s = socket.create_connection((host, int(port)), timeout=20)
        self.buf = b""

    def read_until(self, marker: bytes, timeout=20.0) -> bytes:
        deadline = time.monotonic() + timeout
        while marker not in self.buf:
            assert time.monotonic() < deadline, f"no {marker!r} in {self.buf!r}"
            chunk = self.s.recv(4096)
            assert chunk, f"closed before {marker!r}: {self.buf!r}"
            self.buf += strip_telnet(chunk)
        i = self.buf.index(marker) + len(marker)
        seen, self.buf = self.buf[:i], self.buf[i:]
        return seen

    def send(self, data: bytes):
        self.s.sendall(data)

    def command(self, line: str) -> str:
        """Types a command and reads up to its prompt (CR LF then `>`)."""
        self.send(line.encode() + b"\r\n")
        return self.read_until(b"\r\n>").decode(errors="replace")

    def frame(self) -> bytes:
        """The next controller frame, ENQ STX letter … ETB: its letter and payload."""
        self.read_until(ENQ + STX)
        return self.read_until(ETB)[:-1]

    def load(self, name: str, data: bytes, block=200) -> str:
        self.send(f"LOAD {name}\r\n".encode())
        assert self.frame()[:1] == b"A"
        self.send(STX + b"A    0" + ETB)
        for i in range(0, len(data), block):
            assert self.frame() == b"C"
            self.send(STX + b"C    0" + data[i : i + block] + ETB)
        assert self.frame() == b"C"
        # The end of file as khi_robot_py sends it: a block whose data ends with SUB.
        self.send(STX + b"C    0\r\n" + SUB + ETB)
        assert self.frame() == b"E"
        self.send(STX + b"E    0" + ETB)
        return self.read_until(b"\r\n>").decode(errors="replace")


@pytest.fixture()
def controller():
    env = {k: v for k, v in os.environ.items() if k != "FS020N_ROBOT"}
    p = subprocess.Popen(
        [BIN, "--json", "sim", "--bare", "--listen", "127.0.0.1:0", "--terminal", "127.0.0.1:0",
         "--terminal-piece", "16"],
        stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True, env=env,
    )
    try:
        addrs = json.loads(p.stdout.readline())
        yield addrs
    finally:
        p.terminate()
        p.wait(timeout=20)


def test_a_python_telnet_script_uploads_starts_and_talks_to_its_program(controller):
    t = Terminal(controller["terminal"])
    t.read_until(b"login: ")
    t.send(b"as\r\n")
    assert b"AS monitor terminal" in t.read_until(b"\r\n>")

    done = t.load("echo.as", ECHO_AS)
    assert "Program echo.pc()" in done and "Program wave()" in done, done
    assert "File load completed. (0 errors)" in done, done
    assert "echo.pc" in t.command("DIRECTORY/P")

    # Started: by the time the prompt returns the program listens, so a client connecting at
    # once is not refused.
    assert "(P" not in t.command("PCEXECUTE 1: echo.pc")
    host, port = controller["listen"].rsplit(":", 1)
    with socket.create_connection((host, int(port)), timeout=10) as c:
        c.sendall(b"hello robot")
        assert c.recv(256) == b"echo: hello robot"

    # The monitor commands such scripts send, answered in the controller's format.
    assert "(P" not in t.command("SIGNAL 1, -2")
    assert t.command("TYPE SIG(1)").split()[-2] == "-1"
    where = t.command("WHERE")
    assert "JT1" in where and "X[mm]" in where, where
    assert "Robot status:" in t.command("STATUS")
    assert "(P" not in t.command("ZPOWER ON")
    assert "(P" not in t.command("MESSAGES ON")
    assert "(P" not in t.command("ERESET")
    assert "(P" not in t.command("HOLD")
    assert "(P" not in t.command("CONTINUE")

    # A robot program started by EXECUTE announces its end.
    assert "(P" not in t.command("EXECUTE wave")
    assert b"Program completed.No = 1" in t.read_until(b"Program completed.No = 1", timeout=10)

    # The yes/no question keeps its trailing blank: a script waits for "0) ".
    t.send(b"PCABORT 1:\r\n")
    t.read_until(b"\r\n>")
    for _ in range(100):
        if t.command("TYPE TASK (1001)").split()[-2] == "0":
            break
        time.sleep(0.2)
    t.send(b"PCKILL 1:\r\n")
    t.read_until(b"Are you sure ? (Yes:1, No:0) ")
    t.send(b"1\r\n")
    after = t.read_until(b"\r\n>").decode()
    assert "(P" not in after, after
    # The question takes one key: a library that answers `1` alone and waits for the prompt.
    t.send(b"DELETE/P echo.pc\r\n")
    t.read_until(b"0) ")
    t.send(b"1")
    t.read_until(b"\r\n>")
    assert "echo.pc" not in t.command("DIRECTORY/P")

    # Instructions typed at the prompt run as in a program: DO, TYPE of any expression, SOUT,
    # the payload.
    assert "(P" not in t.command("DO gain = 2.5")
    typed = t.command("TYPE gain * 4, $LEFT(\"robot\", 3)")
    assert "\r\n 10rob\r\n" in typed, typed
    assert "(P" not in t.command("SOUT 5 = 1 AND -2")
    assert t.command("TYPE SIG(5)").split()[-2] == "-1"
    assert "(P" not in t.command("WEIGHT 0, 0, 0, 0")
    assert "(E1095)" in t.command("DO JMOVE #PPOINT(10)"), "a motion is not made from the prompt"
