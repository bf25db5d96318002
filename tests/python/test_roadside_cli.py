# SPDX-License-Identifier: BSD-3-Clause
"""`roadpreview roadside run|info|extrinsics`: a simulated run through the CLI equals the Python processor, real
SICK files, and clear errors for bad input."""

import json

import pytest

import roadpreview as rp
from roadpreview.sim import roadside as sr
from paths import SHARED_DATA, VELODYNE, run_cli

SICK = SHARED_DATA / "laserscan2d" / "sick_scan_xd"


@pytest.fixture(scope="module")
def sim_files(tmp_path_factory):
    d = tmp_path_factory.mktemp("roadside")
    run = sr.simulate("pedestrian_crossing", seed=4)
    (d / "site.yaml").write_text(run.site_yaml)
    rp.roadside.write_scan_csv(run.scans, d / "scans.csv")
    with open(d / "det.csv", "w") as f:
        f.write("t,x,y,w,h,class,score\n")
        for t, x, y, w, h, c, s in run.detections:
            f.write(f"{t},{x},{y},{w},{h},{c},{s}\n")
    return d, run


def test_run_writes_one_line_per_cycle_with_wgs84_and_geojson(sim_files):
    d, run = sim_files
    out, geo = d / "out.jsonl", d / "out.geojson"
    proc = run_cli("roadside", "run", "--site", d / "site.yaml", d / "scans.csv", "--detections", d / "det.csv",
                   "-o", out, "--geojson", geo)
    lines = [json.loads(line) for line in out.read_text().splitlines()]
    assert len(lines) > 300
    assert "cycles" in proc.stderr and "cycle processing" in proc.stderr
    tracked = [o for c in lines for o in c["objects"] if o["id"] > 0]
    assert tracked and {o["class"] for o in tracked} == {"pedestrian"}
    assert {o["source"] for o in tracked} >= {"both"}  # the camera saw it too
    o = tracked[-1]
    lat, lon = rp.roadside.site_to_wgs84(run.site_yaml, o["x_m"], o["y_m"])  # x_m, y_m are rounded to 1 mm
    assert (o["lat_deg"], o["lon_deg"]) == pytest.approx((lat, lon), abs=2e-8)
    assert len(o["mbr_wgs84_deg"]) == 4 and len(o["mbr_site_m"]) == 4
    features = json.loads(geo.read_text())["features"]
    assert {f["geometry"]["type"] for f in features} == {"Point", "Polygon"}
    # The CLI and the Python processor give the same lines (the CSV rounds ranges to 0.1 mm).
    py = rp.roadside.Processor(d / "site.yaml").run(rp.roadside.read_scans(d / "scans.csv"), run.detections)
    def without_timing(c):  # process_ms: the cycle's CPU time, the only field that differs
        return {k: v for k, v in c.items() if k != "process_ms"}

    assert len(py) == len(lines)
    assert all("process_ms" in c for c in lines)
    assert [without_timing(c) for c in py] == [without_timing(c) for c in lines]


def test_bad_inputs_are_clear_errors(sim_files, tmp_path):
    d, _ = sim_files
    bad_site = tmp_path / "bad.yaml"
    bad_site.write_text(d.joinpath("site.yaml").read_text().replace("beams: 361", "beams: 360", 1))
    proc = run_cli("roadside", "run", "--site", bad_site, d / "scans.csv", check=False)
    assert proc.returncode == 1 and "360" in proc.stderr and "scans.csv" in proc.stderr
    proc = run_cli("roadside", "run", "--site", tmp_path / "missing.yaml", d / "scans.csv", check=False)
    assert proc.returncode == 1 and "missing.yaml" in proc.stderr
    (tmp_path / "x.txt").write_text("hello")
    proc = run_cli("roadside", "info", tmp_path / "x.txt", check=False)
    assert proc.returncode == 1 and "unknown scan format" in proc.stderr
    proc = run_cli("roadside", "run", "--site", d / "site.yaml", check=False)
    assert proc.returncode == 2  # usage: SCANS missing
    # Before any is read: a third scan file for a two-scanner site, a scanner the site does not name.
    three = [tmp_path / f"s{k}.json" for k in range(3)]
    proc = run_cli("roadside", "run", "--site", d / "site.yaml", *three, check=False)
    assert proc.returncode == 2, proc.stderr
    assert f"{three[2]}: the site file {d / 'site.yaml'} has 2 scanner(s), and this is scan file 3" in proc.stderr
    proc = run_cli("roadside", "run", "--site", d / "site.yaml", f"s9={three[0]}", check=False)
    assert proc.returncode == 2 and f"s9={three[0]}: no scanner named 's9'" in proc.stderr
    # A LiDAR capture is not a SICK one: the error names it and what was looked for.
    velodyne = VELODYNE / "velodyne_example.pcap"
    proc = run_cli("roadside", "run", "--site", d / "site.yaml", velodyne, check=False)
    assert proc.returncode == 1
    assert f"no scans in the inputs: {velodyne}: no SICK telegram in a TCP stream on port 2112" in proc.stderr
    huge = tmp_path / "det.jsonl"  # a number beyond a double: nlohmann's out_of_range once escaped without the file
    huge.write_text('{"t": 1e400, "x": 1, "y": 2, "w": 3, "h": 4, "class": "car"}\n')
    proc = run_cli("roadside", "run", "--site", d / "site.yaml", d / "scans.csv", "--detections", huge, check=False)
    assert proc.returncode == 1 and "det.jsonl:1: not JSON" in proc.stderr, proc.stderr


@pytest.mark.skipif(not (SICK / "20210302_lms111.pcapng.json").exists(), reason="shared data absent")
def test_info_on_real_sick_files():
    proc = run_cli("roadside", "info", SICK / "20210302_lms111.pcapng.json", SICK / "test.pcapng")
    assert "172 scans, 102 other, 0 bad, 3 repeating the scan before (dropped)" in proc.stderr
    assert "172 scans" in proc.stdout and "beams 541" in proc.stdout and "-135.0000° to 135.0000°" in proc.stdout
    assert "16 scans" in proc.stdout and "scan counter 44981 to 44996" in proc.stdout
