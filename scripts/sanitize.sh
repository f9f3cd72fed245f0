#!/usr/bin/env bash
# The test suite under sanitizers (long: not part of CI). "address": the whole project with gcc,
# ASan and UBSan (RelWithDebInfo) in $KEYFLEET_ASAN_BUILD_DIR (default build-asan/), then the
# whole ctest suite. "thread": the station's worker-pool tests with TSan in
# $KEYFLEET_TSAN_BUILD_DIR (default build-tsan/, only those tests and what they link). Reports
# from third-party libraries are suppressed by tests/sanitizers/*.supp, each entry saying why.
#   ./scripts/sanitize.sh [address|thread|all] [ctest options for the address run...]
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
what=${1:-all}
shift || true
supp=$root/tests/sanitizers
jobs=${KEYFLEET_JOBS:-$(nproc)}
export KEYFLEET_DATA=${KEYFLEET_DATA:-$root/../shared/data}
generator=()
command -v ninja >/dev/null 2>&1 && generator=(-G Ninja)
launcher=()
command -v ccache >/dev/null 2>&1 && launcher=(-DCMAKE_CXX_COMPILER_LAUNCHER=ccache)

configure() {  # BUILD_DIR SANITIZERS
  [ -f "$1/CMakeCache.txt" ] && return
  cmake -S "$root" -B "$1" "${generator[@]}" "${launcher[@]}" -DCMAKE_BUILD_TYPE=RelWithDebInfo \
    -DKEYFLEET_SANITIZE="$2" -DKEYFLEET_BUILD_TESTS=ON -DKEYFLEET_BUILD_BENCHMARKS=OFF \
    -DKEYFLEET_WARNINGS_AS_ERRORS=ON
}

case "$what" in address|thread|all) ;; *)
  echo "sanitize: error: unknown run '$what' (address, thread or all)" >&2; exit 2 ;;
esac

if [ "$what" != thread ]; then
  # OpenCV tries its gphoto2 backend on a file no other backend opens, and libgphoto2 leaks its
  # USB camera scan (from a plugin unloaded at exit, so that no suppression can name it): off.
  export OPENCV_VIDEOIO_PRIORITY_GPHOTO2=0
  dir=${KEYFLEET_ASAN_BUILD_DIR:-$root/build-asan}
  configure "$dir" address,undefined
  cmake --build "$dir" --parallel "$jobs"
  KEYFLEET_BUILD_DIR="$dir" "$root/scripts/fetch_ppocr.sh"
  # intercept_tls_get_addr=0: GCC 12's LeakSanitizer misreads glibc 2.36's dynamic TLS and its
  # tracer crashes at exit in some test programs, test_bow among them (a libsanitizer bug).
  # new_delete_type_mismatch=0: Fast DDS 2.9 deletes its StatisticsReaderImpl through a base of
  # another size when a participant closes (Fast DDS's code; ASan's suppressions cannot name it).
  asan=detect_leaks=1:intercept_tls_get_addr=0:new_delete_type_mismatch=0:strict_string_checks=1
  ASAN_OPTIONS=$asan \
  LSAN_OPTIONS=suppressions=$supp/lsan.supp:print_suppressions=0 \
  UBSAN_OPTIONS=suppressions=$supp/ubsan.supp:print_stacktrace=1:halt_on_error=1 \
    ctest --test-dir "$dir" --output-on-failure --parallel "$jobs" "$@"
fi

if [ "$what" != address ]; then
  dir=${KEYFLEET_TSAN_BUILD_DIR:-$root/build-tsan}
  configure "$dir" thread
  cmake --build "$dir" --target test_station_analysis --parallel "$jobs"
  TSAN_OPTIONS=suppressions=$supp/tsan.supp:halt_on_error=1:second_deadlock_stack=1 \
    ctest --test-dir "$dir" -R '^(AnalysisPool|AnalysisStoreTest|ReadOnlyStores)\.' \
    --output-on-failure --parallel "$jobs"
fi
