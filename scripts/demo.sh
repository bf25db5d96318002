#!/usr/bin/env bash
# Sets up roadpreview and runs the main job: the CLI over the bundled KITTI frames, driving at 5 m/s
# in a gentle left curve, one JSON line per frame into demo_output.jsonl, progress and a summary on stderr.
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
source "$ROOT/scripts/setup.sh"

cd "$ROOT"
roadpreview run tests/data/semantickitti --sensor-height 1.73 --speed 5 --yaw-rate 0.05 -o demo_output.jsonl
python - <<'PY'
import json
for line in open("demo_output.jsonl"):
    r = json.loads(line)
    rough = r["roughness"]
    gd = rough["vehicle"]["gd_n0"]
    print(f'{r["source"]}: left {rough["left"]["class"]}, right {rough["right"]["class"]}, '
          f'vehicle {rough["vehicle"]["class"]} (G_d(n0) = {gd * 1e6:.0f}e-6 m³), {r["timing_ms"]["total"]:.2f} ms')
PY
echo "full output: demo_output.jsonl (schema: docs/output.md)"
