#!/usr/bin/env bash
# A longer fuzzing run: each libFuzzer target (tests/fuzz) for SECONDS (default 300) on a fresh
# copy of its seed corpus, one after the other, then per target: executions, executions a
# second, coverage (libFuzzer's cov: edges, ft: features) at the end, corpus size, crashes.
# Crash inputs stay in build-fuzz/fuzz-runs/<target>/; the exit status is 1 if any target crashed.
#   ./scripts/fuzz.sh [SECONDS] [TARGET...]
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
seconds=${1:-300}
shift || true
build_dir=${KEYFLEET_FUZZ_BUILD_DIR:-$root/build-fuzz}
KEYFLEET_FUZZ_BUILD_DIR="$build_dir" "$root/scripts/build_fuzz.sh"
targets=("$@")
if [ ${#targets[@]} -eq 0 ]; then
  for dir in "$root"/tests/fuzz/corpus/*/; do targets+=("$(basename "$dir")"); done
fi

runs="$build_dir/fuzz-runs"
mkdir -p "$runs"
summary=()
failed=0
for target in "${targets[@]}"; do
  work="$runs/$target"
  log="$runs/$target.log"
  echo "fuzz: $target for ${seconds} s (log $log)"
  set +e
  "$root/tests/fuzz/run_fuzzer.sh" "$build_dir/bin/$target" "$root/tests/fuzz/corpus/$target" \
    "$work" "$seconds" >"$log" 2>&1
  status=$?
  set -e
  stat() { sed -n "s/^stat::$1: *//p" "$log" | tail -1; }
  last=$(grep -aE '^#[0-9]+.*cov: ' "$log" | tail -1)
  cov=$(sed -n 's/.* cov: \([0-9]*\).*/\1/p' <<<"$last")
  ft=$(sed -n 's/.* ft: \([0-9]*\).*/\1/p' <<<"$last")
  corpus=$(find "$work/corpus" -type f | wc -l)
  crashes=$(find "$work" -maxdepth 1 -type f \( -name 'crash-*' -o -name 'leak-*' -o -name 'oom-*' \
    -o -name 'timeout-*' \) | wc -l)
  [ "$status" -ne 0 ] && failed=1
  summary+=("$(printf '%-26s %12s %8s %6s %7s %7s %8s' "$target" "$(stat number_of_executed_units)" \
    "$(stat average_exec_per_sec)" "${cov:-?}" "${ft:-?}" "$corpus" "$crashes")")
done

printf '%-26s %12s %8s %6s %7s %7s %8s\n' target executions exec/s cov ft corpus crashes
printf '%s\n' "${summary[@]}"
exit "$failed"
