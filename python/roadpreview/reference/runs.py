"""Runs of valid bins in a profile, shared by the profile, roughness and IRI stages."""

from __future__ import annotations

import numpy as np

NO_VALID_BIN = "no valid profile"


def true_runs(mask) -> list[tuple[int, int]]:
    """Half-open (start, stop) of every run of consecutive True values, in order."""
    padded = np.concatenate(([False], np.asarray(mask, dtype=bool), [False]))
    edges = np.flatnonzero(np.diff(padded.astype(np.int8)))
    return list(zip(edges[0::2].tolist(), edges[1::2].tolist()))


def longest_run(mask) -> tuple[int, int]:
    """(start, stop) of the longest run of True values, the first one on ties; (0, 0) when there is none."""
    runs = true_runs(mask)
    if not runs:
        return 0, 0
    lengths = [stop - start for start, stop in runs]
    return runs[int(np.argmax(lengths))]  # argmax picks the first on ties


def longest_valid_stretch(z) -> tuple[int, int]:
    """(start, stop) of the longest run of non-NaN bins, the first one on ties; (0, 0) when there is none."""
    return longest_run(~np.isnan(np.asarray(z, dtype=np.float64)))
