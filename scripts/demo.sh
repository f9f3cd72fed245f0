#!/usr/bin/env bash
# The README's first command: installs what building and flying the demo needs (install_deps.sh
# --for demo: no test, training or browser packages), builds the three programs it runs, and flies
# the demo mission (3 drones + station).
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
"$root/scripts/install_deps.sh" --for demo
"$root/scripts/build.sh" --for demo
build_dir=${KEYFLEET_BUILD_DIR:-$root/build}
cd "$root"
exec "$build_dir/bin/keyfleet" mission "${1:-configs/demo_mission.yaml}"
