#!/usr/bin/env bash
# Configures and builds keyfleet (Release, tests included) into $KEYFLEET_BUILD_DIR (default build/),
# then fetches and converts the optional ppocr text models (a failure there only warns).
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
build_dir=${KEYFLEET_BUILD_DIR:-$root/build}
generator=()
command -v ninja >/dev/null 2>&1 && generator=(-G Ninja)
if [ ! -f "$build_dir/CMakeCache.txt" ]; then
  cmake -S "$root" -B "$build_dir" "${generator[@]}" -DCMAKE_BUILD_TYPE=Release \
    -DKEYFLEET_BUILD_TESTS=ON -DKEYFLEET_WARNINGS_AS_ERRORS=ON
fi
cmake --build "$build_dir" --parallel "$(nproc)"
KEYFLEET_BUILD_DIR="$build_dir" "$root/scripts/fetch_ppocr.sh"
