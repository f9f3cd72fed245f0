#!/usr/bin/env bash
# Where the ground station's CPU goes in a fleet run: `keyfleet bench fleet` on the demo mission
# (the same run as scripts/fleet_ab.sh's) under `perf record`, then the station's samples split
# by thread (its analysis workers, its main thread, the rest: Fast DDS, the dashboard) and by
# library, scaled to the station's measured CPU and divided by the keyframes it stored: ms of
# CPU a keyframe. perf's sampling adds a few per cent to every figure.
#   scripts/profile_station.sh [--drones N] [--avx2-only] [--scenario-dir DIR] [--out DIR]
# Needs perf (Debian: linux-perf) and kernel.perf_event_paranoid <= 2; nothing else should run
# meanwhile. About a minute at N = 8 after the build.
set -euo pipefail

root=$(cd "$(dirname "$0")/.." && pwd)
build=${KEYFLEET_BUILD_DIR:-$root/build}
python=/usr/bin/python3
usage="usage: scripts/profile_station.sh [--drones N] [--avx2-only] [--scenario-dir DIR] [--out DIR]"

drones=8
avx2_only=0
scenario=()
out="$root/runs/station-profile-$(date -u +%Y%m%d-%H%M%S)"
while [ $# -gt 0 ]; do
  case "$1" in
    --drones) drones=${2:?--drones needs a count}; shift 2 ;;
    --avx2-only) avx2_only=1; shift ;;
    --scenario-dir) scenario=(--scenario-dir "${2:?--scenario-dir needs a folder}"); shift 2 ;;
    --out) out=${2:?--out needs a folder}; shift 2 ;;
    *) echo "profile_station: error: unknown argument '$1'" >&2; echo "$usage" >&2; exit 2 ;;
  esac
done
case "$drones" in
  ''|*[!0-9]*|0) echo "profile_station: error: --drones must be 1 or more" >&2; exit 2 ;;
esac
command -v perf >/dev/null ||
  { echo "profile_station: error: perf is missing (Debian: apt-get install linux-perf)" >&2; exit 1; }

"$root/scripts/build.sh" --for demo
if [ "$avx2_only" = 1 ]; then
  # shellcheck source=scripts/avx2_only.sh
  . "$root/scripts/avx2_only.sh"
fi
mkdir -p "$out"
out=$(cd "$out" && pwd)
echo "profile_station: N = $drones under perf; the run in $out"
perf record -F 999 -o "$out/perf.data" -- "$build/bin/keyfleet" bench fleet \
  "$root/configs/demo_mission.yaml" --drones "$drones" --frames 600 --mode realtime \
  "${scenario[@]}" --out "$out/run" >"$out/bench.log" 2>&1 ||
  { echo "profile_station: error: the run failed: $out/bench.log" >&2; exit 1; }
perf script -i "$out/perf.data" -F comm,pid,tid,ip,sym,dso -G 2>/dev/null >"$out/samples.txt"

"$python" - "$out" <<'EOF'
import collections, glob, json, os, re, sys

out = sys.argv[1]
found = glob.glob(os.path.join(out, "run", "fleet-*", "fleet.json"))
if not found:
    sys.exit(f"profile_station: error: no fleet.json under {out}/run")
figures = json.load(open(found[0]))
run = figures["runs"][0]
keyframes = run.get("station_keyframes") or 0
station_ms = (run.get("station_cpu_ms_per_frame") or 0) * run["frames"]
if keyframes == 0 or station_ms == 0:
    sys.exit("profile_station: error: the station stored no keyframe or spent no CPU")

# The station's threads: its process is the one whose main thread is called ground_station.
# keyfleet::vision's kernels, called directly or through OpenCV's parallel_for_.
vision_symbols = ("keyfleet::vision",
                  "std::_Function_handler<void (cv::Range const&), keyfleet::vision")
samples = []
for line in open(os.path.join(out, "samples.txt"), errors="replace"):
    m = re.match(r"\s*(.+?)\s+(\d+)/(\d+)\s+[0-9a-f]+\s+(.*?)\s*\((.*)\)\s*$", line)
    if m:
        comm, pid, tid, symbol, dso = m.groups()
        library = os.path.basename(dso)
        if library == "ground_station":  # keyfleet's own: the networks' kernels or the rest
            vision = symbol.startswith(vision_symbols)
            library += ": vision" if vision else ": the rest"
        samples.append((pid, tid, comm, library))
stations = {pid for pid, tid, comm, _ in samples if pid == tid and comm == "ground_station"}
mine = [s for s in samples if s[0] in stations]
if not mine:
    sys.exit("profile_station: error: perf recorded no sample of the station")

def role(pid, tid, comm):
    if comm.startswith("kf-analysis"):
        return "analysis"
    return "main" if pid == tid else "other threads"

by_role = collections.Counter()
by_library = collections.defaultdict(collections.Counter)
for pid, tid, comm, dso in mine:
    by_role[role(pid, tid, comm)] += 1
    by_library[role(pid, tid, comm)][dso] += 1
per_sample = station_ms / len(mine) / keyframes
start = run["station_cpu_ms_per_frame"] - (run.get("station_work_cpu_ms_per_frame") or 0)
print(f"station: {station_ms / keyframes:.1f} ms of CPU a keyframe ({keyframes} keyframes, "
      f"{run['drones']} drones; {run['station_cpu_ms_per_frame']:.2f} ms a fleet frame, "
      f"{start:.2f} of it the station's start)")
print(f"text reading {run.get('station_text_cpu_ms_per_keyframe', 0):.1f} ms CPU a keyframe, "
      f"the place step {run.get('station_places_ms_per_keyframe', 0):.1f} ms wall")
print()
print("| thread | library | ms of CPU a keyframe |")
print("|---|---|---|")
for r, count in by_role.most_common():
    print(f"| {r} | (all) | {count * per_sample:.2f} |")
    for dso, n in by_library[r].most_common(8):
        if n * per_sample >= 0.05:
            print(f"| | {dso} | {n * per_sample:.2f} |")
print()
print(figures.get("cpu", ""))
EOF
echo "profile_station: samples in $out/perf.data (perf report -i $out/perf.data --sort comm,dso)"
