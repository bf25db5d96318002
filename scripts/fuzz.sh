#!/usr/bin/env bash
# Fuzzes every parser with libFuzzer (AddressSanitizer + UBSan) and prints a table of executions and findings.
#   scripts/fuzz.sh [SECONDS_PER_TARGET] [TARGET...]     (default 120 s each, all targets; 2 run at a time)
# Installs clang and libFuzzer's runtime with apt-get when missing; not part of test.sh. Corpora grow in
# build/fuzz/corpus/<target> (seeded from tests/data by fuzz/seed_corpora.py); findings land in
# build/fuzz/findings/<target>/ and make the script exit 1.
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
SECONDS_PER_TARGET="${1:-120}"
shift || true
ALL_TARGETS=(packet_decoders pcap ouster_metadata velodyne_calibration pcd ply kitti_bin config csv range_sensor
             beams stereo_calibration stereo_images sick_telegram route_lines)
TARGETS=("${@:-${ALL_TARGETS[@]}}")
cd "$ROOT"

if ! command -v clang++ >/dev/null || ! ls /usr/lib/llvm-*/lib/clang/*/lib/linux/libclang_rt.fuzzer-x86_64.a >/dev/null 2>&1; then
    apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends clang libclang-rt-14-dev >/dev/null
fi
CC=clang CXX=clang++ cmake -S fuzz -B build/fuzz -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo >/dev/null
cmake --build build/fuzz -j "$(nproc)" --target "${TARGETS[@]/%/_fuzz}"
python3 fuzz/seed_corpora.py tests/data build/fuzz/corpus

run_target() {
    local target="$1" work="build/fuzz/work/$1"
    mkdir -p "$work" "build/fuzz/findings/$target"
    # Each target runs in its own folder: the parsers read scratch files written there.
    (cd "$work" && "../../${target}_fuzz" -max_total_time="$SECONDS_PER_TARGET" -max_len=65536 -rss_limit_mb=2048 \
        -print_final_stats=1 -artifact_prefix="../../findings/$target/" "../../corpus/$target" >log.txt 2>&1) || true
}
export -f run_target
export SECONDS_PER_TARGET
printf '%s\n' "${TARGETS[@]}" | xargs -P "$(nproc)" -I{} bash -c 'run_target {}'

printf '| target | executions | corpus | findings |\n|---|---|---|---|\n'
total=0 findings=0
for target in "${TARGETS[@]}"; do
    log="build/fuzz/work/$target/log.txt"
    runs=$(grep -o 'stat::number_of_executed_units: [0-9]*' "$log" | awk '{print $2}' | tail -1)
    found=$(find "build/fuzz/findings/$target" -type f | wc -l)
    # A crash whose input could not be saved (the process out of descriptors, say) still counts.
    if [ "$found" -eq 0 ] && grep -q '^SUMMARY: ' "$log"; then found=1; fi
    printf '| %s | %s | %s | %s |\n' "$target" "${runs:-?}" "$(ls "build/fuzz/corpus/$target" | wc -l)" "$found"
    total=$((total + ${runs:-0})) findings=$((findings + found))
done
printf '| total | %s | | %s |\n' "$total" "$findings"
[ "$findings" -eq 0 ] || { echo "findings: see build/fuzz/findings/ and build/fuzz/work/*/log.txt" >&2; exit 1; }
