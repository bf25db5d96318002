"""Spinning multi-beam LiDAR models: beam tables of real sensors, mounting, noise, dropouts and range limits.

Sensor frame: x forward, y left, z up (Ouster's "sensor frame"; the Velodyne convention once rotated so). A ray
of beam b and column c points at elevation elevations_deg[b] and azimuth 360°·c/columns − azimuth_offsets_deg[b]
(counter-clockwise from x). Each frame is one instantaneous sweep: the motion during the 0.1 s sweep is not
modelled.
"""

from __future__ import annotations

import dataclasses
import json
from dataclasses import dataclass
from pathlib import Path

import numpy as np

_DATA = Path(__file__).resolve().parent / "data"


@dataclass(frozen=True)
class Lidar:
    name: str
    elevations_deg: tuple  #: per beam, + up
    azimuth_offsets_deg: tuple  #: per beam, subtracted from the column's azimuth
    columns: int  #: firings per revolution
    range_noise_m: float  #: 1σ Gaussian noise of the range along the ray
    max_range_m: float
    min_range_m: float = 0.0
    dropout: float = 0.0  #: probability that a ray returns nothing
    height_m: float = 1.8  #: mounting height above the base origin (on the ground)
    pitch_deg: float = 0.0  #: mounting tilt, positive looks down (R = Ry(pitch)·Rx(roll))
    roll_deg: float = 0.0
    elevation_error_deg: float = 0.0  #: 1σ of each beam's fixed calibration error: rays fly this far off the table
    calibration_seed: int = 0  #: draws the beams' errors (the same unit in every frame)
    beam_errors_deg: tuple = ()  #: per beam, added to the drawn errors: e.g. uniform offsets of a given bound

    def __post_init__(self):
        if len(self.elevations_deg) != len(self.azimuth_offsets_deg) or not len(self.elevations_deg):
            raise ValueError("a lidar needs one azimuth offset per beam and at least one beam")
        for ok, need, value in ((self.columns >= 1, "columns >= 1", self.columns),
                                (0 <= self.dropout < 1, "0 <= dropout < 1", self.dropout),
                                (self.range_noise_m >= 0, "range_noise_m >= 0", self.range_noise_m),
                                (0 < self.height_m < 100, "0 < height_m < 100 (above the ground)", self.height_m)):
            if not ok:
                raise ValueError(f"{self.name}: need {need}, got {value!r}")
        if not 0 <= self.min_range_m < self.max_range_m:
            raise ValueError(f"{self.name}: need 0 <= min_range_m < max_range_m")
        if self.beam_errors_deg and len(self.beam_errors_deg) != len(self.elevations_deg):
            raise ValueError(f"{self.name}: beam_errors_deg needs one entry per beam ({len(self.elevations_deg)})")

    @property
    def beams(self) -> int:
        return len(self.elevations_deg)

    def with_(self, **changes) -> "Lidar":
        """A copy with some fields changed, e.g. ``lidar.with_(height_m=1.9, range_noise_m=0.03)``."""
        return dataclasses.replace(self, **changes)

    def directions(self, actual: bool = False) -> np.ndarray:
        """Unit ray directions in the sensor frame, (beams·columns, 3), beam-major like an organised cloud: as the
        beam table says (where the sensor places its points), or as the rays actually fly (with the beams'
        calibration errors)."""
        elevations = np.asarray(self.elevations_deg, float)
        if actual:
            elevations = elevations + self.elevation_errors_deg()
        elevation = np.radians(elevations)[:, None]
        azimuth = (2 * np.pi * np.arange(self.columns)[None, :] / self.columns
                   - np.radians(np.asarray(self.azimuth_offsets_deg, float))[:, None])
        cos_el = np.cos(elevation)
        d = np.stack(np.broadcast_arrays(cos_el * np.cos(azimuth), cos_el * np.sin(azimuth), np.sin(elevation)), -1)
        return d.reshape(-1, 3)

    def elevation_errors_deg(self) -> np.ndarray:
        """How far each beam's ray flies above its table angle (the truth a beam calibration should recover)."""
        errors = np.zeros(self.beams)
        if self.elevation_error_deg:
            errors += np.random.default_rng(self.calibration_seed).normal(0.0, self.elevation_error_deg, self.beams)
        if self.beam_errors_deg:
            errors += np.asarray(self.beam_errors_deg, float)
        return errors

    def beam_index(self) -> np.ndarray:
        """Beam of each row of a frame (beam-major rows, as directions() and drive() give them)."""
        return np.repeat(np.arange(self.beams), self.columns)

    def mount_rotation(self) -> np.ndarray:
        """Sensor-to-base rotation Ry(pitch)·Rx(roll) (no yaw), as roadpreview's extrinsics define it."""
        p, r = np.radians(self.pitch_deg), np.radians(self.roll_deg)
        ry = np.array([[np.cos(p), 0, np.sin(p)], [0, 1, 0], [-np.sin(p), 0, np.cos(p)]])
        rx = np.array([[1, 0, 0], [0, np.cos(r), -np.sin(r)], [0, np.sin(r), np.cos(r)]])
        return ry @ rx

    def extrinsics(self) -> dict:
        """The pose of this sensor in the base frame as a ``roadpreview.Config(extrinsics=...)`` value."""
        return {"x_m": 0.0, "y_m": 0.0, "z_m": self.height_m, "roll_rad": float(np.radians(self.roll_deg)),
                "pitch_rad": float(np.radians(self.pitch_deg)), "yaw_rad": 0.0}


def os1_128(**changes) -> Lidar:
    """Ouster OS1-128 in 1024×10 mode: beam altitudes and azimuth offsets of a real unit (ouster-sdk test
    metadata, serial 122201000998); range repeatability 1.5 cm 1σ at high SNR and 120 m range (OS1 datasheet)."""
    meta = json.loads((_DATA / "os1_128_beams.json").read_text())
    lidar = Lidar("OS1-128", tuple(meta["beam_altitude_angles"]), tuple(meta["beam_azimuth_angles"]), columns=1024,
                  range_noise_m=0.015, max_range_m=120.0, min_range_m=0.8)
    return lidar.with_(**changes)


def hdl_64e(**changes) -> Lidar:
    """Velodyne HDL-64E at 10 Hz: +2° to −24.8° in 64 equally spaced beams (HDL-64E S2 manual, specifications),
    0.1728° azimuth step at 600 rpm (manual, appendix "Angular Resolution"), 2 cm range accuracy and 120 m range
    (as used in KITTI: Geiger et al., IJRR 2013)."""
    elevations = tuple(np.linspace(2.0, -24.8, 64))
    lidar = Lidar("HDL-64E", elevations, (0.0,) * 64, columns=2083, range_noise_m=0.02, max_range_m=120.0)
    return lidar.with_(**changes)


def vlp_16(**changes) -> Lidar:
    """Velodyne VLP-16 at 10 Hz: 16 beams at −15°…+15° every 2° (VLP-16 user manual 63-9243 Rev. D, table of
    vertical angles), 0.2° azimuth step, ±3 cm typical range accuracy, 100 m range (manual, specifications)."""
    elevations = (-15.0, 1.0, -13.0, 3.0, -11.0, 5.0, -9.0, 7.0, -7.0, 9.0, -5.0, 11.0, -3.0, 13.0, -1.0, 15.0)
    lidar = Lidar("VLP-16", elevations, (0.0,) * 16, columns=1800, range_noise_m=0.03, max_range_m=100.0)
    return lidar.with_(**changes)


PRESETS = {"os1-128": os1_128, "hdl-64e": hdl_64e, "vlp-16": vlp_16}


def preset(name: str, **changes) -> Lidar:
    """One of PRESETS by name ("os1-128", "hdl-64e", "vlp-16"), with optional field changes."""
    try:
        return PRESETS[name.lower()](**changes)
    except KeyError:
        raise ValueError(f"unknown lidar preset {name!r}; known: {sorted(PRESETS)}") from None
