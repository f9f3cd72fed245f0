#!/usr/bin/env bash
# Regenerates the README's results blocks from fresh runs, with the machine and the date:
#   scripts/results.sh            # builds (Release), runs `keyfleet eval configs/eval.yaml`
# The block between <!-- results:eval:begin --> and <!-- results:eval:end --> is replaced;
# its plots go to docs/results/. KEYFLEET_BUILD_DIR overrides build/; KEYFLEET_EVAL_SCENARIO_DIR
# evaluates a scenario generated before instead of generating the default one.
set -euo pipefail

root=$(cd "$(dirname "$0")/.." && pwd)
build=${KEYFLEET_BUILD_DIR:-$root/build}
python=/usr/bin/python3

cmake -S "$root" -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=Release >/dev/null
cmake --build "$build" --target keyfleet

machine="$(nproc) cores, $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | sed 's/^ *//')"
when=$(date -u '+%Y-%m-%d %H:%M UTC')

eval_block() {
  local out="$root/runs/results-eval-$(date +%Y%m%d-%H%M%S)"
  local args=("$root/configs/eval.yaml" --out "$out")
  [ -n "${KEYFLEET_EVAL_SCENARIO_DIR:-}" ] && args+=(--scenario-dir "$KEYFLEET_EVAL_SCENARIO_DIR")
  local start=$SECONDS
  "$build/bin/keyfleet" eval "${args[@]}"
  local took=$((SECONDS - start))
  mkdir -p "$root/docs/results"
  cp "$out/fig6a_words.png" "$root/docs/results/eval_fig6a_words.png"
  cp "$out/fig6b_places.png" "$root/docs/results/eval_fig6b_places.png"
  "$python" - "$out/report.md" "$root/README.md" "$machine" "$when" "$took" <<'PY'
import re, sys
report, readme, machine, when, took = sys.argv[1:]
text = open(report).read()
body = text[text.index("## (a)"):]
body = re.sub(r"^## ", "#### ", body, flags=re.M)
body = body.replace("](fig6a_words.png)", "](docs/results/eval_fig6a_words.png)")
body = body.replace("](fig6b_places.png)", "](docs/results/eval_fig6b_places.png)")
intro = text[text.index("Scenario "):text.index("## (a)")].strip()
block = (f"*Measured {when} on {machine} (shared and busy: figures of time are noisy), "
         f"`scripts/results.sh` ({took} s).* {intro}\n\n{body.strip()}\n")
begin, end = "<!-- results:eval:begin -->", "<!-- results:eval:end -->"
old = open(readme).read()
if begin not in old or end not in old:
    sys.exit(f"{readme}: the {begin} ... {end} markers are missing")
head, rest = old.split(begin, 1)
_, tail = rest.split(end, 1)
open(readme, "w").write(head + begin + "\n" + block + end + tail)
PY
  echo "README results:eval block updated from $out"
}

eval_block
