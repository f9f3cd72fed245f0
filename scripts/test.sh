#!/usr/bin/env bash
# The README's second command: installs what the tests need (install_deps.sh --for tests: the demo's
# packages, GoogleTest, clang with libFuzzer, torch, chromium, ...), builds everything, runs the
# whole test suite (ctest), then builds the libFuzzer targets (build-fuzz/, clang) and runs each
# for a short fixed time (ctest -L fuzz).
# The container test (tests/container: both images, a two-drone compose mission) runs for real
# under CI=true and whenever this runs as root: scripts/container_setup.sh sets podman up first
# and fails loudly when it cannot, and the test may skip only where this machine cannot run
# containers at all (no root, or the kernel refuses namespaces or cgroups: it prints which).
# Elsewhere it skips, saying why, as before.
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
"$root/scripts/install_deps.sh" --for tests
"$root/scripts/build.sh" --for tests
build_dir=${KEYFLEET_BUILD_DIR:-$root/build}
export KEYFLEET_DATA=${KEYFLEET_DATA:-$root/../shared/data}

if [ "${CI:-}" = true ] || [ "$(id -u)" -eq 0 ]; then
  if "$root/scripts/container_setup.sh" --check-host; then
    "$root/scripts/container_setup.sh"
    # A skip of the container test is now a failure (tests/container/test_compose_mission.py).
    export KEYFLEET_CONTAINER_TEST=required
  else
    echo "test: the container test will skip: this machine cannot run containers (see above)"
  fi
fi

ctest --test-dir "$build_dir" --output-on-failure --parallel "$(nproc)" "$@"
fuzz_dir=${KEYFLEET_FUZZ_BUILD_DIR:-$root/build-fuzz}
KEYFLEET_FUZZ_BUILD_DIR="$fuzz_dir" "$root/scripts/build_fuzz.sh"
ctest --test-dir "$fuzz_dir" -L fuzz --output-on-failure --parallel "$(nproc)"
