"""roadpreview.sim — simulated roads of known roughness scanned by simulated spinning LiDARs and stereo cameras
(numpy only).

    from roadpreview import sim
    road = sim.Road.iso8608("C", seed=1, bumps=(sim.SpeedBump(x_m=15, height_m=0.05, length_m=0.6),))
    scene = sim.Scene(road, boxes=(sim.Box(12, 16.5, 2.5, 4.3, 1.5),))
    lidar = sim.os1_128(height_m=1.8)
    frames = sim.drive(scene, lidar, speed_mps=10, yaw_rate_rps=0.1, frames=10, seed=0)
    cfg = rp.Config(extrinsics=lidar.extrinsics())
    truth = sim.truth_profiles(scene, frames[0].pose, 10, 0.1)
    rings = sim.ring_profiles(scene, lidar, frames[0].pose, 10, 0.1)   # what a noise-free sensor's rings can see

Every result is deterministic for a given seed. Units: metres, seconds, radians (angles of beam tables in
degrees, as the manuals give them). Frames: see ``drive`` (world = frame 0's base frame) and ``lidar``.
"""

from .drive import Frame, Pose, drive, ring_profiles, scan, trajectory, truth_profiles, wheel_path_xy
from .lidar import PRESETS, Lidar, hdl_64e, os1_128, preset, vlp_16
from .road import ISO_CLASSES, GradeChange, Pothole, Road, RoughField, SpeedBump, class_gd_n0, iso_psd
from .scene import LABEL_NONE, LABEL_OBSTACLE, LABEL_ROAD, Box, Scene, cast
from . import roadside  # roadside scenes: python/roadpreview/sim/roadside.py
from .range_sensor import (BenchTrack, ProfileTrack, RangeDrive, RangeSensorModel, bench_counts, bench_profile, bench_reference,
                           bench_road, drive_readings, laser, layout_yaml, measured_distance, ultrasonic)
from .stereo import SGBM_ON_KITTI, StereoCamera, StereoFrame, correlated_noise, drive_stereo, kitti_stereo, render

__all__ = [
    "Box", "Frame", "ISO_CLASSES", "LABEL_NONE", "LABEL_OBSTACLE", "LABEL_ROAD", "Lidar", "PRESETS", "Pose",
    "GradeChange", "Pothole", "Road", "RoughField", "Scene", "SpeedBump", "cast", "class_gd_n0", "drive", "hdl_64e",
    "iso_psd",
    "os1_128", "preset", "ring_profiles", "scan", "trajectory", "truth_profiles", "vlp_16", "wheel_path_xy",
    "BenchTrack", "ProfileTrack", "RangeDrive", "RangeSensorModel", "bench_counts", "bench_profile", "bench_reference", "bench_road",
    "drive_readings", "laser", "layout_yaml", "measured_distance", "ultrasonic",
    "SGBM_ON_KITTI", "StereoCamera", "StereoFrame", "correlated_noise", "drive_stereo", "kitti_stereo", "render",
]
