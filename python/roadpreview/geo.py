# SPDX-License-Identifier: BSD-3-Clause
"""Segments on the map: latitude and longitude for each segment's start and end, GeoParquet / GeoJSON, a PNG.

Two ways to place a drive on the earth:

* poses (``--poses``, ``--motion-from lidar``) and the WGS84 position of their origin (``--origin lat,lon[,alt]``):
  the poses' x and y are taken as metres east and north of the origin (a local tangent plane; pyproj's azimuthal
  equidistant projection about the origin turns them into lat/lon);
* a GNSS CSV (``t,lat,lon[,alt]``, s in the frames' clock, degrees, m): each segment end's distance along the
  drive gives a time (the frames' distance driven against their timestamps) and the fix is interpolated there.
  A drive that starts before or ends after the GNSS file's span is an error naming the file.

Road seen ahead of the drive's last frame (previewed but never reached) is not placed: its lat/lon are None and
its segment has no geometry on the map.
"""

from __future__ import annotations

import os
from typing import Optional, Sequence

import numpy as np

ISO_COLOURS = {"A": "#1a9850", "B": "#66bd63", "C": "#a6d96a", "D": "#fee08b", "E": "#fdae61", "F": "#f46d43",
               "G": "#d73027", "H": "#a50026"}
NO_CLASS_COLOUR = "#bdbdbd"


def read_gnss(path) -> dict:
    """Columns t, lat, lon (and alt when present) of a GNSS CSV, checked."""
    path = os.fspath(path)
    try:
        data = np.atleast_1d(np.genfromtxt(path, delimiter=",", names=True, dtype=float))
    except (OSError, ValueError) as err:
        raise RuntimeError(f"{path}: cannot read the GNSS file ({err})") from None
    names = data.dtype.names or ()
    if not {"t", "lat", "lon"} <= set(names):
        raise RuntimeError(f"{path}: a GNSS file needs the header t,lat,lon[,alt] (has {','.join(names)})")
    track = {k: np.asarray(data[k], dtype=float) for k in ("t", "lat", "lon", "alt") if k in names}
    if len(track["t"]) < 2:
        raise RuntimeError(f"{path}: a GNSS file needs at least two fixes")
    for k, v in track.items():
        bad = np.flatnonzero(~np.isfinite(v))
        if bad.size:
            raise RuntimeError(f"{path}:{bad[0] + 2}: {k} is not a finite number")
    if np.any(np.diff(track["t"]) <= 0):
        raise RuntimeError(f"{path}: the GNSS times must increase")
    if np.any(np.abs(track["lat"]) > 90) or np.any(np.abs(track["lon"]) > 180):
        raise RuntimeError(f"{path}: latitudes must lie in [-90, 90] and longitudes in [-180, 180] degrees")
    return track


def distance_by_frame(timestamps: Sequence, speeds: Sequence, frame_rate_hz: float = 10.0) -> np.ndarray:
    """Distance driven at each frame: |speed| × the time since the previous frame (as the route stitches)."""
    t = np.array([np.nan if v is None else v for v in timestamps], dtype=float)
    v = np.abs(np.array([0.0 if s is None else s for s in speeds], dtype=float))
    dt = np.where(np.isfinite(np.diff(t)), np.diff(t), 1.0 / frame_rate_hz) if len(t) > 1 else np.zeros(0)
    return np.concatenate(([0.0], np.cumsum(v[1:] * dt)))


def locate_from_origin(xs, ys, origin: Sequence[float]) -> tuple[np.ndarray, np.ndarray]:
    """lat, lon of points x m east and y m north of ``origin`` (lat, lon[, alt])."""
    from pyproj import Transformer

    lat0, lon0 = float(origin[0]), float(origin[1])
    if not (abs(lat0) <= 90 and abs(lon0) <= 180):
        raise ValueError(f"--origin {lat0},{lon0}: latitude must lie in [-90, 90], longitude in [-180, 180]")
    local = f"+proj=aeqd +lat_0={lat0} +lon_0={lon0} +datum=WGS84 +units=m"
    to_wgs84 = Transformer.from_crs(local, "EPSG:4326", always_xy=True)
    lon, lat = to_wgs84.transform(np.asarray(xs, dtype=float), np.asarray(ys, dtype=float))
    return np.asarray(lat), np.asarray(lon)


def locate_from_gnss(distances_m, frame_distance_m, frame_times_s, track: dict, source: str):
    """lat, lon at distances along the drive, through the frames' times and the GNSS fixes."""
    t_frames = np.asarray(frame_times_s, dtype=float)
    if not np.isfinite(t_frames).all():
        raise RuntimeError(f"{source}: the frames carry no timestamps to match with the GNSS times")
    t0, t1 = track["t"][0], track["t"][-1]
    if t_frames[0] < t0 - 1e-6 or t_frames[-1] > t1 + 1e-6:
        raise RuntimeError(f"{source}: the drive ({t_frames[0]:.3f} … {t_frames[-1]:.3f} s) lies outside the GNSS "
                           f"file's time span ({t0:.3f} … {t1:.3f} s)")
    t = np.interp(distances_m, frame_distance_m, t_frames)
    return np.interp(t, track["t"], track["lat"]), np.interp(t, track["t"], track["lon"])


def locate_segments(rows: list[dict], frames, origin: Optional[Sequence[float]] = None,
                    gnss: Optional[str] = None, frame_rate_hz: float = 10.0) -> list[dict]:
    """The segment rows (``batch.segment_rows``) with start/end lat and lon added; None for a start or end ahead of
    the drive's last frame (the road it previewed but never reached: docs/output.md)."""
    if not rows:
        return rows
    if origin is not None and all(r["x_start_m"] is None for r in rows):
        raise ValueError("--origin places poses on the map: the segments have no poses "
                         "(give --poses or --motion-from lidar, or a --gnss file)")
    for end in ("start", "end"):
        if origin is not None:
            driven = [r[f"x_{end}_m"] is not None for r in rows]
            xs = [r[f"x_{end}_m"] if ok else 0.0 for r, ok in zip(rows, driven)]
            ys = [r[f"y_{end}_m"] if ok else 0.0 for r, ok in zip(rows, driven)]
            lat, lon = locate_from_origin(xs, ys, origin)
        else:
            track = read_gnss(gnss)
            d = distance_by_frame(frames.column("timestamp").to_pylist(), frames.column("speed_mps").to_pylist(),
                                  frame_rate_hz)
            t = np.array([np.nan if v is None else v for v in frames.column("timestamp").to_pylist()], dtype=float)
            driven = [r[f"{end}_m"] <= d[-1] + 1e-9 for r in rows]
            lat, lon = locate_from_gnss([r[f"{end}_m"] for r in rows], d, t, track, os.fspath(gnss))
        for r, ok, a, b in zip(rows, driven, lat, lon):
            r[f"lat_{end}"], r[f"lon_{end}"] = (float(a), float(b)) if ok else (None, None)
    return rows


def to_geodataframe(segments):
    """A GeoDataFrame (EPSG:4326) of segment rows or a table with start/end lat/lon: one line per segment."""
    import geopandas as gpd
    import pandas as pd
    from shapely.geometry import LineString

    df = segments.to_pandas() if hasattr(segments, "to_pandas") else pd.DataFrame(segments)
    missing = [c for c in ("lat_start", "lon_start", "lat_end", "lon_end") if c not in df]
    if missing:
        raise ValueError(f"segments have no {', '.join(missing)}: give --origin with poses, or --gnss")
    lines = [LineString([(a, b), (c, d)]) if all(pd.notna([a, b, c, d])) else None  # ahead of the drive: none
             for a, b, c, d in zip(df["lon_start"], df["lat_start"], df["lon_end"], df["lat_end"])]
    return gpd.GeoDataFrame(df, geometry=lines, crs="EPSG:4326")


def write_map(gdf, png_path, length_m: Optional[float] = None, side: str = "vehicle") -> None:
    """PNG of the segments (the shortest length unless given) coloured by ISO 8608 class."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.lines import Line2D
    from matplotlib.ticker import MaxNLocator

    length = length_m if length_m is not None else float(gdf["segment_length_m"].min())
    shown = gdf[(gdf["segment_length_m"] == length) & gdf.geometry.notna()]  # the segments the drive reached
    colours = [ISO_COLOURS.get(c, NO_CLASS_COLOUR) if isinstance(c, str) else NO_CLASS_COLOUR
               for c in shown[f"class_{side}"]]
    fig, ax = plt.subplots(figsize=(7, 7))
    if len(shown):
        shown.plot(ax=ax, color=colours, linewidth=4, aspect=None)
        _square_view(ax, shown.total_bounds)
    else:  # a drive shorter than a segment: every segment ends on road it previewed but never reached
        ax.text(0.5, 0.5, f"no {length:g} m segment lies on the drive", ha="center", transform=ax.transAxes)
    present = sorted({c for c in shown[f"class_{side}"] if isinstance(c, str)})
    handles = [Line2D([], [], color=ISO_COLOURS[c], lw=4, label=f"class {c}") for c in present]
    handles.append(Line2D([], [], color=NO_CLASS_COLOUR, lw=4, label="no class"))
    ax.legend(handles=handles, loc="upper left", bbox_to_anchor=(1.01, 1.0))
    ax.set_xlabel("longitude (deg)")
    ax.set_ylabel("latitude (deg)")
    ax.set_title(f"ISO 8608 class ({side}), {length:g} m segments")
    ax.ticklabel_format(useOffset=False)
    ax.xaxis.set_major_locator(MaxNLocator(4))
    fig.tight_layout()
    fig.savefig(png_path, dpi=120)
    plt.close(fig)


def _square_view(ax, bounds, min_half_m: float = 30.0) -> None:
    """Equal metres on both axes around the segments, at least 2 × ``min_half_m`` across (a straight drive
    along a meridian has no width)."""
    import math

    lon0, lat0, lon1, lat1 = bounds
    m_per_deg_lat = 111_320.0
    m_per_deg_lon = m_per_deg_lat * math.cos(math.radians((lat0 + lat1) / 2))
    half_m = max(min_half_m, 0.55 * max((lon1 - lon0) * m_per_deg_lon, (lat1 - lat0) * m_per_deg_lat))
    cx, cy = (lon0 + lon1) / 2, (lat0 + lat1) / 2
    ax.set_xlim(cx - half_m / m_per_deg_lon, cx + half_m / m_per_deg_lon)
    ax.set_ylim(cy - half_m / m_per_deg_lat, cy + half_m / m_per_deg_lat)
    ax.set_aspect(m_per_deg_lat / m_per_deg_lon)


def write_geo(segments, out_dir) -> list[str]:
    """segments.geoparquet, segments.geojson and map.png in ``out_dir``; returns their paths."""
    gdf = to_geodataframe(segments)
    out = [os.path.join(out_dir, name) for name in ("segments.geoparquet", "segments.geojson", "map.png")]
    gdf.to_parquet(out[0])
    gdf.to_file(out[1], driver="GeoJSON")
    write_map(gdf, out[2])
    return out
