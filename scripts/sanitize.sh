#!/usr/bin/env bash
# Builds the C++ suite with AddressSanitizer and UndefinedBehaviorSanitizer (-DROADPREVIEW_SANITIZE) and runs it;
# a sanitizer report fails the run. Sets up like test.sh. About twice test.sh's C++ build time on 2 cores.
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
source "$ROOT/scripts/setup.sh"

cd "$ROOT"
log "building and running the C++ tests with AddressSanitizer and UndefinedBehaviorSanitizer"
# The find_package consumer and the search benchmark add nothing under the sanitizers but time.
cmake -S . -B build/sanitize -G Ninja -DROADPREVIEW_BUILD_TESTS=ON -DROADPREVIEW_BUILD_PYTHON=OFF \
      -DROADPREVIEW_BUILD_CLI=OFF -DROADPREVIEW_SANITIZE=address,undefined >/dev/null
cmake --build build/sanitize -j "$(nproc)"
ASAN_OPTIONS=detect_leaks=1:abort_on_error=1 UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1 \
    ctest --test-dir build/sanitize -j "$(nproc)" --output-on-failure -E "find_package_consumer|cluster_search_bench"
