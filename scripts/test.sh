#!/usr/bin/env bash
# Sets up roadpreview and runs every test: the C++ suite (GoogleTest + find_package consumer, via ctest) and the
# Python suite (bindings, numpy reference, cross-checks, CLI, CMake package; via pytest); then the C++ suite again
# built with AddressSanitizer + UBSan (scripts/sanitize.sh), which ROADPREVIEW_SANITIZER=0 skips (local runs).
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
source "$ROOT/scripts/setup.sh"

cd "$ROOT"
log "building and running the C++ tests"
cmake -S . -B build/ctest -G Ninja -DROADPREVIEW_BUILD_TESTS=ON -DROADPREVIEW_BUILD_PYTHON=OFF >/dev/null
cmake --build build/ctest -j "$(nproc)"
ctest --test-dir build/ctest -j "$(nproc)" --output-on-failure

log "running the Python tests"
python -m pytest -q tests/python

# The ASan + UBSan build of the C++ suite (README, Hardening): its own build directory, so it runs last.
if [ "${ROADPREVIEW_SANITIZER:-1}" != 0 ]; then
    ROADPREVIEW_SETUP_DONE=1 "$ROOT/scripts/sanitize.sh"
fi
