# SPDX-License-Identifier: BSD-3-Clause
"""`roadpreview roadside run|info|extrinsics`: a simulated run through the CLI equals the Python processor, real
SICK files, and clear errors for bad input."""

import json

import numpy as np
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


def test_python_orders_scans_by_the_site_file_s_clock_offsets_as_the_cli_does(tmp_path):
    """Scanner s2's clock runs 0.1 s ahead and the site file says so: the Python processor once sorted the scans on
    their own clocks (7 track ids for two cars, 263 cycles), the CLI on the site clock (2 ids, 394 cycles)."""
    run = sr.simulate("two_cars_crossing", seed=2, clock_offsets_s=(0.0, 0.1))
    (tmp_path / "site.yaml").write_text(sr.site_yaml(run.scanners, [0.0, -0.1]))
    rp.roadside.write_scan_csv(run.scans, tmp_path / "scans.csv")
    cli = [json.loads(line) for line in run_cli("roadside", "run", "--site", tmp_path / "site.yaml",
                                                 tmp_path / "scans.csv", "-q").stdout.splitlines()]
    py = rp.roadside.Processor(tmp_path / "site.yaml").run(rp.roadside.read_scans(tmp_path / "scans.csv"))
    without_timing = [{k: v for k, v in c.items() if k != "process_ms"} for c in py]
    assert without_timing == [{k: v for k, v in c.items() if k != "process_ms"} for c in cli]
    assert len({o["id"] for c in cli for o in c["objects"] if o["id"] > 0}) == 2


def test_detections_on_another_clock_are_said_to_be_in_no_output(sim_files, tmp_path):
    """Detections 1.6e9 s off the scans' clock (a SICK capture's epoch times beside a video's) once vanished unsaid."""
    d, run = sim_files
    shifted = tmp_path / "det.csv"
    shifted.write_text("t,x,y,w,h,class,score\n" + "".join(f"{t + 1.6e9},{x},{y},{w},{h},{c},{s}\n"
                                                         for t, x, y, w, h, c, s in run.detections))
    proc = run_cli("roadside", "run", "--site", d / "site.yaml", d / "scans.csv", "--detections", shifted, "-q")
    assert f"{len(run.detections)} of {len(run.detections)} camera detections lie more than 1 s outside" in proc.stderr
    assert "time_offset_s" in proc.stderr
    processor = rp.roadside.Processor(d / "site.yaml")
    with pytest.warns(RuntimeWarning, match=f"{len(run.detections)} camera detections lie more than 1 s outside"):
        processor.run(rp.roadside.read_scans(d / "scans.csv"), [(t + 1.6e9, *rest) for t, *rest in run.detections])
    assert processor.detections_outside_scans == len(run.detections)
    proc = run_cli("roadside", "run", "--site", d / "site.yaml", d / "scans.csv", "--detections", d / "det.csv", "-q")
    assert "camera detections lie" not in proc.stderr  # the simulated camera's detections fall in the scans' time
    # A site scanner without scans is said to be, by the CLI and the Python processor alike.
    alone = [s for s in rp.roadside.read_scans(d / "scans.csv") if s["scanner"] == 0]
    rp.roadside.write_scan_csv(alone, tmp_path / "s1.csv")
    proc = run_cli("roadside", "run", "--site", d / "site.yaml", tmp_path / "s1.csv", "-q")
    assert "warning: site scanner 's2' has no scans in the inputs" in proc.stderr
    with pytest.warns(RuntimeWarning, match="site scanner 's2' has no scans in the inputs"):
        rp.roadside.Processor(d / "site.yaml").run(alone)


@pytest.mark.parametrize("score", ["0", "-1", "1.5", "1e308"])
def test_a_detection_score_outside_0_to_1_is_refused(sim_files, tmp_path, score):
    """A score votes for its class: 0 voted nothing (a matched box left its track unclassed), 1e308 summed to an
    infinite vote (a null score in the output), −1 was echoed back."""
    d, _ = sim_files
    det = tmp_path / "det.csv"
    det.write_text(f"t,x,y,w,h,class,score\n1.0,100,200,30,60,pedestrian,{score}\n")
    proc = run_cli("roadside", "run", "--site", d / "site.yaml", d / "scans.csv", "--detections", det, check=False)
    assert proc.returncode == 1 and f"det.csv:2: detection score must be in (0, 1], got {float(score):g}" in proc.stderr
    with pytest.raises(RuntimeError, match=r"camera detection 0 \(of 1\): detection score must be in \(0, 1\]"):
        rp.roadside.Processor(d / "site.yaml").add_detections([(1.0, 100, 200, 30, 60, "pedestrian", float(score))])


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
    no_scanner_left = f"the site file {d / 'site.yaml'} has 2 scanner(s), and no scanner is left for this scan file"
    assert f"{three[2]}: {no_scanner_left}" in proc.stderr
    # A file without a name takes the next scanner no file is named for: s2=a b c leaves none for c (b once became
    # s1 and c s2 again, beside a, silently).
    proc = run_cli("roadside", "run", "--site", d / "site.yaml", f"s2={three[0]}", three[1], three[2], check=False)
    assert proc.returncode == 2 and f"{three[2]}: {no_scanner_left}" in proc.stderr, proc.stderr
    proc = run_cli("roadside", "run", "--site", d / "site.yaml", f"s9={three[0]}", check=False)
    assert proc.returncode == 2 and f"s9={three[0]}: no scanner named 's9'" in proc.stderr
    # A LiDAR capture is not a SICK one: the error names it and what was looked for.
    velodyne = VELODYNE / "velodyne_example.pcap"
    proc = run_cli("roadside", "run", "--site", d / "site.yaml", velodyne, check=False)
    assert proc.returncode == 1
    assert f"no scans in the inputs: {velodyne}: no SICK telegram in a TCP stream on port 2112" in proc.stderr
    # Scans that end within the background learning: an error, and no empty output files left behind.
    short, out, geo = tmp_path / "short.csv", tmp_path / "out.jsonl", tmp_path / "out.geojson"
    rp.roadside.write_scan_csv(rp.roadside.read_scans(d / "scans.csv")[:10], short)
    proc = run_cli("roadside", "run", "--site", d / "site.yaml", short, "-o", out, "--geojson", geo, check=False)
    assert proc.returncode == 1 and "no cycle written" in proc.stderr
    assert not out.exists() and not geo.exists()
    # A scan restamped 0.5 s back is said to be (the run merges every file's scans by time, and took it elsewhere).
    restamped = rp.roadside.read_scans(d / "scans.csv")
    restamped[200]["time_s"] -= 0.5
    rp.roadside.write_scan_csv(restamped, tmp_path / "restamped.csv")
    proc = run_cli("roadside", "run", "--site", d / "site.yaml", tmp_path / "restamped.csv", "-q")
    assert "restamped.csv: 1 scans are timed before a scan they follow (by up to 0.47" in proc.stderr, proc.stderr
    assert "are timed before" not in run_cli("roadside", "run", "--site", d / "site.yaml", d / "scans.csv", "-q").stderr
    # ICP that finds no pairs prints no site entry to paste (it printed the guess, and a fitness of 1.8e308).
    scans = rp.roadside.read_scans(d / "scans.csv")
    fixed, moving = tmp_path / "fixed.csv", tmp_path / "moving.csv"
    rp.roadside.write_scan_csv([s for s in scans if s["scanner"] == 0], fixed)
    rp.roadside.write_scan_csv([dict(s, ranges_m=np.full(len(s["ranges_m"]), 79.0)) for s in scans
                                if s["scanner"] == 1], moving)
    proc = run_cli("roadside", "extrinsics", "--site", d / "site.yaml", fixed, moving, check=False)
    assert proc.returncode == 1 and proc.stdout == ""
    assert "s2 onto s1: ICP did not converge (no point pairs within --max-distance)" in proc.stderr, proc.stderr
    huge = tmp_path / "det.jsonl"  # a number beyond a double: nlohmann's out_of_range once escaped without the file
    huge.write_text('{"t": 1e400, "x": 1, "y": 2, "w": 3, "h": 4, "class": "car"}\n')
    proc = run_cli("roadside", "run", "--site", d / "site.yaml", d / "scans.csv", "--detections", huge, check=False)
    assert proc.returncode == 1 and "det.jsonl:1: not JSON" in proc.stderr, proc.stderr


def test_info_describes_each_scanner_of_a_file_and_fails_on_a_file_without_scans(sim_files, tmp_path):
    """A CSV of two scanners once read as one at the sum of their rates (75 Hz), with the first one's layout; a file
    without scans was "0 scans", exit 0."""
    d, _ = sim_files
    out = run_cli("roadside", "info", d / "scans.csv").stdout
    assert out.count(": 525 scans\n") == 2 and " scanner 1: 525 scans" in out and out.count("37.50 Hz") == 2
    empty = tmp_path / "empty.csv"
    empty.write_text("t,scanner,angle_deg,range_m\n")
    proc = run_cli("roadside", "info", empty, check=False)
    assert proc.returncode == 1 and "empty.csv: 0 scans" in proc.stdout and "empty.csv: no scans" in proc.stderr


@pytest.mark.skipif(not (SICK / "test.pcapng").exists(), reason="shared data absent")
def test_a_sick_capture_that_breaks_off_is_said_to(tmp_path):
    """A capture cut inside a record read as the telegrams before the cut, unsaid (exit 0)."""
    cut = tmp_path / "cut.pcapng"
    cut.write_bytes((SICK / "test.pcapng").read_bytes()[:-300])
    proc = run_cli("roadside", "info", cut, check=False)
    assert proc.returncode == 1 and "cut.pcapng: the capture breaks off after" in proc.stderr
    assert "--skip-bad reads the telegrams before it" in proc.stderr
    proc = run_cli("roadside", "info", "--skip-bad", cut)
    assert "note: " in proc.stderr and "truncated or corrupt" in proc.stderr and ": 15 scans" in proc.stdout
    with pytest.warns(RuntimeWarning, match="cut.pcapng: the capture breaks off after"):
        assert len(rp.roadside.read_scans(cut, skip_bad=True)) == 15


@pytest.mark.skipif(not (SICK / "20210302_lms111.pcapng.json").exists(), reason="shared data absent")
def test_info_on_real_sick_files():
    proc = run_cli("roadside", "info", SICK / "20210302_lms111.pcapng.json", SICK / "test.pcapng")
    assert "172 scans, 102 other, 0 bad, 3 repeating the scan before (dropped)" in proc.stderr
    assert "172 scans" in proc.stdout and "beams 541" in proc.stdout and "-135.0000° to 135.0000°" in proc.stdout
    assert "16 scans" in proc.stdout and "scan counter 44981 to 44996" in proc.stdout
