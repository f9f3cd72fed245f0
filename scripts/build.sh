#!/usr/bin/env bash
# Configures and builds keyfleet (Release) into $KEYFLEET_BUILD_DIR (default build/), then fetches
# and converts the optional ppocr text models (a failure there only warns).
#   build.sh --for demo    the three programs the demo runs (keyfleet, robot_agent,
#                          ground_station); a new build folder is configured without tests and
#                          benchmarks, so that install_deps.sh --for demo suffices
#   build.sh [--for tests] everything, tests and benchmarks included (turned on where a demo
#                          build folder had them off)
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
build_dir=${KEYFLEET_BUILD_DIR:-$root/build}
purpose=tests
case "${1:-}" in
  "") ;;
  --for) purpose=${2:-} ;;
  --for=*) purpose=${1#--for=} ;;
  *) echo "build: error: unknown option '$1' (--for demo|tests)" >&2; exit 2 ;;
esac
generator=()
command -v ninja >/dev/null 2>&1 && generator=(-G Ninja)
cache="$build_dir/CMakeCache.txt"
case "$purpose" in
  demo)
    if [ ! -f "$cache" ]; then
      cmake -S "$root" -B "$build_dir" "${generator[@]}" -DCMAKE_BUILD_TYPE=Release \
        -DKEYFLEET_BUILD_TESTS=OFF -DKEYFLEET_BUILD_BENCHMARKS=OFF -DKEYFLEET_WARNINGS_AS_ERRORS=ON
    fi
    cmake --build "$build_dir" --parallel "$(nproc)" --target keyfleet robot_agent ground_station ;;
  tests)
    if [ ! -f "$cache" ]; then
      cmake -S "$root" -B "$build_dir" "${generator[@]}" -DCMAKE_BUILD_TYPE=Release \
        -DKEYFLEET_BUILD_TESTS=ON -DKEYFLEET_WARNINGS_AS_ERRORS=ON
    elif grep -qE '^KEYFLEET_BUILD_(TESTS|BENCHMARKS):BOOL=OFF' "$cache"; then
      echo "build: $build_dir was configured for the demo: turning tests and benchmarks on"
      cmake -S "$root" -B "$build_dir" -DKEYFLEET_BUILD_TESTS=ON -DKEYFLEET_BUILD_BENCHMARKS=ON
    fi
    cmake --build "$build_dir" --parallel "$(nproc)" ;;
  *) echo "build: error: --for needs 'demo' or 'tests', got '$purpose'" >&2; exit 2 ;;
esac
KEYFLEET_BUILD_DIR="$build_dir" "$root/scripts/fetch_ppocr.sh"
