"""Point range preview sensors over a simulated road: downward-looking ultrasonic sensors (first echo within the
beam cone, counts, latency, noise, dropouts) and laser displacement sensors (a small spot), a bench track of arcs
and triangles, and straight drives at bench or road speeds.

World frame as in ``sim.drive`` (x forward along the drive, y left, z up, metres). The vehicle's axle moves along
the line y = 0 from x = ``start_x_m`` at t = 0; a sensor at (x_m, y_m) of the layout hangs ``height_m`` above the
road's mean plane below it. A reading stamped t was measured at t − latency (the paper's b1 = −latency); its
distance is d = a1·c + a2 at the bench temperature, d = a1·c·v(T)/v(T_cal) + a2 at air temperature T.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Optional, Sequence

import numpy as np

from .road import Road

SOUND_MPS_0C = 331.3


def speed_of_sound_mps(temperature_c) -> np.ndarray:
    """v_sound = 331.3·√(1 + T/273.15) m/s."""
    return SOUND_MPS_0C * np.sqrt(1.0 + np.asarray(temperature_c, float) / 273.15)


@dataclass(frozen=True)
class RangeSensorModel:
    """One simulated point range sensor and its truth (true calibration, latency)."""

    id: str
    kind: str = "laser"  #: "ultrasonic" or "laser"
    wheel: str = "left"  #: "left" or "right"
    x_m: float = 0.5  #: ahead of the axle
    y_m: float = 0.8  #: positive left
    height_m: float = 0.3  #: above the road's mean plane
    pitch_deg: float = 0.0  #: beam from straight down towards +x
    beam_half_angle_deg: float = 0.0  #: ultrasonic cone half angle
    spot_m: float = 0.002  #: laser spot diameter
    rate_hz: float = 500.0
    latency_s: float = 0.0  #: time from measuring to the reading's timestamp
    noise_m: float = 0.0  #: σ of the distance
    dropout: float = 0.0  #: probability that a reading is missing
    a1: float = 343.2 / 2 / 1e6  #: true m per count (1 µs clock, round trip)
    a2: float = 0.0  #: true distance offset, m
    temperature_c: float = 20.0  #: bench temperature of a1
    max_count: float = 65535.0

    @property
    def foot_m(self) -> float:
        """Where the beam meets the mean plane, ahead of the axle (the true b2)."""
        return self.x_m + self.height_m * math.tan(math.radians(self.pitch_deg))


def ultrasonic(id: str = "us_left", wheel: str = "left", **kw) -> RangeSensorModel:
    """A cheap ultrasonic sensor: 12° half cone, 1 mm noise, 12 ms latency, 2 % dropouts, a 5 mm offset."""
    args = dict(kind="ultrasonic", wheel=wheel, y_m=0.8 if wheel == "left" else -0.8, beam_half_angle_deg=12.0,
                rate_hz=200.0, latency_s=0.012, noise_m=0.001, dropout=0.02, a2=0.005)
    args.update(kw)
    return RangeSensorModel(id, **args)


def laser(id: str = "laser_left", wheel: str = "left", **kw) -> RangeSensorModel:
    """A laser displacement sensor: 2 mm spot, 0.3 mm noise, 1 ms latency, 1 kHz, distances in metres."""
    args = dict(kind="laser", wheel=wheel, y_m=0.8 if wheel == "left" else -0.8, spot_m=0.002, rate_hz=1000.0,
                latency_s=0.001, noise_m=0.0003, dropout=0.0)
    args.update(kw)
    return RangeSensorModel(id, **args)


def layout_yaml(sensors: Sequence[RangeSensorModel]) -> str:
    """The layout file roadpreview reads (docs/method.md §11.1) for these sensors."""
    lines = ["sensors:"]
    for s in sensors:
        lines += [f"  - id: {s.id}", f"    kind: {s.kind}", f"    wheel: {s.wheel}", f"    x_m: {s.x_m!r}",
                  f"    y_m: {s.y_m!r}", f"    height_m: {s.height_m!r}", f"    pitch_deg: {s.pitch_deg!r}",
                  f"    beam_half_angle_deg: {s.beam_half_angle_deg!r}", f"    max_count: {s.max_count!r}"]
    return "\n".join(lines) + "\n"


# --- the bench track -----------------------------------------------------------------------------------------

BENCH_START_M = 0.5  #: the track's first metre mark in the world frame
BENCH_LENGTH_M = 3.0


def bench_profile(x) -> np.ndarray:
    """Height (m) of the built-in 3 m bench track at world x: circular arcs (a bump and a dip) and triangles
    (a steep ramp, a symmetric one) on flat ground, like the paper's test bench; 0 off the track."""
    u = np.asarray(x, float) - BENCH_START_M
    z = np.zeros_like(u)
    z += _arc(u, 0.40, 0.30, 0.030)     # bump 30 cm long, 3 cm high
    z -= _arc(u, 0.95, 0.30, 0.020)     # dip 30 cm long, 2 cm deep
    z += _triangle(u, 1.40, 1.70, 1.75, 0.040)  # 30 cm up, 5 cm steep edge down (the paper's "steep downhill")
    z += _triangle(u, 2.10, 2.30, 2.50, 0.025)  # symmetric 40 cm, 2.5 cm
    z += _arc(u, 2.65, 0.20, 0.015)     # small bump
    return z


def _arc(u, start, length, height):
    """A circular-arc segment of chord `length` and sagitta `height` starting at u = start."""
    radius = (length**2 / 4 + height**2) / (2 * height)
    c = start + length / 2
    inside = np.abs(u - c) < length / 2
    return np.where(inside, np.sqrt(np.maximum(radius**2 - (u - c) ** 2, 0.0)) - (radius - height), 0.0)


def _triangle(u, a, peak, b, height):
    up = (u >= a) & (u < peak)
    down = (u >= peak) & (u < b)
    return np.where(up, height * (u - a) / (peak - a), np.where(down, height * (b - u) / (b - peak), 0.0))


@dataclass(frozen=True)
class BenchTrack:
    """The bench track as a road feature (sim.Road's bumps take it): the same height across y."""

    height_m: float = 0.04  #: its highest point (for Road.relief_bounds)

    def height(self, x, y) -> np.ndarray:
        return bench_profile(np.broadcast_arrays(np.asarray(x, float), np.asarray(y, float))[0])


@dataclass(frozen=True)
class ProfileTrack:
    """A measured longitudinal profile laid on the road (sim.Road's bumps take it): height z(x) linearly
    interpolated, the same across y, 0 outside."""

    x_m: np.ndarray
    z_m: np.ndarray

    @property
    def height_m(self) -> float:
        return float(np.max(self.z_m, initial=0.0))

    def height(self, x, y) -> np.ndarray:
        x = np.broadcast_arrays(np.asarray(x, float), np.asarray(y, float))[0]
        return np.interp(x, self.x_m, self.z_m, left=0.0, right=0.0)


def bench_road() -> Road:
    """A flat road carrying the bench track at world x ∈ [0.5, 3.5] m."""
    return Road(bumps=(BenchTrack(),))


def bench_reference(step_m: float = 0.001, x_from: float = -1.0, x_to: float = 6.0) -> np.ndarray:
    """(x, z) of the bench track, the reference profile of the offset calibration."""
    x = np.arange(x_from, x_to + step_m / 2, step_m)
    return np.column_stack([x, bench_profile(x)])


# --- measuring -----------------------------------------------------------------------------------------------

def measured_distance(road: Road, sensor: RangeSensorModel, x_axle, y_axle: float = 0.0) -> np.ndarray:
    """Exact distance (m) each sensor reading sees with the axle at x_axle (straight drive along +x).

    Ultrasonic: the first echo — the nearest road point inside the beam cone (a grid of the footprint).
    Laser: the mean height over the spot where the (pitched) beam meets the road.
    """
    x_axle = np.asarray(x_axle, float)
    xs, ys, h = x_axle + sensor.x_m, y_axle + sensor.y_m, sensor.height_m
    pitch = math.radians(sensor.pitch_deg)
    axis = np.array([math.sin(pitch), 0.0, -math.cos(pitch)])
    if sensor.kind == "ultrasonic":
        return _first_echo(road, xs, ys, h, axis, math.radians(sensor.beam_half_angle_deg))
    d = np.full_like(xs, h / math.cos(pitch))
    for _ in range(4):  # where the beam meets the surface: a fixed point, converging fast for small pitch
        foot = xs + d * axis[0]
        offsets = np.linspace(-sensor.spot_m / 2, sensor.spot_m / 2, 3)
        z = np.mean([road.height(foot + o, np.full_like(foot, ys)) for o in offsets], axis=0)
        d = (h - z) / math.cos(pitch)
    return d


def _first_echo(road: Road, xs, ys, h, axis, half_angle, rings: int = 8, spokes: int = 16) -> np.ndarray:
    """Nearest road point within the cone about `axis` from (xs, ys, h): the footprint sampled in rings."""
    best = np.full_like(xs, np.inf)
    r_max = h * math.tan(half_angle) * 1.3  # the footprint grows over dips
    foot_x = xs + h * axis[0] / -axis[2]
    radii = np.linspace(0.0, r_max, rings + 1)
    for r in radii:
        angles = np.linspace(0, 2 * np.pi, spokes, endpoint=False) if r > 0 else np.array([0.0])
        for a in angles:
            px, py = foot_x + r * math.cos(a), ys + r * math.sin(a)
            pz = road.height(px, np.full_like(px, py))
            v = np.stack([px - xs, np.full_like(px, py - ys), pz - h])
            dist = np.linalg.norm(v, axis=0)
            inside = (axis @ v.reshape(3, -1)).reshape(dist.shape) >= dist * math.cos(half_angle)
            best = np.where(inside, np.minimum(best, dist), best)
    return best


@dataclass
class RangeDrive:
    """Readings and motion of one simulated drive, as roadpreview reads them."""

    t: np.ndarray  #: s
    sensor: np.ndarray  #: sensor id per reading (str)
    value: np.ndarray  #: count (ultrasonic) or distance in m (laser), per reading
    counts: bool  #: whether value holds counts
    temperature_c: Optional[np.ndarray]  #: per reading, or None
    motion: np.ndarray  #: (K, 3) t, speed, yaw_rate
    x_axle: np.ndarray  #: world x of the axle at each reading's timestamp
    true_z: np.ndarray  #: true road height (m) below the beam's foot where each reading was measured

    def readings_csv(self) -> str:
        name = "count" if self.counts else "distance"
        header = f"t,sensor,{name}" + (",temperature_c" if self.temperature_c is not None else "")
        fmt = "{:.6f},{},{:.0f}" if self.counts else "{:.6f},{},{:.6f}"
        rows = [header]
        for i in range(len(self.t)):
            row = fmt.format(self.t[i], self.sensor[i], self.value[i])
            if self.temperature_c is not None:
                row += f",{self.temperature_c[i]:.2f}"
            rows.append(row)
        return "\n".join(rows) + "\n"

    def motion_csv(self) -> str:
        return "t,speed,yaw_rate\n" + "".join(f"{t:.6f},{v:.6f},{w:.6f}\n" for t, v, w in self.motion)


def drive_readings(road: Road, sensors: Sequence[RangeSensorModel], speed_mps: float, length_m: float, *,
                   start_x_m: float = 0.0, temperature_c: Optional[float] = None, counts: Optional[bool] = None,
                   seed: int = 0) -> RangeDrive:
    """Every sensor's readings while the axle drives `length_m` along +x at constant speed from start_x_m.

    counts: readings in counts (default: for ultrasonic sensors only when every sensor is ultrasonic).
    temperature_c: air temperature; counts then follow the speed of sound (and the file gets the column).
    """
    if not speed_mps > 0 or not length_m > 0:
        raise ValueError(f"need speed_mps > 0 and length_m > 0, got {speed_mps}, {length_m}")
    counts = all(s.kind == "ultrasonic" for s in sensors) if counts is None else counts
    rng = np.random.default_rng(seed)
    duration = length_m / speed_mps
    parts = []
    for k, s in enumerate(sensors):
        t = np.arange(0.5 / s.rate_hz + k * 1e-5, duration, 1.0 / s.rate_hz)
        x_meas = start_x_m + speed_mps * (t - s.latency_s)  # where the axle was when it measured
        d_true = measured_distance(road, s, x_meas)
        true_z = road.height(x_meas + s.foot_m, np.full_like(t, s.y_m))
        d = d_true + rng.normal(0.0, s.noise_m, len(t)) if s.noise_m > 0 else d_true
        if counts:
            scale = 1.0
            if temperature_c is not None:
                scale = speed_of_sound_mps(temperature_c) / speed_of_sound_mps(s.temperature_c)
            value = np.round((d - s.a2) / (s.a1 * scale))
        else:
            value = d
        keep = rng.random(len(t)) >= s.dropout
        parts.append((t[keep], np.full(keep.sum(), s.id, dtype=object), value[keep],
                      x_meas[keep] + speed_mps * s.latency_s,
                      true_z[keep]))
    t = np.concatenate([p[0] for p in parts])
    order = np.argsort(t, kind="stable")
    motion_t = np.linspace(0.0, duration + 0.01, max(2, int(duration * 10) + 2))
    return RangeDrive(
        t=t[order], sensor=np.concatenate([p[1] for p in parts])[order],
        value=np.concatenate([p[2] for p in parts])[order],
        counts=counts, temperature_c=None if temperature_c is None else np.full(len(t), float(temperature_c)),
        motion=np.column_stack([motion_t, np.full_like(motion_t, speed_mps), np.zeros_like(motion_t)]),
        x_axle=np.concatenate([p[3] for p in parts])[order], true_z=np.concatenate([p[4] for p in parts])[order])


def bench_counts(sensor: RangeSensorModel, distances_m, repeats: int = 20, seed: int = 0) -> np.ndarray:
    """(count, distance) rows of a distance calibration bench: `repeats` noisy, quantised readings at each
    known distance (a flat target straight below)."""
    rng = np.random.default_rng(seed)
    d = np.repeat(np.asarray(distances_m, float), repeats)
    c = np.round((d + rng.normal(0.0, sensor.noise_m, len(d)) - sensor.a2) / sensor.a1)
    return np.column_stack([c, d])
