#!/usr/bin/env bash
# Sets up roadpreview and runs every test: the C++ suite (GoogleTest + find_package consumer, via ctest), the
# C++ suite again built with AddressSanitizer + UBSan, and the Python suite (bindings, numpy reference,
# cross-checks, CLI, CMake package; via pytest).
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
source "$ROOT/scripts/setup.sh"

cd "$ROOT"
log "building and running the C++ tests"
cmake -S . -B build/ctest -G Ninja -DROADPREVIEW_BUILD_TESTS=ON -DROADPREVIEW_BUILD_PYTHON=OFF >/dev/null
cmake --build build/ctest -j "$(nproc)"
ctest --test-dir build/ctest -j "$(nproc)" --output-on-failure

log "building and running the C++ tests with AddressSanitizer and UndefinedBehaviorSanitizer"
# The find_package consumer and the search benchmark add nothing under the sanitizers but time.
cmake -S . -B build/sanitize -G Ninja -DROADPREVIEW_BUILD_TESTS=ON -DROADPREVIEW_BUILD_PYTHON=OFF \
      -DROADPREVIEW_BUILD_CLI=OFF -DROADPREVIEW_SANITIZE=address,undefined >/dev/null
cmake --build build/sanitize -j "$(nproc)"
ASAN_OPTIONS=detect_leaks=1:abort_on_error=1 UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1 \
    ctest --test-dir build/sanitize -j "$(nproc)" --output-on-failure -E "find_package_consumer|cluster_search_bench"

log "running the Python tests"
python -m pytest -q tests/python
