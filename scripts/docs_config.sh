#!/usr/bin/env bash
# Regenerates the key tables of docs/configuration.md (between <!-- config-reference:begin -->
# and <!-- config-reference:end -->) from the config structs: `keyfleet config reference`.
#   scripts/docs_config.sh            (builds keyfleet in build/ first; KEYFLEET_BUILD_DIR overrides)
# `ctest -R ConfigReference` fails while the page and the structs differ.
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
build=${KEYFLEET_BUILD_DIR:-$root/build}
cmake --build "$build" --target keyfleet >/dev/null
"$build/bin/keyfleet" config reference | /usr/bin/python3 -c '
import sys
page = sys.argv[1]
block = sys.stdin.read()
begin, end = "<!-- config-reference:begin -->", "<!-- config-reference:end -->"
old = open(page).read()
if begin not in old or end not in old:
    sys.exit(f"{page}: the {begin} ... {end} markers are missing")
head, rest = old.split(begin, 1)
_, tail = rest.split(end, 1)
open(page, "w").write(head + begin + "\n" + block + end + tail)
' "$root/docs/configuration.md"
echo "docs/configuration.md: key tables regenerated"
