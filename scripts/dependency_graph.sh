#!/usr/bin/env bash
# Draws keyfleet's target dependencies (libraries, executables, Fast DDS) into
# docs/dependencies.png with `cmake --graphviz` and Graphviz's dot.
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
command -v dot >/dev/null 2>&1 || {
  echo "dependency_graph: Graphviz's dot is missing (apt-get install graphviz)" >&2
  exit 1
}
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
cp "$root/cmake/CMakeGraphVizOptions.cmake" "$work/"
(cd "$work" && cmake -S "$root" -B . -DKEYFLEET_BUILD_TESTS=OFF -DKEYFLEET_BUILD_BENCHMARKS=OFF \
  --graphviz=keyfleet.dot >/dev/null)
dot -Tpng -Gdpi=80 -Grankdir=BT "$work/keyfleet.dot" -o "$root/docs/dependencies.png"
echo "dependency_graph: wrote docs/dependencies.png"
