#!/usr/bin/env bash
# Runs one libFuzzer target for a fixed time on a fresh copy of its seed corpus; exits non-zero
# when it finds a crash, a leak, a timeout or undefined behaviour (the input lands in WORK_DIR).
#   run_fuzzer.sh FUZZER SEED_CORPUS WORK_DIR SECONDS [libFuzzer options...]
set -euo pipefail
fuzzer=$1 seeds=$2 work=$3 seconds=$4
shift 4
rm -rf "$work"
mkdir -p "$work/corpus"
cp "$seeds"/* "$work/corpus/"
exec "$fuzzer" -max_total_time="$seconds" -timeout=30 -print_final_stats=1 \
  -artifact_prefix="$work/" "$@" "$work/corpus"
