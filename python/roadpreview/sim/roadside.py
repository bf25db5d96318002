# SPDX-License-Identifier: BSD-3-Clause
"""Roadside scenes: an intersection with walls and poles, road users on the method paper's five scenarios, two
LMS291-like 2-D scanners, a pole camera's detections and RTK-like truth (numpy only).

    from roadpreview.sim import roadside as sr
    run = sr.simulate("two_cars_crossing", seed=3, clock_offsets_s=(0.0, 0.1))
    run.scans            # list of dicts (time_s on each scanner's own clock, scanner, ranges_m, ...)
    run.site_yaml        # the site file (scanner poses, camera homography points, origin); offsets not in it
    run.detections       # (t, x, y, w, h, class, score) camera boxes, px
    run.truth            # per object: t, x_m, y_m, heading, class at 10 Hz (rtk_1hz(), rtk_10hz() in WGS84)

Site frame: origin at the intersection's centre, x east, y north, metres. Roads 7 m wide along both axes;
buildings' walls 8 m from each axis; poles at the corners. Scan plane ~0.5 m above the road: cars are
4.5 × 1.8 m rectangles, cyclists 1.75 × 0.5 m, pedestrians 0.45 m discs (legs and hips).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Optional, Sequence

import numpy as np

SCENARIOS = ("one_car", "two_cars_crossing", "two_cars_in_a_row", "pedestrian_crossing", "cyclist_crossing")
SIZES_M = {"car": (4.5, 1.8), "cyclist": (1.75, 0.5), "pedestrian": (0.45, 0.45)}
SCAN_HZ = 37.5
BEAMS = 361
ORIGIN = (49.01, 8.40, 115.0)  # lat, lon, height of the site origin (any place; the bench reports metres)


@dataclass
class Mover:
    """A road user on a straight line at constant speed, present between t0_s and t1_s."""
    cls: str
    x0_m: float
    y0_m: float
    heading_rad: float
    speed_mps: float
    t0_s: float
    t1_s: float
    id: int = 0

    def at(self, t: float) -> tuple[float, float]:
        d = self.speed_mps * (t - self.t0_s)
        return self.x0_m + d * math.cos(self.heading_rad), self.y0_m + d * math.sin(self.heading_rad)

    def present(self, t: float) -> bool:
        return self.t0_s <= t <= self.t1_s


@dataclass
class Scanner:
    x_m: float
    y_m: float
    yaw_rad: float
    phase_s: float = 0.0          # first scan time on the true clock
    clock_offset_s: float = 0.0   # its clock reads true time + offset
    noise_m: float = 0.01         # LMS291: ~1 cm range noise (σ)
    max_range_m: float = 80.0


@dataclass
class Run:
    scenario: str
    seed: int
    scans: list
    detections: list
    truth: list                 # dicts: id, cls, t, x_m, y_m, heading_rad (10 Hz)
    site_yaml: str
    scanners: list
    movers: list = field(default_factory=list)

    def truth_at(self, t: float) -> list[dict]:
        return [dict(id=m.id, cls=m.cls, x_m=m.at(t)[0], y_m=m.at(t)[1], heading_rad=m.heading_rad)
                for m in self.movers if m.present(t)]


def walls() -> np.ndarray:
    """Wall segments (x0, y0, x1, y1): four building corners, each 8 m off both road axes."""
    segs = []
    for sx in (-1, 1):
        for sy in (-1, 1):
            corner = (8.0 * sx, 8.0 * sy)
            segs.append((*corner, 45.0 * sx, 8.0 * sy))
            segs.append((*corner, 8.0 * sx, 45.0 * sy))
    return np.array(segs)


POLES = np.array([(5.5, 5.5), (-5.5, -5.5), (5.5, -5.5), (-5.5, 5.5), (20.0, -5.0)])
POLE_RADIUS_M = 0.12


def scanners() -> list[Scanner]:
    """Two scanners at opposite corners, looking into the intersection (180° each)."""
    return [Scanner(-6.5, -6.5, math.radians(45.0)), Scanner(6.5, 6.5, math.radians(-135.0), phase_s=0.011)]


def movers(scenario: str, rng: np.random.Generator) -> list[Mover]:
    v = lambda base, spread: base * (1.0 + spread * rng.uniform(-1, 1))  # noqa: E731
    if scenario == "one_car":
        return [Mover("car", -40.0, -1.75, 0.0, v(9.0, 0.15), 0.0, 9.0, 1)]
    if scenario == "two_cars_crossing":
        return [Mover("car", -40.0, -1.75, 0.0, v(9.0, 0.1), 0.0, 9.0, 1),
                Mover("car", 1.75, -40.0, math.pi / 2, v(9.0, 0.1), 1.5, 10.5, 2)]
    if scenario == "two_cars_in_a_row":
        s = v(8.0, 0.1)
        return [Mover("car", -35.0, -1.75, 0.0, s, 0.0, 9.0, 1), Mover("car", -50.0, -1.75, 0.0, s, 0.0, 10.5, 2)]
    if scenario == "pedestrian_crossing":
        return [Mover("pedestrian", -4.5, -9.0, math.pi / 2, v(1.4, 0.15), 0.0, 12.0, 1)]
    if scenario == "cyclist_crossing":
        return [Mover("cyclist", 4.5, -30.0, math.pi / 2, v(5.0, 0.15), 0.0, 11.0, 1)]
    raise ValueError(f"unknown scenario {scenario!r}; one of {', '.join(SCENARIOS)}")


def _footprint_segments(m: Mover, t: float) -> np.ndarray:
    length, width = SIZES_M[m.cls]
    x, y = m.at(t)
    if m.cls == "pedestrian":
        return np.empty((0, 4))
    c, s = math.cos(m.heading_rad), math.sin(m.heading_rad)
    corners = [(x + c * a - s * b, y + s * a + c * b)
               for a, b in ((length / 2, width / 2), (-length / 2, width / 2), (-length / 2, -width / 2),
                            (length / 2, -width / 2))]
    return np.array([(*corners[i], *corners[(i + 1) % 4]) for i in range(4)])


def _ray_segments(ox, oy, dx, dy, segs: np.ndarray) -> np.ndarray:
    """Distance along each ray (dx, dy unit arrays) to the nearest segment; inf where none."""
    if len(segs) == 0:
        return np.full(dx.shape, np.inf)
    ax, ay = segs[:, 0] - ox, segs[:, 1] - oy
    ex, ey = segs[:, 2] - segs[:, 0], segs[:, 3] - segs[:, 1]
    den = dx[:, None] * ey[None, :] - dy[:, None] * ex[None, :]
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):  # parallel: no hit, masked below
        t = (ax[None, :] * ey[None, :] - ay[None, :] * ex[None, :]) / den
        u = (ax[None, :] * dy[:, None] - ay[None, :] * dx[:, None]) / den
    hit = (np.abs(den) > 1e-12) & (t > 0) & (u >= 0) & (u <= 1)
    return np.where(hit, t, np.inf).min(axis=1)


def _ray_discs(ox, oy, dx, dy, centres: np.ndarray, radius: float) -> np.ndarray:
    if len(centres) == 0:
        return np.full(dx.shape, np.inf)
    cx, cy = centres[:, 0] - ox, centres[:, 1] - oy
    b = dx[:, None] * cx[None, :] + dy[:, None] * cy[None, :]
    c = (cx ** 2 + cy ** 2)[None, :] - radius ** 2
    disc = b * b - c
    t = b - np.sqrt(np.maximum(disc, 0.0))
    return np.where((disc >= 0) & (t > 0), t, np.inf).min(axis=1)


def scan(sc: Scanner, index: int, t: float, present: Sequence[Mover], rng: np.random.Generator) -> dict:
    """One 361-beam scan at true time t (beams −90°…+90° in 0.5° steps), objects occluding each other."""
    angles = np.radians(np.arange(BEAMS) * 0.5 - 90.0) + sc.yaw_rad
    dx, dy = np.cos(angles), np.sin(angles)
    segs = [walls()] + [_footprint_segments(m, t) for m in present]
    r = _ray_segments(sc.x_m, sc.y_m, dx, dy, np.vstack(segs))
    r = np.minimum(r, _ray_discs(sc.x_m, sc.y_m, dx, dy, POLES, POLE_RADIUS_M))
    peds = np.array([m.at(t) for m in present if m.cls == "pedestrian"]).reshape(-1, 2)
    r = np.minimum(r, _ray_discs(sc.x_m, sc.y_m, dx, dy, peds, SIZES_M["pedestrian"][0] / 2))
    r = r + rng.normal(0.0, sc.noise_m, r.shape)
    r = np.where(r < sc.max_range_m, r, np.nan).astype(np.float32)
    return dict(time_s=t + sc.clock_offset_s, scanner=None, counter=index, start_angle_rad=math.radians(-90.0),
                step_rad=math.radians(0.5), ranges_m=r)


# The pole camera: 3.5 m up at (0, −12), looking north and 25° down, 720 × 480 px, f = 600 px.
CAMERA_POSE = (0.0, -12.0, 3.5, math.radians(90.0), math.radians(25.0))
CAMERA_SIZE = (720, 480)
CAMERA_F_PX = 600.0


def project(x: np.ndarray, y: np.ndarray, z: np.ndarray | float = 0.0) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Site points → image px (u right, v down) and depth along the optical axis."""
    cx, cy, cz, yaw, pitch = CAMERA_POSE
    fwd = np.array([math.cos(pitch) * math.cos(yaw), math.cos(pitch) * math.sin(yaw), -math.sin(pitch)])
    right = np.array([math.sin(yaw), -math.cos(yaw), 0.0])
    down = np.cross(fwd, right)
    p = np.stack([np.asarray(x, float) - cx, np.asarray(y, float) - cy, np.broadcast_to(z, np.shape(x)) - cz], -1)
    depth = p @ fwd
    u = CAMERA_SIZE[0] / 2 + CAMERA_F_PX * (p @ right) / depth
    v = CAMERA_SIZE[1] / 2 + CAMERA_F_PX * (p @ down) / depth
    return u, v, depth


def camera_points() -> list[list[float]]:
    """Surveyed ground points for the site file: [u, v, x, y]."""
    xs, ys = np.meshgrid([-6.0, 0.0, 6.0], [-4.0, 4.0, 15.0])
    u, v, _ = project(xs.ravel(), ys.ravel())
    return [[float(a), float(b), float(c), float(d)] for a, b, c, d in zip(u, v, xs.ravel(), ys.ravel())]


HEIGHTS_M = {"car": 1.5, "cyclist": 1.8, "pedestrian": 1.75}


def detections(ms: Sequence[Mover], t_end: float, rng: np.random.Generator, fps: float = 10.0,
               pixel_sigma: float = 3.0, miss: float = 0.1, false_alarms: float = 0.05, confusion: float = 0.03,
               clock_offset_s: float = 0.0) -> list[tuple]:
    """Camera boxes at `fps`: the object's ground centre projected (box bottom centre), px noise, misses, false
    alarms at random ground points, a wrong class now and then."""
    out = []
    classes = list(SIZES_M)
    for t in np.arange(0.0, t_end, 1.0 / fps):
        for m in ms:
            if not m.present(t) or rng.random() < miss:
                continue
            x, y = m.at(t)
            u, v, depth = project(np.array([x]), np.array([y]))
            if depth[0] < 1.0 or not (0 <= u[0] < CAMERA_SIZE[0] and 0 <= v[0] < CAMERA_SIZE[1]):
                continue
            h = CAMERA_F_PX * HEIGHTS_M[m.cls] / depth[0]
            w = CAMERA_F_PX * SIZES_M[m.cls][0 if m.cls != "car" else 1] / depth[0]
            cls = m.cls if rng.random() >= confusion else classes[rng.integers(len(classes))]
            u0, v0 = u[0] + rng.normal(0, pixel_sigma), v[0] + rng.normal(0, pixel_sigma)
            out.append((float(t + clock_offset_s), float(u0 - w / 2), float(v0 - h), float(w), float(h), cls,
                        float(rng.uniform(0.6, 0.99))))
        if rng.random() < false_alarms:
            x, y = rng.uniform(-6, 6), rng.uniform(-4, 15)
            u, v, depth = project(np.array([x]), np.array([y]))
            out.append((float(t + clock_offset_s), float(u[0] - 20), float(v[0] - 60), 40.0, 60.0,
                        classes[rng.integers(len(classes))], float(rng.uniform(0.3, 0.7))))
    return out


def site_yaml(scs: Sequence[Scanner], time_offsets_s: Optional[Sequence[float]] = None, camera: bool = True,
              processing: str = "") -> str:
    """The site file of the simulated intersection; `time_offsets_s` per scanner (site clock = scanner + offset)."""
    offs = time_offsets_s or [0.0] * len(scs)
    lines = [f"origin: {{lat_deg: {ORIGIN[0]}, lon_deg: {ORIGIN[1]}, height_m: {ORIGIN[2]}, heading_deg: 90}}",
             "scanners:"]
    for i, (s, o) in enumerate(zip(scs, offs)):
        lines.append(f"  - {{name: s{i + 1}, x_m: {s.x_m}, y_m: {s.y_m}, yaw_deg: {math.degrees(s.yaw_rad)}, "
                     f"time_offset_s: {o}, max_range_m: {s.max_range_m}, start_angle_deg: -90, step_deg: 0.5, "
                     f"beams: {BEAMS}}}")
    if camera:
        lines += ["camera:", f"  width_px: {CAMERA_SIZE[0]}", f"  height_px: {CAMERA_SIZE[1]}",
                  f"  intrinsics: [{CAMERA_F_PX}, {CAMERA_F_PX}, {CAMERA_SIZE[0] / 2}, {CAMERA_SIZE[1] / 2}]",
                  f"  points: {camera_points()}"]
    if processing:
        lines.append(f"processing: {processing}")
    return "\n".join(lines) + "\n"


def simulate(scenario: str, seed: int = 0, clock_offsets_s: Sequence[float] = (0.0, 0.0), camera_offset_s: float = 0.0,
             background_s: float = 2.0, noise_m: float = 0.01) -> Run:
    """One run of a scenario: `background_s` of empty scene first (the background is learned), then the road
    users. Scanner clocks read true time + their offset; the site file written carries no offsets."""
    rng = np.random.default_rng(seed)
    ms = movers(scenario, rng)
    for m in ms:
        m.t0_s += background_s
        m.t1_s += background_s
    t_end = max(m.t1_s for m in ms)
    scs = scanners()
    for s, off in zip(scs, clock_offsets_s):
        s.clock_offset_s = off
        s.noise_m = noise_m
    scans = []
    for i, sc in enumerate(scs):
        for k, t in enumerate(np.arange(sc.phase_s, t_end, 1.0 / SCAN_HZ)):
            s = scan(sc, k, float(t), [m for m in ms if m.present(t)], rng)
            s["scanner"] = i
            scans.append(s)
    scans.sort(key=lambda s: s["time_s"])
    truth = [dict(id=m.id, cls=m.cls, t=float(t), x_m=m.at(t)[0], y_m=m.at(t)[1], heading_rad=m.heading_rad)
             for t in np.arange(0.0, t_end, 0.1) for m in ms if m.present(t)]
    return Run(scenario, seed, scans, detections(ms, t_end, rng, clock_offset_s=camera_offset_s), truth,
               site_yaml(scs), scs, ms)


def rtk_log(run: Run, rate_hz: float) -> list[dict]:
    """Truth as an RTK receiver logs it: per object, time, lat/lon (WGS84, via the site origin), at `rate_hz`."""
    from ..roadside import site_to_wgs84
    t_end = max(m.t1_s for m in run.movers)
    out = []
    for t in np.arange(0.0, t_end, 1.0 / rate_hz):
        for row in run.truth_at(float(t)):
            lat, lon = site_to_wgs84(run.site_yaml, row["x_m"], row["y_m"])
            out.append(dict(t=float(t), id=row["id"], cls=row["cls"], lat_deg=lat, lon_deg=lon))
    return out


def simulate_moving_scanner(seed: int = 0, rate_hz: float = 10.0, speed_mps: float = 2.0,
                            noise_m: float = 0.01) -> Run:
    """A scanner on a vehicle driving east through the intersection (y = −1.75 m, x −30 → +30 m) while a pedestrian
    crosses ahead (x = 15 m, northwards at 1.4 m/s from t = 3 s). Every scan carries the vehicle's pose; the site
    file's scanner sits at the vehicle's origin. Truth: the pedestrian (id 1)."""
    rng = np.random.default_rng(seed)
    walker = Mover("pedestrian", 15.0, -9.0, math.pi / 2, 1.4, 3.0, 3.0 + 18.0 / 1.4, 1)
    t_end = 60.0 / speed_mps
    scans = []
    for k, t in enumerate(np.arange(0.0, t_end, 1.0 / rate_hz)):
        x = -30.0 + speed_mps * float(t)
        s = scan(Scanner(x, -1.75, 0.0, noise_m=noise_m), k, float(t), [walker] if walker.present(t) else [], rng)
        s.update(scanner=0, pose=(x, -1.75, 0.0), source=f"vehicle#{k}")
        scans.append(s)
    truth = [dict(id=1, cls="pedestrian", t=float(t), x_m=walker.at(t)[0], y_m=walker.at(t)[1],
                  heading_rad=walker.heading_rad) for t in np.arange(0.0, t_end, 0.1) if walker.present(t)]
    site = (f"origin: {{lat_deg: {ORIGIN[0]}, lon_deg: {ORIGIN[1]}, height_m: {ORIGIN[2]}, heading_deg: 90}}\n"
            f"scanners: [{{name: vehicle, max_range_m: 80, start_angle_deg: -90, step_deg: 0.5, beams: {BEAMS}}}]\n"
            f"processing: {{cycle_s: {1.0 / rate_hz}, confirm_hits: 3, scanner_timeout_s: {3.0 / rate_hz}}}\n")
    return Run("moving_scanner", seed, scans, [], truth, site, [], [walker])
