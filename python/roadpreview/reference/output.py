# SPDX-License-Identifier: BSD-3-Clause
"""The output line of a reference result, as docs/output.md defines it (the C++ core's ``Result.to_dict()``).

The reference does not time its stages (``timing_ms`` is null), has no temporal fusion (``fusion`` null) and is
not told where the yaw rate came from (``path`` is null unless the path is an arc).
"""

from __future__ import annotations

import math

import numpy as np

from .mounting import check_mounting


def _number(v):
    return None if v is None or not math.isfinite(float(v)) else float(v)


def _numbers(values) -> list:
    return [_number(v) for v in np.asarray(values, dtype=np.float64)]


def _rounded(v: float) -> float:
    """To 1 mm (1 mrad), halves away from zero as the C++ side rounds."""
    return math.copysign(math.floor(abs(v) * 1e3 + 0.5), v) / 1e3


def _rounded3(row) -> list:
    return [_rounded(float(v)) for v in row]


def _iri(i) -> dict:
    return {"value": _number(i.value), "length": float(i.length), "reason": i.reason,
            "backed_fraction": _number(i.backed_fraction), "noise": _number(i.noise)}


def _roughness(r) -> dict:
    fitted = r.iso_class is not None
    return {
        "class": r.iso_class,
        "gd_n0": _number(r.gd_n0) if fitted else None,
        "gd_n0_free": _number(r.gd_n0_free) if fitted else None,
        "waviness": _number(r.waviness) if fitted else None,
        "band": [float(r.band[0]), float(r.band[1])] if fitted else None,
        "n": _numbers(r.n),
        "psd": _numbers(r.psd),
        "octave_bands": [{"center": float(c), "gd": _number(g)} for c, g in zip(r.octave_centers, r.octave_gd)],
        "reason": r.reason,
        "confidence": _number(r.confidence) if fitted else None,
        "band_limit": r.band_limit,
        "backed_fraction": _number(r.backed_fraction),
        "noise_floor": _number(r.noise_floor),
        "noise_psd": [] if r.noise_psd is None else _numbers(r.noise_psd),
        "iri": _iri(r.iri),
    }


def _path_obstacles(o):
    if o is None:
        return None
    return [{"id": int(i), "s_start": _rounded(a), "s_end": _rounded(b), "height": _rounded(h)}
            for i, a, b, h in zip(o.id, o.s_start, o.s_end, o.height)]


def _clusters(o):
    if o is None:
        return None
    return [{"id": int(o.id[k]), "count": int(o.count[k]), "centroid": _rounded3(o.centroid[k]),
             "aabb_min": _rounded3(o.aabb_min[k]), "aabb_max": _rounded3(o.aabb_max[k]),
             "obb": {"center": _rounded3(o.obb_center[k]), "size": _rounded3(o.obb_size[k]),
                     "yaw": _rounded(float(o.obb_yaw[k]))},
             "height": _rounded(float(o.height[k])), "bottom": _rounded(float(o.bottom[k]))}
            for k in range(len(o.id))]


def _profile(p, ds: float) -> dict:
    return {"s0": float(p.s[0]) if len(p.s) else ds / 2, "ds": ds, "s": _numbers(p.s), "z": _numbers(p.z),
            "count": [int(c) for c in p.count], "spread": _numbers(p.spread),
            "blocked": [bool(b) for b in p.blocked], "obstacles": _path_obstacles(p.obstacles)}


def _mounting(result) -> dict:
    cfg = result.config
    if cfg.extrinsics is not None:
        e = cfg.extrinsics
        extrinsics = [e.x_m, e.y_m, e.z_m, e.roll_rad, e.pitch_rad, e.yaw_rad]
    else:
        extrinsics = [0.0, 0.0, float(cfg.sensor_height or 0.0), 0.0, 0.0, 0.0]
    given = cfg.sensor_height is not None or cfg.extrinsics is not None
    check = {"ground_offset": None, "ground_tilt_deg": None, "disagrees": None}
    if result.plane is not None:
        check = check_mounting(result.plane)
    return {"extrinsics": [float(v) for v in extrinsics], "source": "given" if given else "none", **check}


def result_to_dict(result) -> dict:
    cfg = result.config
    path = result.path
    arc = path["status"] == "arc"
    return {
        "frame": 0,
        "source": "",
        "timestamp": None,
        "motion": {"speed": float(result.speed), "yaw_rate": float(result.yaw_rate), "status": path["status"]},
        "points": {k: int(result.points[k]) for k in ("input", "finite", "roi", "ground")},
        "ground": {"method": cfg.ground.method,
                   "plane": None if result.plane is None else [float(v) for v in result.plane]},
        "mounting": _mounting(result),
        "path": {k: path[k] for k in ("icr_y", "left_radius", "right_radius")} if arc else None,
        "obstacles": _clusters(result.obstacles),
        "profiles": {side: _profile(getattr(result, side), cfg.profile.ds_m) for side in ("left", "right")},
        "roughness": {"left": _roughness(result.left.roughness), "right": _roughness(result.right.roughness),
                      "vehicle": _roughness(result.vehicle)},
        "reason": result.reason,
        "fusion": None,
        "timing_ms": None,
    }
