#!/usr/bin/python3
"""The live dashboard in a real browser (Debian's chromium, headless, through python3-selenium).

1. `keyfleet mission` flies a short generated scenario (real robot_agent and ground_station
   processes on a DDS domain and partition of their own); the page, opened at the address the
   mission prints, must show the robots' stored counts and thumbnails growing while keyframes
   arrive, without console errors.
2. A ground station started on the finished run's database serves that run: same counts as
   its report.json, and a word search returns the keyframe the database has that word in.
Screenshots go to OUT_DIR. Exits 77 (ctest SKIP_RETURN_CODE) when no browser or driver is there.

Usage: test_dashboard_browser.py KEYFLEET_BIN GROUND_STATION_BIN PPOCR_DIR OUT_DIR
"""
import json
import os
import random
import re
import shutil
import sqlite3
import subprocess
import sys
import threading
import time
from pathlib import Path

SKIP = 77


def skip(why):
    print(f"SKIPPED: {why}")
    sys.exit(SKIP)


try:
    from selenium import webdriver
    from selenium.webdriver.chrome.service import Service
    from selenium.common.exceptions import TimeoutException
    from selenium.webdriver.common.by import By
    from selenium.webdriver.support.ui import WebDriverWait
except ImportError:
    skip("python3-selenium is not installed (scripts/install_deps.sh installs it)")

CHROMIUM = shutil.which("chromium")
DRIVER = shutil.which("chromedriver")
if not CHROMIUM or not DRIVER:
    skip("chromium and chromium-driver are not installed (scripts/install_deps.sh installs them)")


class Lines:
    """A child's stdout, line by line, read on a thread: waits never block on the pipe."""

    def __init__(self, process):
        self.lines, self.cond, self.ended = [], threading.Condition(), False
        threading.Thread(target=self._read, args=(process,), daemon=True).start()

    def _read(self, process):
        for line in process.stdout:
            with self.cond:
                self.lines.append(line.rstrip("\n"))
                self.cond.notify_all()
        with self.cond:
            self.ended = True
            self.cond.notify_all()

    def wait_for(self, pattern, timeout):
        deadline = time.monotonic() + timeout
        with self.cond:
            while True:
                for line in self.lines:
                    if m := re.search(pattern, line):
                        return m
                left = deadline - time.monotonic()
                if left <= 0 or self.ended:
                    why = "the process ended" if self.ended else f"{timeout} s passed"
                    raise AssertionError(f"no line matching {pattern!r} ({why}):\n"
                                         + "\n".join(self.lines[-30:]))
                self.cond.wait(left)


def browser():
    options = webdriver.ChromeOptions()
    options.binary_location = CHROMIUM
    for flag in ("--headless=new", "--no-sandbox", "--disable-gpu", "--disable-dev-shm-usage",
                 "--window-size=1400,1600"):
        options.add_argument(flag)
    options.set_capability("goog:loggingPrefs", {"browser": "ALL"})
    return webdriver.Chrome(service=Service(executable_path=DRIVER),
                            options=options)


def counts(driver):
    """{robot: (stored shown in the table, thumbnails shown)} as the page shows them now."""
    return driver.execute_script("""
        const out = {};
        for (const row of document.querySelectorAll('#robots tbody tr[data-robot]')) {
          const robot = row.dataset.robot;
          const strip = document.querySelector(`.strip[data-robot="${robot}"]`);
          out[robot] = [Number(row.querySelector('td.stored').textContent),
                        strip ? strip.querySelectorAll('figure.kf').length : 0];
        }
        return out;""")


def console_errors(driver):
    return [e for e in driver.get_log("browser") if e["level"] == "SEVERE"]


def wait(driver, what, condition, timeout=60):
    return WebDriverWait(driver, timeout, poll_frequency=0.2).until(
        lambda d: condition(d), message=what)


def live_mission(keyfleet, ppocr_dir, out):
    (out / "scenario.yaml").write_text(
        "name: browser\nseed: 11\nframes_per_drone: 250\nfps: 10\nwidth: 640\nheight: 480\n"
        "street: {length_m: 80}\ndrones: {count: 2, days: 1, speed_mps: 2.0}\n")
    # The station's default reader where scripts/fetch_ppocr.sh has fetched its models.
    engine = "ppocr" if (Path(ppocr_dir) / "ppocr_det_640x480.onnx").exists() else "tesseract"
    # 25 s of flight at 10 fps, a keyframe a second per drone: the station (which loads its
    # readers for several seconds on a busy machine) still receives most of them after the
    # page is open.
    (out / "mission.yaml").write_text(
        f"name: browser\nscenario: scenario.yaml\nrun_root: {out / 'runs'}\n"
        "agent_timeout_s: 120\nstation_drain_timeout_s: 60\n"
        "agent:\n  source: {realtime: true}\n"
        "  selector: {strategy: vslam, trigger: {kind: stride, stride: 10}}\n"
        "  dds: {lease_duration_s: 2, announcement_period_s: 0.5}\n"
        f"station:\n  analysis: {{drain_timeout_s: 30, text: {{engine: {engine}}}}}\n"
        "  dashboard: {update_period_s: 0.25}\n")
    mission = subprocess.Popen([keyfleet, "mission", str(out / "mission.yaml")],
                               stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    lines = Lines(mission)
    driver = None
    try:
        url = lines.wait_for(r"dashboard: (http://\S+)", 120).group(1)
        run_dir = Path(lines.wait_for(r"run folder: (\S+)", 5).group(1))
        driver = browser()
        driver.get(url)
        wait(driver, "the page to say it is live",
             lambda d: d.find_element(By.ID, "status").text == "live")
        # Every distinct (stored, thumbnails) each drone showed: two or more positive ones each
        # mean the page followed keyframes as they arrived, without a reload.
        seen = {"drone_0": set(), "drone_1": set()}

        def followed(d):
            for robot, shown in counts(d).items():
                if robot in seen and shown[0] > 0 and shown[1] > 0:
                    seen[robot].add(tuple(shown))
            return all(len({s[0] for s in v}) >= 2 and len({s[1] for s in v}) >= 2
                       for v in seen.values())
        try:
            wait(driver, "", followed, timeout=90)
        except TimeoutException:
            raise AssertionError(f"the page did not follow both drones' keyframes: saw {seen}")
        print(f"live page followed the drones: {seen}")
        driver.save_screenshot(str(out / "dashboard_live.png"))
        errors = console_errors(driver)
        assert not errors, f"console errors on the live page: {errors}"
    finally:
        if driver:
            driver.quit()
    lines.wait_for(r"^mission (OK|FAILED)", 240)
    assert mission.wait(timeout=30) == 0, "\n".join(lines.lines[-40:])
    lines.wait_for(r"report\.html", 1)
    assert (run_dir / "report.html").exists()
    return run_dir


def old_run(station_bin, run_dir, out):
    database = run_dir / "station" / "station.sqlite"
    with sqlite3.connect(f"file:{database}?mode=ro", uri=True) as db:
        row = db.execute("SELECT text, robot_id, sequence_number FROM words "
                         "WHERE length(text) >= 4 AND text GLOB '[A-Za-z]*' "
                         "ORDER BY confidence DESC LIMIT 1").fetchone()
    assert row, f"the station read no word in {database}: nothing to search for"
    word, robot, sequence = row
    report = json.loads((run_dir / "station" / "report.json").read_text())
    station_dir = out / "replay"
    if station_dir.exists():
        shutil.rmtree(station_dir)
    shutil.copytree(run_dir / "station", station_dir)
    env = dict(os.environ, KEYFLEET_DOMAIN=str(random.randint(100, 230)),
               KEYFLEET_PARTITION=f"browser-replay-{os.getpid()}")
    station = subprocess.Popen(
        [station_bin, "--config", str(run_dir / "config" / "station.yaml"), "--run-dir",
         str(station_dir)], stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, env=env)
    lines = Lines(station)
    driver = None
    try:
        url = lines.wait_for(r"dashboard at (http://\S+)", 60).group(1)
        driver = browser()
        driver.get(url)
        expected = {r["robot_id"]: r["keyframes_stored"] for r in report["robots"]}
        wait(driver, f"the old run's counts {expected}",
             lambda d: {r: c[0] for r, c in counts(d).items() if r != "FLEET"} == expected and
             all(c[1] > 0 for r, c in counts(d).items() if r != "FLEET"))
        box = driver.find_element(By.ID, "search-text")
        box.send_keys(word)
        driver.find_element(By.CSS_SELECTOR, "#search button").click()
        key = f"{robot}#{sequence}"
        hits = wait(driver, f"search '{word}' to list {key}",
                    lambda d: [e.get_attribute("data-key") for e in
                               d.find_elements(By.CSS_SELECTOR, "#search-results .hit")] or None)
        assert key in hits, f"search '{word}' gave {hits}, not {key}"
        print(f"old run: counts {expected}; search '{word}' -> {hits}")
        wait(driver, "word boxes on the thumbnails",
             lambda d: d.find_elements(By.CSS_SELECTOR, ".strip rect.word"))
        driver.save_screenshot(str(out / "dashboard.png"))
        errors = console_errors(driver)
        assert not errors, f"console errors on the old run's page: {errors}"
    finally:
        if driver:
            driver.quit()
        station.terminate()
        station.wait(timeout=90)


def main():
    keyfleet, station_bin, ppocr_dir, out = sys.argv[1:5]
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    run_dir = live_mission(keyfleet, ppocr_dir, out)
    old_run(station_bin, run_dir, out)
    print(f"screenshots: {out / 'dashboard_live.png'}, {out / 'dashboard.png'}")
    print("PASSED")


if __name__ == "__main__":
    main()
