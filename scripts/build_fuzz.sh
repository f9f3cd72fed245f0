#!/usr/bin/env bash
# Configures and builds the libFuzzer targets (tests/fuzz) with clang-14, ASan and UBSan into
# $KEYFLEET_FUZZ_BUILD_DIR (default build-fuzz/): only the targets and the libraries they link.
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
build_dir=${KEYFLEET_FUZZ_BUILD_DIR:-$root/build-fuzz}
generator=()
command -v ninja >/dev/null 2>&1 && generator=(-G Ninja)
launcher=()
command -v ccache >/dev/null 2>&1 && launcher=(-DCMAKE_CXX_COMPILER_LAUNCHER=ccache)
if [ ! -f "$build_dir/CMakeCache.txt" ]; then
  cmake -S "$root" -B "$build_dir" "${generator[@]}" "${launcher[@]}" \
    -DCMAKE_CXX_COMPILER=clang++-14 -DCMAKE_BUILD_TYPE=RelWithDebInfo -DKEYFLEET_FUZZ=ON \
    -DKEYFLEET_BUILD_TESTS=OFF -DKEYFLEET_BUILD_BENCHMARKS=OFF -DKEYFLEET_WARNINGS_AS_ERRORS=ON
fi
cmake --build "$build_dir" --target fuzz --parallel "${KEYFLEET_JOBS:-$(nproc)}"
