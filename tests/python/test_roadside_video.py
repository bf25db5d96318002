# SPDX-License-Identifier: BSD-3-Clause
"""`roadpreview roadside detect` and `roadside run --video`: the built-in HOG people detector on a video of a
simulated crossing (silhouettes drawn where the simulated camera sees the pedestrian's feet), its boxes' ground
points, and the tracks it joins; bad input."""

import csv
import json

import numpy as np
import pytest

import roadpreview as rp
from roadpreview.sim import roadside as sr
from paths import run_cli

cv2 = pytest.importorskip("cv2")

FPS = 10.0
MIN_HEIGHT_PX = 130  # HOG's 64 × 128 window holds a person 96 px tall: smaller ones are drawn this tall


def draw_person(image, x, foot_y, height):
    """A dark walking silhouette (head, torso, legs, arms) standing on (x, foot_y), `height` px tall."""
    s = height / 180.0

    def at(dx, dy):
        return int(round(x + dx * s)), int(round(foot_y - dy * s))

    colour = (60, 40, 40)
    cv2.ellipse(image, at(0, 165), (int(11 * s), int(14 * s)), 0, 0, 360, colour, -1)
    cv2.ellipse(image, at(0, 115), (int(20 * s), int(36 * s)), 0, 0, 360, colour, -1)
    for (x0, y0), (x1, y1), w in (((-8, 85), (-14, 2), 11), ((8, 85), (15, 2), 11), ((-18, 140), (-26, 80), 8),
                                  ((18, 140), (26, 80), 8)):
        cv2.line(image, at(x0, y0), at(x1, y1), colour, max(1, int(w * s)))


@pytest.fixture(scope="module")
def crossing(tmp_path_factory):
    """The simulated pedestrian crossing: site, scans, and a 720 × 480 video from the first camera detection of the
    pedestrian on, one frame per 0.1 s, a silhouette on each detection's foot point while one fits the picture."""
    d = tmp_path_factory.mktemp("roadside_video")
    run = sr.simulate("pedestrian_crossing", seed=4)
    (d / "site.yaml").write_text(run.site_yaml)
    rp.roadside.write_scan_csv(run.scans, d / "scans.csv")
    people = [det for det in run.detections if det[5] == "pedestrian"]
    t0 = people[0][0]
    feet = {}  # frame → (x, y, height) of the simulated camera's box: where the pedestrian stands
    for t, x, y, w, h, _, _ in people:
        feet[int(round((t - t0) * FPS))] = (x + w / 2, y + h, h)
    frames = max(k for k, (_, y, _) in feet.items() if y >= MIN_HEIGHT_PX + 10) + 1
    rng = np.random.default_rng(0)
    writer = cv2.VideoWriter(str(d / "camera.avi"), cv2.VideoWriter_fourcc(*"MJPG"), FPS, (720, 480))
    assert writer.isOpened()
    shown = {}
    for k in range(frames):
        image = np.clip(170 + rng.normal(0, 6, (480, 720, 3)), 0, 255).astype(np.uint8)
        if k in feet:
            x, y, h = feet[k]
            if 40 <= x <= 680 and MIN_HEIGHT_PX + 10 <= y <= 470:  # wholly in the picture
                draw_person(image, x, y, max(h, MIN_HEIGHT_PX))
                shown[k] = (x, y, max(h, MIN_HEIGHT_PX))
        writer.write(image)
    writer.release()
    return d, run, t0, shown


def read_csv(path):
    with open(path) as f:
        return [dict(row) for row in csv.DictReader(f)]


@pytest.fixture(scope="module")
def detected(crossing):
    """`roadside detect` on the crossing's video: its stderr and the CSV's rows."""
    d, _, t0, _ = crossing
    proc = run_cli("roadside", "detect", d / "camera.avi", "-o", d / "det.csv", "--video-start", t0)
    return proc.stderr, read_csv(d / "det.csv")


def test_detect_finds_each_drawn_person_at_its_feet(crossing, detected):
    _, _, t0, shown = crossing
    stderr, rows = detected
    assert "720x480 px" in stderr and "pedestrian" in stderr
    assert {r["class"] for r in rows} == {"pedestrian"}
    by_frame = {}
    for r in rows:
        k = int(round((float(r["t"]) - t0) * FPS))
        assert float(r["t"]) == pytest.approx(t0 + k / FPS, abs=1e-6)  # frame times from the container
        assert 0.0 < float(r["score"]) < 1.0
        foot = (float(r["x"]) + float(r["w"]) / 2, float(r["y"]) + float(r["h"]))
        by_frame.setdefault(k, []).append(foot)
    # Within HOG's quantisation (8 px stride, 1.05 scale steps) of the feet: the trimmed box ends where they stand.
    found = 0
    for k, (x, y, height) in shown.items():
        near = [f for f in by_frame.get(k, []) if abs(f[0] - x) < 8 and abs(f[1] - y) < 0.1 * height]
        found += bool(near)
    assert len(shown) > 20 and found >= 0.9 * len(shown), f"{found} of {len(shown)} drawn people found"
    blank = set(by_frame) - set(shown)
    assert len(blank) <= 0.05 * len(by_frame), f"detections in {len(blank)} frames without a person"


def test_run_with_video_tracks_the_pedestrian_seen_by_both(crossing):
    d, _, t0, _ = crossing
    common = ("--video-start", t0)
    out = d / "video.jsonl"
    run_cli("roadside", "run", "--site", d / "site.yaml", d / "scans.csv", "--video", d / "camera.avi", "-o", out,
            "-q", *common)
    lines = [json.loads(line) for line in out.read_text().splitlines()]
    tracked = [o for c in lines for o in c["objects"] if o["id"] > 0]
    both = [o for o in tracked if o["source"] == "both"]
    assert both and {o["class"] for o in both} == {"pedestrian"}
    assert len(both) > 0.3 * len(tracked)
    # The same as detecting first and running on the detections.
    run_cli("roadside", "detect", d / "camera.avi", "-o", d / "det2.csv", "-q", *common)
    out2 = d / "detections.jsonl"
    run_cli("roadside", "run", "--site", d / "site.yaml", d / "scans.csv", "--detections", d / "det2.csv", "-o",
            out2, "-q")
    strip = lambda text: [{k: v for k, v in json.loads(line).items() if k != "process_ms"}
                          for line in text.splitlines()]
    assert strip(out.read_text()) == strip(out2.read_text())


def test_python_detect_video_gives_the_clis_detections(crossing, detected):
    d, run, t0, _ = crossing
    found = rp.roadside.detect_video(d / "camera.avi", start_s=t0, expect_size=(720, 480))
    assert found == [(float(r["t"]), float(r["x"]), float(r["y"]), float(r["w"]), float(r["h"]), r["class"],
                      float(r["score"])) for r in detected[1]]
    cycles = rp.roadside.Processor(run.site_yaml).run(run.scans, found)
    assert any(o["source"] == "both" for c in cycles for o in c["objects"])
    with pytest.raises(RuntimeError, match="640x480"):
        rp.roadside.detect_video(d / "camera.avi", expect_size=(640, 480))


def test_video_bad_input_is_named(crossing, tmp_path):
    d, _, _, _ = crossing
    site, scans = d / "site.yaml", d / "scans.csv"
    (tmp_path / "not_a_video.avi").write_bytes(b"RIFF" + b"\0" * 100)
    proc = run_cli("roadside", "detect", tmp_path / "not_a_video.avi", "-o", tmp_path / "x.csv", check=False)
    assert proc.returncode != 0 and "not_a_video.avi" in proc.stderr and "cannot read the video" in proc.stderr
    proc = run_cli("roadside", "detect", tmp_path / "missing.mp4", "-o", tmp_path / "x.csv", check=False)
    assert proc.returncode != 0 and "missing.mp4" in proc.stderr
    proc = run_cli("roadside", "detect", d / "camera.avi", "-o", tmp_path / "x.csv", "--cascade",
                   f"car={tmp_path / 'cars.xml'}", check=False)
    assert proc.returncode != 0 and "cars.xml" in proc.stderr
    proc = run_cli("roadside", "detect", d / "camera.avi", "-o", tmp_path / "x.csv", "--cascade", "cars.xml",
                   check=False)
    assert proc.returncode != 0 and "CLASS=FILE" in proc.stderr
    proc = run_cli("roadside", "detect", d / "camera.avi", "-o", tmp_path / "x.csv", "--no-people", check=False)
    assert proc.returncode != 0 and "nothing to detect" in proc.stderr
    # Frames of another size than the site's camera.
    small = tmp_path / "small.avi"
    writer = cv2.VideoWriter(str(small), cv2.VideoWriter_fourcc(*"MJPG"), FPS, (640, 480))
    for _ in range(3):
        writer.write(np.full((480, 640, 3), 128, np.uint8))
    writer.release()
    proc = run_cli("roadside", "run", "--site", site, scans, "--video", small, "-q", "-o", tmp_path / "o.jsonl",
                   check=False)
    assert proc.returncode != 0 and "640x480" in proc.stderr and "720x480" in proc.stderr
    # A site without a camera.
    no_camera = tmp_path / "no_camera.yaml"
    text = site.read_text()
    no_camera.write_text(text[:text.index("camera:")])
    proc = run_cli("roadside", "run", "--site", no_camera, scans, "--video", d / "camera.avi", "-q", check=False)
    assert proc.returncode != 0 and "camera" in proc.stderr and "no_camera.yaml" in proc.stderr
