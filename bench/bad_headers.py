"""Cost of rejecting frame files whose headers lie: time and peak memory of ``roadpreview run`` on them.

Each case is a small file whose header declares far more data than it holds (a 200-byte PCD claiming 2·10⁸
points, as binary, ASCII and binary_compressed; a PLY claiming 2·10⁸ vertices), or a header with a value that
is no count. Every run must fail with a message naming the file. For each case the CLI runs ``--repeat``
times in a fresh process; the table gives the wall time (median, min–max, ms, process start included), the
peak resident memory of the CLI process (MB, max over the runs) and the first line of its error; then the
same file through ``rp.io.read`` in a fresh Python process: the time of the failing call (median) and the
peak resident memory it adds (max). The target from the issue: a 200-byte PCD claiming 2·10⁸ points fails in
< 0.1 s using < 50 MB. For scale, the table gives ``roadpreview --version`` (start-up alone).

Usage: ``python bench/bad_headers.py [--repeat N] [--quick]``
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

PCD = ("# .PCD v0.7\nVERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\nWIDTH {w}\nHEIGHT 1\n"
       "VIEWPOINT 0 0 0 1 0 0 0\nPOINTS {n}\nDATA {data}\n")
PLY = ("ply\nformat binary_little_endian 1.0\nelement vertex 200000000\nproperty float x\nproperty float y\n"
       "property float z\nend_header\n")
LZF_SIZES = (100).to_bytes(4, "little") + (2_400_000_000).to_bytes(4, "little")


def cases(folder: Path) -> list[tuple[str, Path]]:
    files = {
        "PCD binary, POINTS 2e8": PCD.format(w=200000000, n=200000000, data="binary").encode(),
        "PCD ascii, POINTS 2e8": PCD.format(w=200000000, n=200000000, data="ascii").encode() + b"1 2 3\n",
        "PCD binary_compressed, POINTS 2e8": PCD.format(w=200000000, n=200000000,
                                                       data="binary_compressed").encode() + LZF_SIZES,
        "PCD WIDTH -5": PCD.format(w=-5, n=5, data="binary").encode(),
        "PCD WIDTH 4e9": PCD.format(w="4e9", n=4000000000, data="binary").encode(),
        "PLY binary, 2e8 vertices": PLY.encode(),
    }
    out = []
    for i, (name, data) in enumerate(files.items()):
        path = folder / f"case{i}{'.ply' if name.startswith('PLY') else '.pcd'}"
        path.write_bytes(data.ljust(200, b"\0"))
        out.append((name, path))
    return out


def cli() -> str:
    beside = Path(sys.executable).parent / "roadpreview"
    return str(beside) if beside.exists() else "roadpreview"


def timed_run(args: list[str]) -> tuple[float, float, int, str]:
    """(wall ms, peak RSS MB, exit status, stderr) of one CLI run in a fresh measuring process."""
    code = ("import resource, subprocess, sys, time; t = time.perf_counter(); "
            "p = subprocess.run(sys.argv[1:], capture_output=True, text=True); dt = time.perf_counter() - t; "
            "print(dt * 1e3, resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss / 1024, p.returncode); "
            "print(p.stderr.strip().splitlines()[0] if p.stderr.strip() else '')")
    out = subprocess.run([sys.executable, "-c", code, *args], capture_output=True, text=True, timeout=120).stdout
    first, err = (out.splitlines() + [""])[:2]
    ms, mb, status = first.split()
    return float(ms), float(mb), int(status), err


def timed_read(path: Path) -> tuple[float, float]:
    """(ms, MB of peak resident memory added) of ``rp.io.read`` failing on `path`, in a fresh process."""
    code = ("import resource, sys, time; import roadpreview as rp; before = resource.getrusage(resource.RUSAGE_SELF)"
            ".ru_maxrss; t = time.perf_counter()\ntry:\n    rp.io.read(sys.argv[1])\nexcept RuntimeError:\n    pass\n"
            "dt = time.perf_counter() - t; after = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss; "
            "print(dt * 1e3, (after - before) / 1024)")
    out = subprocess.run([sys.executable, "-c", code, str(path)], capture_output=True, text=True, timeout=120)
    ms, mb = out.stdout.split()
    return float(ms), float(mb)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=10)
    parser.add_argument("--quick", action="store_true", help="1 run per case")
    args = parser.parse_args()
    repeat = 1 if args.quick else args.repeat
    load = os.getloadavg()[0]
    print(f"CLI {cli()}, {repeat} runs per case, 1-min load {load:.1f}\n")
    print("| file (200 bytes) | exit | CLI wall ms median (min–max) | CLI peak MB | rp.io.read ms median | "
          "rp.io.read added MB | read < 0.1 s and < 50 MB | message |")
    print("|---|---|---|---|---|---|---|---|")
    with tempfile.TemporaryDirectory() as tmp:
        rows = [("roadpreview --version (start-up)", ["--version"], None)]
        rows += [(name, ["run", str(path), "--speed", "5"], path) for name, path in cases(Path(tmp))]
        for name, cli_args, path in rows:
            print(f"{name} ...", file=sys.stderr)
            runs = [timed_run([cli(), *cli_args]) for _ in range(repeat)]
            ms = [r[0] for r in runs]
            peak = max(r[1] for r in runs)
            status, message = runs[0][2], runs[0][3].replace(tmp + "/", "")
            read = "– | – | –"
            if path is not None:
                reads = [timed_read(path) for _ in range(repeat)]
                read_ms, added = statistics.median(r[0] for r in reads), max(r[1] for r in reads)
                read = f"{read_ms:.3f} | {added:.1f} | {'yes' if read_ms < 100 and added < 50 else 'NO'}"
            print(f"| {name} | {status} | {statistics.median(ms):.0f} ({min(ms):.0f}–{max(ms):.0f}) | {peak:.1f} | "
                  f"{read} | {message.replace('|', '/')[:100]} |")


if __name__ == "__main__":
    main()
