# SPDX-License-Identifier: BSD-3-Clause
"""Segments on the map: poses + a WGS84 origin, or a GNSS CSV, give each segment lat/lon; GeoParquet, GeoJSON and a
PNG map; GNSS files that do not cover the drive or are malformed are refused naming the file."""

import json
import shutil

import numpy as np
import pytest

pytest.importorskip("geopandas")
pytest.importorskip("pyproj")

from pyproj import Geod  # noqa: E402

from roadpreview import batch, geo  # noqa: E402
from paths import KITTI_FRAMES, KITTI_SENSOR_HEIGHT, OS1_128_HEIGHT, OS1_128_PCAP, OUSTER  # noqa: E402

ORIGIN = (48.137, 11.575)  # deg


def test_metres_east_and_north_of_the_origin_land_where_the_ellipsoid_says():
    lat, lon = geo.locate_from_origin([0.0, 1000.0, 0.0], [1000.0, 0.0, 0.0], ORIGIN)
    geod = Geod(ellps="WGS84")
    north = geod.fwd(ORIGIN[1], ORIGIN[0], 0.0, 1000.0)  # lon, lat, back azimuth
    east = geod.fwd(ORIGIN[1], ORIGIN[0], 90.0, 1000.0)
    assert (lat[0], lon[0]) == pytest.approx((north[1], north[0]), abs=1e-9)
    assert (lat[1], lon[1]) == pytest.approx((east[1], east[0]), abs=1e-6)
    assert (lat[2], lon[2]) == pytest.approx(ORIGIN, abs=1e-12)
    with pytest.raises(ValueError, match="--origin 95.0,11.0: latitude must lie in"):
        geo.locate_from_origin([0.0], [0.0], (95.0, 11.0))


def gnss_file(path, t, lat, lon):
    path.write_text("t,lat,lon,alt\n" + "".join(f"{a},{b},{c},500\n" for a, b, c in zip(t, lat, lon)))
    return path


def test_gnss_files_are_checked_naming_the_file_and_line(tmp_path):
    bad = tmp_path / "bad.csv"
    bad.write_text("time,lat,lon\n0,1,2\n1,1,2\n")
    with pytest.raises(RuntimeError, match="bad.csv: a GNSS file needs the header t,lat,lon"):
        geo.read_gnss(bad)
    bad.write_text("t,lat,lon\n0,48,11\n1,nan,11\n")
    with pytest.raises(RuntimeError, match="bad.csv:3: lat is not a finite number"):
        geo.read_gnss(bad)
    bad.write_text("t,lat,lon\n0,48,11\n1,48,200\n")
    with pytest.raises(RuntimeError, match="bad.csv: latitudes must lie"):
        geo.read_gnss(bad)
    track = geo.read_gnss(gnss_file(tmp_path / "g.csv", [10, 20], [48.0, 48.001], [11.0, 11.0]))
    with pytest.raises(RuntimeError, match=r"g.csv: the drive \(5.000 … 12.000 s\) lies outside the GNSS file's "
                                           r"time span \(10.000 … 20.000 s\)"):
        geo.locate_from_gnss([0.0], [0.0, 1.0], [5.0, 12.0], track, "g.csv")
    lat, lon = geo.locate_from_gnss([0.0, 5.0, 10.0], [0.0, 10.0], [10.0, 20.0], track, "g.csv")
    np.testing.assert_allclose(lat, [48.0, 48.0005, 48.001])


def run_one(out, inputs, rid, **run_options):
    """One recording through the batch's own tasks, in this process (no cluster needed)."""
    (rec,) = batch.plan(inputs, 0, 0, {})
    geo_options = run_options.pop("geo_options")
    batch.process_chunk(rid, rec.inputs, rec.chunks[0], run_options, str(out))
    batch.finish_recording(rid, str(out), run_options.get("config"), (10.0,), geo_options)
    batch.write_tables(out)


def test_a_gnss_track_puts_the_batch_segments_on_the_map(tmp_path):
    folder = tmp_path / "kitti"
    folder.mkdir()
    for f in [p for p in KITTI_FRAMES if p.name.startswith("0000")]:
        shutil.copy(f, folder / f.name)
    # 3 frames at 1 Hz from t = 0, 5 m apart: a GNSS track heading north at 5 m/s from t = -1 s to 10 s
    t = np.arange(-1.0, 10.5, 0.5)
    north_m = 5.0 * (t + 1.0)
    lat = ORIGIN[0] + north_m / 111_250.0
    gnss = gnss_file(tmp_path / "gnss.csv", t, lat, np.full_like(t, ORIGIN[1]))
    out = tmp_path / "out"
    run_one(out, [str(folder)], "kitti", config={"sensor_height": KITTI_SENSOR_HEIGHT}, motion=(5.0, None),
            frame_rate=1.0, geo_options={"gnss": str(gnss)})
    import geopandas as gpd

    segs = gpd.read_parquet(out / "segments.geoparquet")
    assert len(segs) > 0 and segs.crs.to_epsg() == 4326
    # the vehicle is at distance d at t = d / 5 s; road seen ahead of the last frame (t = 2 s, 10 m) was never
    # reached: not placed (it once took the last frame's place, every such segment on one point)
    assert list(segs["start_m"][:2]) == [0.0, 10.0]
    np.testing.assert_allclose(segs["lat_start"], np.interp(segs["start_m"] / 5.0, t, lat), atol=1e-9)
    assert list(segs["end_m"]) == [10.0, 20.0] and np.isnan(segs["lat_end"].iloc[1])  # 20 m: never reached
    assert segs.geometry.notna().sum() == 1  # 0–10 m: the drive's one whole segment
    assert segs["lat_start"].iloc[1] - segs["lat_start"].iloc[0] == pytest.approx(10.0 / 111_250.0, rel=1e-6)
    features = json.loads((out / "segments.geojson").read_text())["features"]
    assert len(features) == len(segs) and features[0]["geometry"]["type"] == "LineString"
    assert (out / "map.png").stat().st_size > 5000
    late = gnss_file(tmp_path / "late.csv", [5.0, 6.0], [48.0, 48.1], [11.0, 11.0])
    with pytest.raises(RuntimeError, match="late.csv: the drive .* lies outside the GNSS file's time span"):
        run_one(tmp_path / "out2", [str(folder)], "kitti", config={"sensor_height": KITTI_SENSOR_HEIGHT},
                motion=(5.0, None), frame_rate=1.0, geo_options={"gnss": str(late)})


def test_poses_and_an_origin_put_the_segments_on_the_map(tmp_path):
    out = tmp_path / "out"
    run_one(out, [str(OS1_128_PCAP)], "os1", config={"sensor_height": OS1_128_HEIGHT}, motion=(2.5, None),
            poses=str(OUSTER / "OS-1-128_v2.3.0_1024x10_lb_n3_poses_kitti.txt"), geo_options={"origin": ORIGIN})
    import geopandas as gpd

    segs = gpd.read_parquet(out / "segments.geoparquet")
    assert len(segs) >= 1
    assert segs["lat_start"].iloc[0] == pytest.approx(ORIGIN[0], abs=1e-7)  # the drive starts at the origin
    assert segs["lat_end"].isna().all()  # every segment ends ahead of the drive's 0.5 m: never reached, not placed
    assert segs.geometry.isna().all()
    with pytest.raises(ValueError, match="--origin places poses on the map: the segments have no poses"):
        run_one(tmp_path / "out2", [str(OS1_128_PCAP)], "os1", config={"sensor_height": OS1_128_HEIGHT},
                motion=(2.5, None), geo_options={"origin": ORIGIN})


def test_lidar_odometry_places_a_pcap_without_poses_on_the_map(tmp_path):
    pytest.importorskip("kiss_icp")
    out = tmp_path / "out"
    run_one(out, [str(OS1_128_PCAP)], "os1", config={"sensor_height": OS1_128_HEIGHT}, motion_from="lidar",
            geo_options={"origin": ORIGIN})
    frames = batch.read_frames(out, "os1").to_pylist()
    assert [round(f["pose_x_m"], 1) for f in frames] == [0.0, 0.2, 0.5]  # KISS-ICP: ≈ 0.25 m per frame
    assert all(2.3 < f["speed_mps"] < 2.7 for f in frames)
    assert len(np.loadtxt(out / "recordings" / "os1" / "odometry.poses.txt", ndmin=2)) == 3
    import geopandas as gpd

    segs = gpd.read_parquet(out / "segments.geoparquet")
    driven = segs["start_m"] <= 0.5  # the drive's 0.5 m: what lies further ahead was never reached, not placed
    assert segs["lat_start"][driven].notna().all() and segs["lat_start"][~driven].isna().all()
    assert segs["lat_end"].isna().all()
