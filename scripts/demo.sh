#!/usr/bin/env bash
# Sets up roadpreview and runs the main job: the CLI over the bundled Ouster OS1-128 recording (the paper's
# sensor; 3 frames at 10 Hz), driving at 2.5 m/s (its poses file: about 0.25 m per frame) with the yaw rate
# from the sensor's IMU, one JSON line per frame into demo_output.jsonl, progress and a summary on stderr.
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
source "$ROOT/scripts/setup.sh"

cd "$ROOT"
roadpreview run tests/data/ouster/OS-1-128_v2.3.0_1024x10_lb_n3.pcap --sensor-height 1.97 --speed 2.5 \
    -o demo_output.jsonl
python - <<'PY'
import json
for line in open("demo_output.jsonl"):
    r = json.loads(line)
    rough = r["roughness"]
    v = rough["vehicle"]
    fit = f'G_d(n0) = {v["gd_n0"] * 1e6:.0f}e-6 m³, confidence {v["confidence"]:.2f}' if v["class"] else v["reason"]
    iri = f'{v["iri"]["value"]:.1f} m/km' if v["iri"]["value"] is not None else v["iri"]["reason"]
    if v["iri"]["noise"] is not None:
        iri += f' (its bins\' errors alone: {v["iri"]["noise"]:.1f})'  # docs/method.md §6
    print(f'frame at t = {r["timestamp"]:.3f} s: yaw rate {r["motion"]["yaw_rate"]:+.4f} rad/s '
          f'({r["path"]["yaw_rate_source"]}), left {rough["left"]["class"]}, right {rough["right"]["class"]}, '
          f'vehicle {v["class"]} ({fit}), IRI {iri}, {r["timing_ms"]["total"]:.2f} ms')
PY
echo "full output: demo_output.jsonl (schema: docs/output.md)"
