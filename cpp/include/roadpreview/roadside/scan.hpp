// SPDX-License-Identifier: BSD-3-Clause
// One 2-D laser scan in the scanner's own frame, whatever file or protocol it came from, and the readers of the
// plain formats (CSV, CARMEN logs). Scanner frame: x straight ahead, y left, angles counter-clockwise from x.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

namespace roadpreview::roadside {

/// A scanner pose in the site frame (or in a log's world frame): metres, radians.
struct Pose2 {
    double x_m = 0.0, y_m = 0.0, yaw_rad = 0.0;
};

struct LaserScan {
    double time_s = 0.0;            ///< acquisition time of the scan, s (the file's or the capture's clock)
    int scanner = 0;                ///< which scanner (index into the site's scanner list)
    std::int64_t counter = -1;      ///< the sensor's scan counter, -1 when the source has none
    double start_angle_rad = 0.0;   ///< angle of the first beam, scanner frame
    double step_rad = 0.0;          ///< angle between beams (> 0: counter-clockwise)
    std::vector<float> ranges_m;    ///< per beam, NaN = no return (or out of the sensor's range)
    std::vector<float> intensities; ///< per beam, empty when the source has none
    std::optional<Pose2> pose;      ///< the scanner's pose when the source logs one (CARMEN: a moving robot)
    std::string source;             ///< "file:line" or "file#telegram", for messages

    double angle_rad(std::size_t beam) const { return start_angle_rad + step_rad * static_cast<double>(beam); }
};

/// Scans from a CSV with the header `t,scanner,angle_deg,range_m[,intensity]` (extra columns ignored): one row
/// per beam, rows of one scan consecutive with the same t and scanner, beams in increasing angle at a constant
/// step. range_m empty, NaN or ≤ 0 is no return. Throws std::runtime_error naming the file and line.
std::vector<LaserScan> read_scan_csv(const std::string& path);

/// `FLASER` scans of a CARMEN log (plain or .gz): 180° front laser, the first beam at −90°, the step
/// 180°/num_readings when the log has no `laser_front_laser_resolution` PARAM. Ranges ≥ `max_range_m` (the
/// log's `robot_front_laser_max` when 0) are no return. Each scan carries the pose the log gives. A log whose
/// timestamps are all 0 gets times index / `rate_hz` (0.001–100,000 Hz, else std::invalid_argument) and
/// `*timestamps_missing` is set.
std::vector<LaserScan> read_carmen_log(const std::string& path, double rate_hz, double max_range_m = 0.0,
                                       bool* timestamps_missing = nullptr);

}  // namespace roadpreview::roadside
