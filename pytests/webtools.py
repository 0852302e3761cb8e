"""Helpers of the browser and hub suites: the fs020n binary in child processes, a raw
protocol-1040 client, the JSON pendant API, headless chromium through WebDriver."""

import json
import os
import select
import shutil
import socket
import subprocess
import tempfile
import time
import urllib.request
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def binary():
    b = os.environ.get("FS020N_BIN") or str(ROOT / "target" / "debug" / "fs020n")
    assert Path(b).exists(), f"{b} is missing: run scripts/test-all (it builds it and sets FS020N_BIN)"
    return b


class Child:
    """An fs020n child process whose first stdout line is JSON (its addresses)."""

    def __init__(self, *args, timeout=30.0):
        self.log = tempfile.NamedTemporaryFile(prefix="fs020n-", suffix=".log", delete=False)
        self.proc = subprocess.Popen(
            [binary(), "--json", *args],
            stdout=subprocess.PIPE,
            stderr=self.log,
            text=True,
        )
        ready, _, _ = select.select([self.proc.stdout], [], [], timeout)
        line = self.proc.stdout.readline() if ready else ""
        if not line:
            self.stop()
            raise AssertionError(f"fs020n {' '.join(args)} did not start: {self.stderr()}")
        self.info = json.loads(line)

    def stderr(self):
        try:
            return Path(self.log.name).read_text()[-3000:]
        except OSError:
            return ""

    def stop(self):
        if self.proc.poll() is None:
            self.proc.terminate()
            try:
                self.proc.wait(timeout=10)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait()


def start_sim(*extra):
    """`fs020n sim` on free loopback ports with its pendant. info: listen, pendant (URL)."""
    return Child("sim", "--listen", "127.0.0.1:0", "--pendant", "127.0.0.1:0", *extra)


def start_hub(robot, *extra, timeout=30.0):
    """`fs020n hub` on free loopback ports. info: http (URL), listen, foxglove, ros2."""
    return Child(
        "--robot", robot, "hub", "--http", "127.0.0.1:0", "--listen", "127.0.0.1:0", *extra,
        timeout=timeout,
    )


def http_json(base, path, method="GET", body=None):
    data = None if body is None else json.dumps(body).encode()
    req = urllib.request.Request(base.rstrip("/") + path, data=data, method=method)
    if data is not None:
        req.add_header("Content-Type", "application/json")
    with urllib.request.urlopen(req, timeout=10) as r:
        return json.loads(r.read())


def host_port(text):
    host, port = text.rsplit(":", 1)
    return host, int(port)


class Raw:
    """A raw protocol-1040 client: one write per request, strict lock-step."""

    def __init__(self, addr, within=20.0):
        # The emulated controller listens in 3 s windows with a gap between them (as the real
        # one's TCP_ACCEPT loop does) and refuses connections in the gap: retry until a window
        # opens, as a real client must.
        deadline = time.monotonic() + within
        while True:
            try:
                self.sock = socket.create_connection(host_port(addr), timeout=10)
                break
            except ConnectionRefusedError:
                if time.monotonic() > deadline:
                    raise
                time.sleep(0.05)
        self.sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)

    def request(self, text):
        """Sends `text`, returns the reply's 14 fields as numbers (None if the hub closed)."""
        self.sock.sendall(text.encode())
        buf = b""
        while True:
            fields = buf.split()
            if len(fields) >= 14:
                return [float(f) for f in fields[:14]]
            chunk = self.sock.recv(1024)
            if not chunk:
                return None
            buf += chunk

    def joints(self, reply):
        return reply[8:14]

    def close(self):
        self.sock.close()


def wait_until(predicate, timeout=20.0, every=0.05, what="condition"):
    deadline = time.monotonic() + timeout
    while True:
        value = predicate()
        if value:
            return value
        if time.monotonic() > deadline:
            raise AssertionError(f"timed out waiting for {what() if callable(what) else what}")
        time.sleep(every)


def browser(width=1400, height=1000):
    """Debian's chromium, headless, through chromedriver (WebDriver)."""
    from selenium import webdriver
    from selenium.webdriver.chrome.service import Service

    chromium = shutil.which("chromium")
    driver = shutil.which("chromedriver")
    assert chromium and driver, (
        "the browser tests need Debian's chromium and chromium-driver: "
        "apt-get install -y chromium chromium-driver (.ci/run installs them)"
    )
    profile = tempfile.mkdtemp(prefix="fs020n-chromium-")
    opts = webdriver.ChromeOptions()
    opts.binary_location = chromium
    for a in (
        "--headless",
        "--no-sandbox",
        "--disable-gpu",
        "--disable-quic",
        "--no-first-run",
        "--disable-background-networking",
        "--disable-component-update",
        "--disable-sync",
        "--disable-dev-shm-usage",
        f"--user-data-dir={profile}",
        f"--window-size={width},{height}",
    ):
        opts.add_argument(a)
    return webdriver.Chrome(service=Service(executable_path=driver), options=opts)


def check_not_blank(png_path, min_colours=40):
    """The screenshot is an image of the page, not a blank one: many colours, and the 3D view's
    area is not uniform."""
    from PIL import Image, ImageStat

    img = Image.open(png_path).convert("RGB")
    w, h = img.size
    assert w >= 800 and h >= 600, img.size
    colours = img.getcolors(maxcolors=1 << 20)
    assert colours is not None and len(colours) >= min_colours, f"{len(colours or [])} colours"
    view = img.crop((20, 60, w // 2, h // 2))
    spread = ImageStat.Stat(view).stddev
    assert max(spread) > 8.0, f"the 3D view is uniform: {spread}"
    most = max(colours)[0] / (w * h)
    assert most < 0.9, f"one colour covers {most:.0%} of the page"
