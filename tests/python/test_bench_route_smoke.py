# SPDX-License-Identifier: BSD-3-Clause
"""bench/route.py on short drives runs and prints its table."""

from paths import run_bench


def test_route_bench_short_drives():
    out = run_bench("route.py", "--frames", "25", "--classes", "C", timeout=600)
    header, rule, row, *spectra = out.strip().splitlines()
    assert spectra[0] == "" and spectra[1].startswith("What the stitched profile keeps of each wave")
    kept = [line.split("|") for line in spectra[5:]]  # n, wavelength, road C
    assert [float(r[1]) for r in kept] == [0.2, 0.3, 0.4, 0.5, 0.7, 1.0, 1.5, 2.0, 2.5, 3.0, 4.0]
    assert all(0.0 < float(r[3]) < 100.0 for r in kept)
    assert header.startswith("| road | segments to 60 m | classed | same class |") and row.startswith("| C | ")
    segments, classed, same, near = (int(v) for v in row.split("|")[2:6])
    assert segments >= 4 and 0 < classed <= segments and same <= near <= classed
    to_line, to_strip = (float(v.split()[0]) for v in row.split("|")[6:8])  # medians of the two truths' ratios
    assert 0.3 < to_line < to_strip < 3  # the strip keeps less of the road than the line: its ratio is the larger
