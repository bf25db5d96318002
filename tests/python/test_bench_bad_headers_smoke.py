"""Smoke test of ``bench/bad_headers.py --quick``: every lying header fails, cheaply, with its file named."""

from paths import run_bench


def test_every_lying_header_fails_fast_and_small():
    out = run_bench("bad_headers.py", "--quick")
    rows = [line for line in out.splitlines() if line.startswith("| PCD") or line.startswith("| PLY")]
    assert len(rows) == 6
    for row in rows:
        cells = [c.strip() for c in row.strip("|").split("|")]
        assert cells[1] == "1", row  # exit status
        assert cells[6] == "yes", row  # rp.io.read: < 0.1 s, < 50 MB added
        assert "case" in cells[7], row  # the message names the file
