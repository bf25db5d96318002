#!/usr/bin/env bash
# Soak test of the live path (not part of test.sh): the bundled OS1-128 recording replayed in a loop over loopback
# into `roadpreview run udp://...` for MINUTES at RATE × its recorded speed; the run's resident memory (VmRSS) is
# sampled every SAMPLE_S seconds and printed as a table with the frames written so far, then the run's summary.
#   scripts/soak.sh [MINUTES] [RATE] [SAMPLE_S] [RUN OPTIONS...]   (default 60 minutes at 10×, a sample a minute;
#   options after the first three go to `run`, e.g. --busy-wait --roi-columns)
# Needs the roadpreview CLI (after ./scripts/test.sh or demo.sh: .venv/bin/roadpreview, else on PATH).
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
MINUTES="${1:-60}"
RATE="${2:-10}"
SAMPLE_S="${3:-60}"
shift $(( $# < 3 ? $# : 3 ))
CLI="$ROOT/.venv/bin/roadpreview"
[ -x "$CLI" ] || CLI="$(command -v roadpreview)"
PCAP="$ROOT/tests/data/ouster/OS-1-128_v2.3.0_1024x10_lb_n3.pcap"
META="$ROOT/tests/data/ouster/OS-1-128_v2.3.0_1024x10.json"
WORK="$ROOT/build/soak"
mkdir -p "$WORK"
PORT=$(python3 -c 'import socket; s=socket.socket(socket.AF_INET, socket.SOCK_DGRAM); s.bind(("127.0.0.1", 0)); print(s.getsockname()[1])')
DURATION_S=$((MINUTES * 60))
# The capture spans 0.3 s: enough loops to outlast the run (the replay is stopped when the run ends).
LOOPS=$(python3 -c "print(int($DURATION_S * $RATE / 0.3) + 10)")

"$CLI" run "udp://127.0.0.1:$PORT" --meta "$META" --speed 2.5 --sensor-height 1.97 --duration "$DURATION_S" \
    --timeout 10 -q -o "$WORK/out.jsonl" "$@" 2>"$WORK/run.log" &
RUN=$!
sleep 1
"$CLI" replay "$PCAP" --to "127.0.0.1:$PORT" --rate "$RATE" --loop "$LOOPS" -q 2>"$WORK/replay.log" &
REPLAY=$!
trap 'kill $RUN $REPLAY 2>/dev/null || true' EXIT

printf '| minute | RSS MB | frames written |\n|---|---|---|\n'
start=$SECONDS
while kill -0 "$RUN" 2>/dev/null; do
    sleep "$SAMPLE_S"
    rss_kb=$(awk '/VmRSS/ {print $2}' "/proc/$RUN/status" 2>/dev/null || echo "")
    [ -n "$rss_kb" ] || break
    # The last line's frame number (the output grows by gigabytes: counting its lines would delay the samples).
    last=$(tail -c 300000 "$WORK/out.jsonl" | grep -o '^{"frame":[0-9]*' | tail -1 | cut -d: -f2 || true)
    printf '| %s | %.1f | %s |\n' "$(python3 -c "print(round($((SECONDS - start)) / 60, 2))")" \
        "$(python3 -c "print($rss_kb / 1024)")" "$(( ${last:--1} + 1 ))"
done
wait "$RUN" || { echo "the live run failed:" >&2; tail -5 "$WORK/run.log" >&2; exit 1; }
kill "$REPLAY" 2>/dev/null || true
tail -2 "$WORK/run.log"
