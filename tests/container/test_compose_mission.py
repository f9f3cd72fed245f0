#!/usr/bin/python3
"""The images and the compose file, for real: builds the agent and station images
(docker/Dockerfile), generates a two-drone scenario (scenario_two_drones.yaml), flies it with
docker/compose.yaml (two agent replicas and a station on a podman network, DDS discovery inside
it) and checks that every keyframe each agent sent is in the station's database and report.

Skips (exit 77, ctest SKIP_RETURN_CODE) where no container engine works here; set one up with
scripts/container_setup.sh (podman as root, its configuration in $KEYFLEET_CONTAINERS_DIR).
With KEYFLEET_CONTAINER_TEST=required (scripts/test.sh sets it under CI=true or as root, after
container_setup.sh) a reason to skip is a failure, unless `container_setup.sh --check-host` says
this machine cannot run containers at all (no root, or the kernel refuses namespaces or cgroups).
Waits on conditions (container exits) with time limits, never a fixed sleep.

usage: test_compose_mission.py KEYFLEET_BINARY SOURCE_DIR WORK_DIR
"""
import json
import os
import re
import shutil
import sqlite3
import subprocess
import sys
import time
from pathlib import Path

SKIP = 77
BUILD_TIMEOUT_S = 2400     # a cold agent image took 13-17 min on two busy cores
START_TIMEOUT_S = 120
MISSION_TIMEOUT_S = 300    # 150 frames (5 s) per drone, then the drain
STATION_STOP_TIMEOUT_S = 90  # the station drains its analysis (drain_timeout_s 40) on SIGTERM
FRAMES_PER_DRONE = 150
DRONES = ("drone_0", "drone_1")
IMAGES = {"agent": "localhost/keyfleet-agent:latest", "station": "localhost/keyfleet-station:latest"}


SOURCE_DIR = None  # set by main; container_setup.sh --check-host is there


def skip(reason):
    """Skips, or where the container test is required, fails unless the machine cannot run
    containers at all (container_setup.sh --check-host, the one definition of 'cannot')."""
    if os.environ.get("KEYFLEET_CONTAINER_TEST") == "required":
        check = subprocess.run([str(SOURCE_DIR / "scripts/container_setup.sh"), "--check-host"],
                               capture_output=True, text=True)
        if check.returncode != SKIP:
            fail(f"{reason} (KEYFLEET_CONTAINER_TEST=required, and this machine can run "
                 f"containers: {check.stdout.strip()})")
        reason = f"{reason}; {check.stdout.strip()}"
    print(f"SKIP: {reason}", flush=True)
    sys.exit(SKIP)


def fail(reason):
    print(f"FAIL: {reason}", flush=True)
    sys.exit(1)


def run(cmd, timeout, log=None, check=True, env=None):
    """Runs cmd; its output goes to log (a path) or is returned. Fails the test on a non-zero
    exit (check) or past the time limit, naming the command."""
    out = open(log, "w") if log else subprocess.PIPE
    try:
        result = subprocess.run(cmd, stdout=out, stderr=subprocess.STDOUT, text=True,
                                timeout=timeout, env=env)
    except subprocess.TimeoutExpired:
        fail(f"'{' '.join(cmd)}' did not finish within {timeout} s" +
             (f" (output in {log})" if log else ""))
    finally:
        if log:
            out.close()
    if check and result.returncode != 0:
        tail = Path(log).read_text()[-3000:] if log else result.stdout[-3000:]
        fail(f"'{' '.join(cmd)}' exited {result.returncode}:\n{tail}")
    return result


def container_engine_env():
    """The environment podman runs in, or a skip naming what is missing."""
    if os.geteuid() != 0:
        skip("the container test runs rootful podman and needs root")
    for tool in ("podman", "podman-compose"):
        if shutil.which(tool) is None:
            skip(f"{tool} is not installed (scripts/container_setup.sh installs it)")
    conf_dir = Path(os.environ.get("KEYFLEET_CONTAINERS_DIR", "/var/lib/keyfleet-containers"))
    conf = conf_dir / "containers.conf"
    storage = conf_dir / "storage.conf"
    if not conf.is_file() or not storage.is_file():
        skip(f"no podman configuration in {conf_dir} (run scripts/container_setup.sh, with "
             "KEYFLEET_CONTAINERS_DIR set the same way as for this test)")
    env = dict(os.environ, CONTAINERS_CONF=str(conf), CONTAINERS_STORAGE_CONF=str(storage))
    probes = (
        (["podman", "info"], "podman does not start"),
        (["podman", "image", "exists", "debian:12"],
         "the base image debian:12 is missing (scripts/container_setup.sh makes it)"),
        (["podman", "run", "--rm", "debian:12", "true"], "podman cannot run a container here"),
    )
    for cmd, what in probes:
        try:
            probe = subprocess.run(cmd, capture_output=True, text=True, timeout=START_TIMEOUT_S,
                                   env=env)
        except subprocess.TimeoutExpired:
            skip(f"{what}: '{' '.join(cmd)}' did not finish within {START_TIMEOUT_S} s")
        if probe.returncode != 0:
            skip(f"{what}: {(probe.stderr or probe.stdout).strip()[-500:]}")
    return env


def agent_summary(log_path):
    """(frames, keyframes sent, pending) from the agent's last 'done:' line."""
    text = log_path.read_text() if log_path.is_file() else ""
    found = re.findall(r"done: (\d+) frames, (\d+) keyframes sent \(.*?\), (\d+) pending", text)
    if not found:
        fail(f"no 'done:' line in {log_path}")
    return tuple(int(v) for v in found[-1])


def main():
    if len(sys.argv) != 4:
        sys.exit(__doc__)
    global SOURCE_DIR
    keyfleet_bin, source_dir, work = Path(sys.argv[1]), Path(sys.argv[2]), Path(sys.argv[3])
    SOURCE_DIR = source_dir
    env = container_engine_env()
    if work.exists():
        shutil.rmtree(work)
    work.mkdir(parents=True)
    scenario, runs = work / "scenario", work / "run"
    runs.mkdir()
    timings = {}

    started = time.monotonic()
    run([str(keyfleet_bin), "scenario", "generate",
         str(source_dir / "tests/container/scenario_two_drones.yaml"), "--out", str(scenario)],
        timeout=300, log=work / "scenario.log")
    timings["scenario"] = time.monotonic() - started

    # --network host: the RUN steps fetch Debian packages, and container networks here have no
    # way out; the containers of the mission run on their own network.
    for target, tag in IMAGES.items():
        started = time.monotonic()
        run(["podman", "build", "--pull=never", "--network", "host",
             "--build-arg", f"JOBS={os.cpu_count() or 2}", "-f", str(source_dir / "docker/Dockerfile"),
             "--target", target, "-t", tag, str(source_dir)],
            timeout=BUILD_TIMEOUT_S, log=work / f"build-{target}.log", env=env)
        timings[f"build {target}"] = time.monotonic() - started

    project = f"keyfleet-ctest-{os.getpid()}"
    compose = ["podman-compose", "-p", project, "-f", str(source_dir / "docker/compose.yaml")]
    compose_env = dict(env, KEYFLEET_SCENARIO=str(scenario), KEYFLEET_RUNS=str(runs))
    station = f"{project}_station_1"
    agents = [f"{project}_drone_{n}" for n in range(1, len(DRONES) + 1)]
    try:
        started = time.monotonic()
        run(compose + ["up", "-d", "--no-build"], timeout=START_TIMEOUT_S,
            log=work / "compose-up.log", env=compose_env)
        for agent in agents:
            result = run(["podman", "wait", agent], timeout=MISSION_TIMEOUT_S, env=env)
            if result.stdout.strip() != "0":
                fail(f"{agent} exited {result.stdout.strip()} (3: keyframes not acknowledged);"
                     f" logs in {runs}")
        timings["agents"] = time.monotonic() - started
        run(["podman", "stop", "-t", str(STATION_STOP_TIMEOUT_S), station],
            timeout=STATION_STOP_TIMEOUT_S + 30, env=env)
        code = run(["podman", "inspect", "--format", "{{.State.ExitCode}}", station],
                   timeout=60, env=env).stdout.strip()
        if code != "0":
            fail(f"the station exited {code}")
        timings["mission"] = time.monotonic() - started
    finally:
        for name in [station] + agents:
            with open(work / f"{name}.log", "w") as log:
                subprocess.run(["podman", "logs", name], stdout=log, stderr=subprocess.STDOUT,
                               env=env, timeout=60)
        subprocess.run(compose + ["down"], capture_output=True, env=compose_env, timeout=120)
        subprocess.run(["podman", "network", "rm", "-f", f"{project}_fleet"], capture_output=True,
                       env=env, timeout=60)

    # Every keyframe each agent sent is stored once, and the station's stats and report agree.
    database = sqlite3.connect(f"file:{runs / 'station' / 'station.sqlite'}?mode=ro", uri=True)
    stored = dict(database.execute("SELECT robot_id, COUNT(*) FROM keyframes GROUP BY robot_id"))
    stats = {row[0]: row[1:] for row in database.execute(
        "SELECT robot_id, keyframes_sent, keyframes_pending, finished FROM agent_stats")}
    report = json.loads((runs / "station" / "report.json").read_text())
    reported = {robot["robot_id"]: robot["keyframes_stored"] for robot in report["robots"]}
    if sorted(stored) != list(DRONES):
        fail(f"the station stored keyframes of {sorted(stored)}, expected {list(DRONES)}")
    for drone in DRONES:
        frames, sent, pending = agent_summary(runs / drone / "agent.log")
        print(f"{drone}: {frames} frames, {sent} keyframes sent, {pending} pending; station: "
              f"{stored[drone]} stored, agent stats {stats.get(drone)}, report "
              f"{reported.get(drone)}")
        if frames != FRAMES_PER_DRONE:
            fail(f"{drone} saw {frames} frames, expected {FRAMES_PER_DRONE}")
        if sent == 0 or pending != 0:
            fail(f"{drone} sent {sent} keyframes and left {pending} pending")
        if stored[drone] != sent or reported.get(drone) != sent:
            fail(f"{drone} sent {sent} keyframes, the station stored {stored[drone]} and "
                 f"reported {reported.get(drone)}")
        if stats.get(drone) != (sent, 0, 1):
            fail(f"{drone}'s final stats at the station are {stats.get(drone)}, expected "
                 f"(sent={sent}, pending=0, finished=1)")
    print("container test: " + ", ".join(f"{k} {v:.0f} s" for k, v in timings.items()))
    print("PASS: every keyframe delivered")


if __name__ == "__main__":
    main()
