#!/usr/bin/env bash
# The README's first command: set up, build, and fly the demo mission (3 drones + station).
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
"$root/scripts/install_deps.sh"
"$root/scripts/build.sh"
build_dir=${KEYFLEET_BUILD_DIR:-$root/build}
cd "$root"
exec "$build_dir/bin/keyfleet" mission "${1:-configs/demo_mission.yaml}"
