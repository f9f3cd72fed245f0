#!/usr/bin/env bash
# The README's second command: set up, build, and run the whole test suite (ctest).
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
"$root/scripts/install_deps.sh"
"$root/scripts/build.sh"
build_dir=${KEYFLEET_BUILD_DIR:-$root/build}
export KEYFLEET_DATA=${KEYFLEET_DATA:-$root/../shared/data}
ctest --test-dir "$build_dir" --output-on-failure --parallel "$(nproc)" "$@"
