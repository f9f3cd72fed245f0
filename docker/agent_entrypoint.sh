#!/bin/bash
# robot_agent in a container: chooses the robot id and its run folder, then runs robot_agent
# with this container's arguments. The robot id is
#  - $KEYFLEET_ROBOT_ID when set;
#  - else, with a scenario mounted at $KEYFLEET_SCENARIO (default /scenario), the first of its
#    drone_* folders not yet claimed in $KEYFLEET_RUNS (default /runs): the claim is a mkdir,
#    atomic on the shared folder, so the replicas of one compose service fly one drone each;
#  - else drone_<hostname>.
set -euo pipefail
runs=${KEYFLEET_RUNS:-/runs}
scenario=${KEYFLEET_SCENARIO:-/scenario}
robot_id=${KEYFLEET_ROBOT_ID:-}
mkdir -p "$runs"
if [ -z "$robot_id" ] && [ -d "$scenario" ]; then
  for dir in "$scenario"/drone_*/; do
    [ -d "$dir" ] || continue
    name=$(basename "$dir")
    if mkdir "$runs/$name" 2>/dev/null; then
      robot_id=$name
      break
    fi
  done
  if [ -z "$robot_id" ]; then
    echo "agent_entrypoint: error: no unclaimed drone_* folder in $scenario (claims are in" \
         "$runs; more replicas than drones, or a reused run folder?)" >&2
    exit 1
  fi
fi
if [ -z "$robot_id" ]; then
  robot_id=drone_$(hostname | tr -c 'A-Za-z0-9_\n-' '_' | cut -c1-24)
fi
mkdir -p "$runs/$robot_id"
echo "agent_entrypoint: robot $robot_id, run folder $runs/$robot_id"
exec /usr/local/bin/robot_agent --robot-id "$robot_id" --run-dir "$runs/$robot_id" \
  --log-file "$runs/$robot_id/agent.log" "$@"
