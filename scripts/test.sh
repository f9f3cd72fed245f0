#!/usr/bin/env bash
# The README's second command: set up, build, and run the whole test suite (ctest), then build
# the libFuzzer targets (build-fuzz/, clang) and run each for a short fixed time (ctest -L fuzz).
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
"$root/scripts/install_deps.sh"
"$root/scripts/build.sh"
build_dir=${KEYFLEET_BUILD_DIR:-$root/build}
export KEYFLEET_DATA=${KEYFLEET_DATA:-$root/../shared/data}
ctest --test-dir "$build_dir" --output-on-failure --parallel "$(nproc)" "$@"
fuzz_dir=${KEYFLEET_FUZZ_BUILD_DIR:-$root/build-fuzz}
KEYFLEET_FUZZ_BUILD_DIR="$fuzz_dir" "$root/scripts/build_fuzz.sh"
ctest --test-dir "$fuzz_dir" -L fuzz --output-on-failure --parallel "$(nproc)"
