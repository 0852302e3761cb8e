"""The web pendant in a real browser: Debian's headless chromium driven by WebDriver.

The emulator's page (`fs020n sim --pendant`) shows the joints live while a raw client moves
the arm, RUN/HOLD flipped on the page pauses the motion, the page's own kinematics agree with
the Rust ones, and its screenshot is not blank. The hub's page shows a real robot's switches
without making them switchable, and its Stop needs two clicks.

Set FS020N_SCREENSHOTS=DIR to keep the screenshots (docs/web-pendant.png and docs/web-hub.png
come from here).
"""

import json
import os
import shutil
import subprocess
import threading
import time
from pathlib import Path

import pytest
from selenium.webdriver.common.by import By

from webtools import Raw, binary, browser, check_not_blank, http_json, start_hub, start_sim, wait_until


@pytest.fixture
def sim():
    s = start_sim()
    yield s
    s.stop()


@pytest.fixture
def driver():
    d = browser()
    yield d
    d.quit()


def keep_polling(raw, stop, every=0.1):
    """The controlling client's keep-alive (the controller ends a silent session)."""

    def run():
        while not stop.is_set():
            raw.request("0 0 0")
            time.sleep(every)

    t = threading.Thread(target=run, daemon=True)
    t.start()
    return t


def joint(d, n):
    text = d.find_element(By.CSS_SELECTOR, f'[data-joint="{n}"]').text
    return float(text)


def keep_screenshot(path, name):
    keep = os.environ.get("FS020N_SCREENSHOTS")
    if keep:
        Path(keep).mkdir(parents=True, exist_ok=True)
        shutil.copy(path, Path(keep) / name)


def test_the_emulator_page_follows_the_arm_and_pauses_it(sim, driver, tmp_path):
    pendant = sim.info["pendant"]
    driver.get(pendant + "/")
    wait_until(lambda: driver.find_element(By.ID, "live-status").text == "live", what="the live feed")
    wait_until(lambda: driver.find_element(By.CSS_SELECTOR, '[data-joint="3"]').text == "-90.000",
               what="the home pose on the page")
    assert driver.find_element(By.TAG_NAME, "body").get_attribute("data-kind") == "emulator"

    # The page draws with its own kinematics: they agree with fs020n-kin's.
    pose = [30.0, 20.0, -100.0, 40.0, -60.0, 45.0]
    js = driver.execute_script("return window.fs020n.fk(arguments[0]).points.flange;", pose)
    out = subprocess.run([binary(), "--json", "fk", *map(str, pose)], capture_output=True, text=True, check=True)
    rust = json.loads(out.stdout)
    rust = rust.get("flange", rust)
    for got, axis in zip(js, ("x_mm", "y_mm", "z_mm")):
        assert abs(got * 1000 - rust[axis]) < 1e-6, (js, rust)

    # A client moves the arm (JT1 to 150 degrees) at 5 %: about 16 s, so that a slow machine
    # still finds it moving.
    raw = Raw(sim.info["listen"])
    assert raw.request("1040 3 1 5") is not None
    raw.request("1040 1 0")
    raw.request("1040 6 9 0 0 0 150 25 -110 30 -50 45")
    stop = threading.Event()
    poller = keep_polling(raw, stop)
    try:
        first = wait_until(lambda: joint(driver, 1) > 2.0 and joint(driver, 1), what="JT1 moving on the page")
        later = wait_until(lambda: joint(driver, 1) > first + 2.0 and joint(driver, 1), what="JT1 still moving")
        assert later < 150.0

        # HOLD on the page: the motion pauses.
        run = driver.find_element(By.ID, "sw-run")
        assert run.get_attribute("data-state") == "run"
        run.click()
        wait_until(lambda: run.get_attribute("data-state") == "hold", what="the page showing HOLD")
        wait_until(lambda: http_json(pendant, "/state")["motion"] == "held",
                   what=lambda: "the arm held: " + json.dumps(http_json(pendant, "/state")))
        at = http_json(pendant, "/state")["joints_deg"][0]
        held = wait_until(lambda: abs(joint(driver, 1) - at) < 6e-4 and joint(driver, 1),
                          what="the page showing the held pose")
        time.sleep(0.6)
        assert joint(driver, 1) == held, "the arm stands still on HOLD"
        assert held < 149.0, "paused part-way"
        state = http_json(pendant, "/state")
        assert state["panel"]["run"] is False and state["task"] == "paused"
        assert abs(state["joints_deg"][0] - held) < 1e-3

        # RUN again: the motion resumes.
        run.click()
        wait_until(lambda: run.get_attribute("data-state") == "run", what="RUN again")
        wait_until(lambda: joint(driver, 1) > held + 2.0, what="JT1 moving again")
        assert http_json(pendant, "/state")["motion"] == "moving"
        assert len(driver.find_element(By.ID, "chart-legend").text) > 0
        assert driver.execute_script("return window.fs020n.frames();") > 20, "the chart has history"

        shot = tmp_path / "web-pendant.png"
        assert driver.save_screenshot(str(shot))
        check_not_blank(shot)
        keep_screenshot(shot, "web-pendant.png")
    finally:
        stop.set()
        poller.join(timeout=5)
        raw.close()


def test_the_pages_api_calls_follow_the_pendant_rules(sim, driver):
    """The page's own requests: a fault injected and an error raised from the page reach the
    emulator (JSON POSTs from the same origin)."""
    pendant = sim.info["pendant"]
    driver.get(pendant + "/")
    wait_until(lambda: driver.find_element(By.ID, "live-status").text == "live", what="the live feed")
    driver.find_element(By.ID, "btn-raise").click()
    wait_until(lambda: http_json(pendant, "/state")["error"]["name"] == "E1130", what="E1130 raised")
    wait_until(lambda: "E1130" in driver.find_element(By.ID, "error-text").text, what="the error shown")
    driver.find_element(By.ID, "btn-reset").click()
    wait_until(lambda: http_json(pendant, "/state")["error"]["code"] == 0, what="the error reset")
    # ABS.SPEED on and off again from the page (only the pendant switches it off).
    abs_button = driver.find_element(By.ID, "sw-abs")
    assert abs_button.get_attribute("data-state") == "off"
    abs_button.click()
    wait_until(lambda: http_json(pendant, "/state")["abs_speed"] is True, what="ABS.SPEED on")
    wait_until(lambda: abs_button.get_attribute("data-state") == "on", what="the page showing ABS.SPEED on")
    abs_button.click()
    wait_until(lambda: http_json(pendant, "/state")["abs_speed"] is False, what="ABS.SPEED off")
    driver.find_element(By.ID, "btn-fault").click()  # delay_replies, count 1
    wait_until(lambda: http_json(pendant, "/state")["pending_faults"] == 1, what="the fault queued")
    driver.find_element(By.ID, "btn-fault-clear").click()
    wait_until(lambda: http_json(pendant, "/state")["pending_faults"] == 0, what="the faults cleared")


def test_the_page_shows_the_as_programs_tasks_and_terminal(driver):
    """With an AS program (`sim --as-program`), the page lists each task's program, line and
    state and shows the terminal; a client's session changes what the tasks do."""
    program = Path(__file__).resolve().parents[1] / "crates" / "as" / "programs" / "server1040.as"
    s = start_sim("--as-program", str(program))
    try:
        driver.get(s.info["pendant"] + "/")
        wait_until(lambda: driver.find_element(By.ID, "live-status").text == "live", what="the live feed")
        panel = driver.find_element(By.ID, "as-panel")
        wait_until(lambda: panel.is_displayed(), what="the AS panel shown")
        assert "server1040.as" in driver.find_element(By.ID, "as-program").text

        def row(task):
            """(state, text) of a task's row, read in one script: the page replaces the rows
            when they change, so an element found earlier may be gone."""
            return driver.execute_script(
                "const r = document.querySelector('#as-tasks tr[data-task=\"' + arguments[0] + '\"]');"
                " return r ? [r.dataset.state, r.textContent] : [null, ''];",
                task,
            )

        wait_until(lambda: "TCP_ACCEPT" in row("pc1")[1], what="PC task 1 waiting in TCP_ACCEPT")
        state, text = row("pc1")
        assert state == "running" and "autostart.pc" in text, (state, text)
        assert row("robot")[0] == "idle"
        wait_until(lambda: "autostart.pc started in PC task 1" in driver.find_element(By.ID, "as-terminal").text,
                   what="the terminal line")
        # A client starts the motion program: the robot task runs it.
        raw = Raw(s.info["listen"])
        raw.request("1040 1 0")
        wait_until(lambda: row("robot")[0] == "running", what="the robot task running")
        assert "ros_move" in row("robot")[1].lower()
        raw.close()
    finally:
        s.stop()


def test_the_emulator_page_hides_the_as_panel_without_a_program(sim, driver):
    driver.get(sim.info["pendant"] + "/")
    wait_until(lambda: driver.find_element(By.ID, "live-status").text == "live", what="the live feed")
    assert not driver.find_element(By.ID, "as-panel").is_displayed()


def test_the_hub_page_shows_a_real_robot_and_guards_stop(sim, driver, tmp_path):
    hub = start_hub(sim.info["listen"])
    raw = None
    stop = threading.Event()
    poller = None
    try:
        page = hub.info["http"]
        driver.get(page)
        wait_until(lambda: driver.find_element(By.ID, "live-status").text == "live", what="the live feed")
        wait_until(lambda: driver.find_element(By.TAG_NAME, "body").get_attribute("data-kind") == "hub",
                   what="the hub view")
        # The switches are shown, not switchable.
        assert "MOTOR POWER ON" in driver.find_element(By.ID, "lamp-power").text
        assert not driver.find_element(By.ID, "sw-run").is_displayed()
        assert not driver.find_element(By.ID, "sw-estop").is_displayed()
        # A client of the hub's face moves the arm; the page follows.
        raw = Raw(hub.info["listen"])
        raw.request("1040 3 1 20")
        raw.request("1040 1 0")
        raw.request("1040 6 9 0 0 0 -50 0 -90 0 -90 0")
        poller = keep_polling(raw, stop)
        wait_until(lambda: joint(driver, 1) < -2.0, what="JT1 moving on the hub page")
        wait_until(lambda: "controlling" in driver.find_element(By.ID, "clients").text, what="the client listed")
        # Stop needs a second click.
        button = driver.find_element(By.ID, "btn-stop")
        button.click()
        assert "Click again" in button.text
        time.sleep(0.3)
        assert http_json(sim.info["pendant"], "/state")["task"] == "running", "one click sends nothing"
        button.click()
        wait_until(lambda: http_json(sim.info["pendant"], "/state")["task"] == "not_running",
                   what="the program stopped by the page")
        wait_until(lambda: "stop (command 2) sent" in driver.find_element(By.ID, "events").text,
                   what="the stop in the page's event list")
        shot = tmp_path / "web-hub.png"
        assert driver.save_screenshot(str(shot))
        check_not_blank(shot)
        keep_screenshot(shot, "web-hub.png")
    finally:
        stop.set()
        if poller:
            poller.join(timeout=5)
        if raw:
            raw.close()
        hub.stop()
