#!/usr/bin/env bash
# Issue 32's fleet figures for two builds side by side: `keyfleet bench fleet` on the demo mission
# (DDS-Security, `strategy: full`, density 4; 600-frame flights at 30 frames/s, real time), the
# same generated scenario for every run, the builds alternating run by run (base first in odd
# rounds, new first in even ones) so that both see the host's same minutes. Prints each run and,
# for each N, the medians of new / base run by run.
#   scripts/fleet_ab.sh BASE [--drones "6 8"] [--rounds 3] [--avx2-only] [--out DIR]
# BASE: a git revision, checked out as a worktree in DIR/base-src and built into DIR/base-build
# with its own scripts/build.sh --for demo (its own models too; `git worktree remove
# DIR/base-src` when done), or a folder holding bin/{keyfleet,robot_agent,ground_station} (and
# share/, else this build's models are used). New: this checkout, built into $KEYFLEET_BUILD_DIR
# (build/).
# --avx2-only turns OpenCV's AVX-512 dispatch off (OPENCV_CPU_DISABLE): on a host with AVX-512,
# an approximation of an AVX2-only CPU (docs/evaluation.md). Nothing else should run meanwhile.
# About a minute a run (N = 8) after the builds: 2 builds x rounds x sizes runs.
set -euo pipefail

root=$(cd "$(dirname "$0")/.." && pwd)
build=${KEYFLEET_BUILD_DIR:-$root/build}
python=/usr/bin/python3
usage="usage: scripts/fleet_ab.sh BASE [--drones \"6 8\"] [--rounds 3] [--avx2-only] [--out DIR]"

[ $# -ge 1 ] || { echo "$usage" >&2; exit 2; }
base=$1
shift
drones="6 8"
rounds=3
avx2_only=0
out="$root/runs/fleet-ab-$(date -u +%Y%m%d-%H%M%S)"
while [ $# -gt 0 ]; do
  case "$1" in
    --drones) drones=${2:?--drones needs sizes}; shift 2 ;;
    --rounds) rounds=${2:?--rounds needs a count}; shift 2 ;;
    --avx2-only) avx2_only=1; shift ;;
    --out) out=${2:?--out needs a folder}; shift 2 ;;
    *) echo "fleet_ab: error: unknown argument '$1'" >&2; echo "$usage" >&2; exit 2 ;;
  esac
done
case "$rounds" in
  ''|*[!0-9]*|0) echo "fleet_ab: error: --rounds must be 1 or more" >&2; exit 2 ;;
esac
for n in $drones; do
  case "$n" in
    ''|*[!0-9]*|0)
      echo "fleet_ab: error: --drones takes sizes of 1 or more, got '$n'" >&2
      exit 2 ;;
  esac
done
mkdir -p "$out"
out=$(cd "$out" && pwd)

# The two sides' programs, each in <side>/bin with its models in <side>/share.
programs="keyfleet robot_agent ground_station"
side() {  # side NAME BUILD_DIR: links the build's programs and models into $out/NAME
  local dir="$out/$1"
  mkdir -p "$dir/bin"
  for p in $programs; do
    [ -x "$2/bin/$p" ] || { echo "fleet_ab: error: $2/bin/$p is missing" >&2; exit 1; }
    cp "$2/bin/$p" "$dir/bin/"
  done
  if [ -d "$2/share" ]; then
    ln -sfn "$2/share" "$dir/share"
  else
    echo "fleet_ab: $2 has no share/: its programs read $build/share's models" >&2
    ln -sfn "$build/share" "$dir/share"
  fi
}

"$root/scripts/build.sh" --for demo
if [ -d "$base" ]; then
  side base "$(cd "$base" && pwd)"
else
  rev=$(git -C "$root" rev-parse --verify "$base^{commit}") ||
    { echo "fleet_ab: error: '$base' is neither a folder nor a revision" >&2; exit 1; }
  if [ ! -d "$out/base-src" ]; then
    git -C "$root" worktree add --detach "$out/base-src" "$rev" >/dev/null
  fi
  KEYFLEET_BUILD_DIR="$out/base-build" "$out/base-src/scripts/build.sh" --for demo
  side base "$out/base-build"
fi
side new "$build"
# The programs find the plugins they load (OpenCV's image and video files) through their own
# build folder, which stays where it was built.

if [ "$avx2_only" = 1 ]; then
  # shellcheck source=scripts/avx2_only.sh
  . "$root/scripts/avx2_only.sh"
fi
mission="$root/configs/demo_mission.yaml"
most=0
for n in $drones; do [ "$n" -gt "$most" ] && most=$n; done

# The first run generates the scenario (most drones, 600 frames); every run flies that one.
scenario=""
for round in $(seq 1 "$rounds"); do
  # Base first in odd rounds, new first in even ones: a host whose load drifts over the minutes
  # favours neither side.
  order="base new"
  [ $((round % 2)) = 0 ] && order="new base"
  for n in $drones; do
    for s in $order; do
      dest="$out/runs/$s-n$n-r$round"
      rm -rf "$dest"
      args=(bench fleet "$mission" --drones "$n" --frames 600 --mode realtime --out "$dest")
      if [ -z "$scenario" ]; then
        args=(bench fleet "$mission" --drones "$most" --frames 600 --mode realtime
              --out "$out/runs/scenario")
        echo "fleet_ab: generating the scenario ($most drones) with the first run"
        "$out/$s/bin/keyfleet" "${args[@]}" >"$out/scenario.log" 2>&1 ||
          { echo "fleet_ab: error: the first run failed: $out/scenario.log" >&2; exit 1; }
        generated=("$out"/runs/scenario/fleet-*/scenario)
        scenario=${generated[0]}
        [ -d "$scenario" ] ||
          { echo "fleet_ab: error: no scenario in $out/runs/scenario" >&2; exit 1; }
        args=(bench fleet "$mission" --drones "$n" --frames 600 --mode realtime --out "$dest")
      fi
      echo "fleet_ab: round $round of $rounds, N = $n, $s"
      "$out/$s/bin/keyfleet" "${args[@]}" --scenario-dir "$scenario" >"$dest.log" 2>&1 ||
        echo "fleet_ab: warning: $s at N = $n, round $round failed: $dest.log" >&2
    done
  done
done

"$python" - "$out" <<'EOF'
import glob, json, os, re, statistics, sys

out = sys.argv[1]
fields = [("rt", "real time", "keeps_realtime"), ("rtf", "RTF min", "rtf_min"),
          ("agent", "agent ms/f", "agent_cpu_ms_per_frame"),
          ("station", "station ms/f", "station_cpu_ms_per_frame"),
          ("text", "text CPU ms/kf", "station_text_cpu_ms_per_keyframe"),
          ("places", "places ms/kf", "station_places_ms_per_keyframe"),
          ("deferred", "deferred", "station_deferred")]
# Builds older than fleet.json (before 2026-11-28's) print the same figures as tables only: their
# columns, by the names the benchmark prints, for the fields above that they hold.
printed = {"real time": "keeps_realtime", "RTFmin": "rtf_min", "agent ms/f": "agent_cpu_ms_per_frame",
           "stn ms/f": "station_cpu_ms_per_frame", "OCR cpu": "station_text_cpu_ms_per_keyframe"}
columns = re.compile(r"read p95\+dfr|fps/core|real time|RTFmin|RTF|wall s|lag ms|agent ms/f|"
                     r"strm ms/f|stn ms/f|stn work|stn kf|OCR ms/kf|OCR cpu|frames|late|mode|N")

def from_log(log):
    """The first run's figures from the tables a run printed, or None."""
    lines = open(log, errors="replace").read().splitlines()
    run, stages = None, None
    for header, values in zip(lines, lines[1:]):
        if run is None and header.startswith("mode") and "stn ms/f" in header:
            names, cells = columns.findall(header), values.split()
            if len(names) == len(cells):
                run = dict(zip(names, cells))
        elif stages is None and header.startswith("mode") and "semantic" in header:
            names, cells = header.split(), values.split()
            if len(names) == len(cells):
                stages = dict(zip(names, cells))
    if run is None:
        return None
    row = {key: None for key, _, _ in fields}
    for key, _, source in fields:
        for name, wanted in printed.items():
            if wanted == source and name in run:
                row[key] = run[name] == "yes" if name == "real time" else float(run[name])
    row["semantic"] = float(stages["semantic"]) if stages and "semantic" in stages else None
    return row

runs = {}
for log in sorted(glob.glob(os.path.join(out, "runs", "*-n*-r*.log"))):
    name = os.path.basename(log)[:-4]
    side, n, r = name.split("-")
    found = glob.glob(os.path.join(out, "runs", name, "fleet-*", "fleet.json"))
    if found:
        run = json.load(open(found[0]))["runs"][0]
        row = {key: run.get(source) for key, _, source in fields}
        row["semantic"] = run.get("stage_ms_per_frame", {}).get("semantic")
    else:
        row = from_log(log)
        if row is None:
            print(f"{name}: no fleet.json and no figures in its log (see {log})")
            continue
        print(f"{name}: no fleet.json (an older build): figures read from its log")
    runs[(side, int(n[1:]), int(r[1:]))] = row

def cell(v):
    return "-" if v is None else ("yes" if v is True else "no" if v is False else f"{v:.3g}")

print("| build | N | round | " + " | ".join(t for _, t, _ in fields) + " | semantic ms/f |")
print("|---" * (len(fields) + 4) + "|")
for (side, n, r), row in sorted(runs.items(), key=lambda kv: (kv[0][1], kv[0][2], kv[0][0])):
    print(f"| {side} | {n} | {r} | " + " | ".join(cell(row[k]) for k, _, _ in fields) +
          f" | {cell(row['semantic'])} |")
print()
print("new / base, run by run (median, range):")
for n in sorted({k[1] for k in runs}):
    parts = []
    for key in ("agent", "semantic", "station", "text"):
        ratios = [runs[("new", n, r)][key] / runs[("base", n, r)][key]
                  for (s, m, r) in runs if s == "base" and m == n and ("new", n, r) in runs
                  and runs[("base", n, r)][key] and runs[("new", n, r)][key] is not None]
        if ratios:
            parts.append(f"{key} {statistics.median(ratios):.3f} "
                         f"({min(ratios):.3f}-{max(ratios):.3f}, {len(ratios)} rounds)")
    print(f"  N = {n}: " + "; ".join(parts))
EOF
echo "fleet_ab: every run's figures: $out/runs/*/fleet-*/fleet.json"
