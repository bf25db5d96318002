#!/usr/bin/env bash
# Builds the C++ suite with AddressSanitizer and UndefinedBehaviorSanitizer (-DROADPREVIEW_SANITIZE) in its own
# build directory (build/sanitize, -O1 -g) and runs it; a sanitizer report fails the run. Sets up like test.sh
# unless ROADPREVIEW_SETUP_DONE=1 (test.sh runs it last, after its own setup).
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
if [ "${ROADPREVIEW_SETUP_DONE:-0}" = 1 ]; then
    log() { printf '\033[1m[sanitize]\033[0m %s\n' "$*" >&2; }
else
    source "$ROOT/scripts/setup.sh"
fi
started=$SECONDS
# Recompiles only what changed when ccache is there (the sanitizer flags make every object differ from build/ctest's).
if command -v ccache >/dev/null && [ -z "${CMAKE_CXX_COMPILER_LAUNCHER:-}" ]; then
    export CMAKE_CXX_COMPILER_LAUNCHER=ccache CMAKE_C_COMPILER_LAUNCHER=ccache
fi

cd "$ROOT"
log "building and running the C++ tests with AddressSanitizer and UndefinedBehaviorSanitizer"
# The find_package consumer and the search benchmark add nothing under the sanitizers but time.
# -O1 with debug info: sanitizer reports with usable stacks at about a third of -O3's compile time.
cmake -S . -B build/sanitize -G Ninja -DROADPREVIEW_BUILD_TESTS=ON -DROADPREVIEW_BUILD_PYTHON=OFF \
      -DROADPREVIEW_BUILD_CLI=OFF -DROADPREVIEW_SANITIZE=address,undefined \
      -DCMAKE_BUILD_TYPE=Sanitize -DCMAKE_CXX_FLAGS_SANITIZE="-O1 -g" -DCMAKE_C_FLAGS_SANITIZE="-O1 -g" >/dev/null
tests=$(cmake --build build/sanitize --target help | sed -n 's/^\.\.\. \([a-z_]*_test\)$/\1/p; s/^\([a-z_]*_test\): .*/\1/p')
cmake --build build/sanitize -j "$(nproc)" --target $tests
built=$SECONDS
# Only *_test targets are built here: the consumer, the benchmarks and the no-exceptions build are left out.
ASAN_OPTIONS=detect_leaks=1:abort_on_error=1 UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1 \
    ctest --test-dir build/sanitize -j "$(nproc)" --output-on-failure \
    -E "find_package_consumer|cluster_search_bench|frame_tail_bench|realtime_noexceptions"
log "sanitizer build: $((built - started)) s, tests: $((SECONDS - built)) s"
