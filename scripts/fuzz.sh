#!/usr/bin/env bash
# Fuzzes the packet decoders with libFuzzer for SECONDS (default 300) and prints libFuzzer's final counts.
# Needs clang and libFuzzer (Debian: clang, libclang-rt-14-dev); not part of test.sh.
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
SECONDS_TO_RUN="${1:-300}"
cd "$ROOT"
CXX=clang++ cmake -S fuzz -B build/fuzz -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo >/dev/null
cmake --build build/fuzz
mkdir -p build/fuzz/corpus
# Seeds: real packets behind a selector byte (python3 reads the bundled pcaps; stdlib only).
python3 - <<'PY'
import struct, pathlib
out = pathlib.Path("build/fuzz/corpus")
seeds = {0: "OS-1-32-G_v2.1.1_1024x10.pcap", 3: "OS-1-128_v2.3.0_1024x10_lb_n3.pcap",
         5: "../velodyne/velodyne_example.pcap", 7: "../velodyne/hdl32_example.pcap"}
for pick, name in seeds.items():
    data = pathlib.Path("tests/data/ouster", name).read_bytes()
    off, n = 24, 0
    while off + 16 <= len(data) and n < 4:
        incl = struct.unpack_from("<I", data, off + 8)[0]
        payload = data[off + 16 + 42: off + 16 + incl]
        off += 16 + incl
        if len(payload) > 1000:
            (out / f"seed_{pick}_{n}").write_bytes(bytes([pick, 1]) + payload)
            n += 1
PY
build/fuzz/packet_decoders_fuzz -max_total_time="$SECONDS_TO_RUN" -print_final_stats=1 build/fuzz/corpus 2>&1 | tail -25
