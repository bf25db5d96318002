// SPDX-License-Identifier: BSD-3-Clause
// Vehicle motion per frame: a table of speed and yaw rate over time (motion.csv), or the yaw rate an IMU
// measured, rotated into the base frame.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "roadpreview/core/config.hpp"
#include "roadpreview/io/frame_source.hpp"

namespace roadpreview {

struct Motion {
    double speed_mps = 0.0;     ///< negative when reversing
    double yaw_rate_rps = 0.0;  ///< positive turning left
};

/// Speed and yaw rate sampled over time, linearly interpolated in between.
class MotionTable {
public:
    /// A CSV file with a header naming the columns t (s), speed (m/s) and yaw_rate (rad/s), in any order
    /// (other columns are ignored), then at least two rows with strictly increasing t. Lines starting
    /// with '#' and blank lines are skipped. Throws std::runtime_error naming the file and line.
    static MotionTable read_csv(const std::string& path);

    /// A table from samples in memory (a bag's odometry topic, LiDAR odometry): equal lengths, at least two
    /// rows, finite values, strictly increasing t. Throws std::runtime_error naming `source`.
    static MotionTable from_samples(std::vector<double> t, std::vector<double> speed_mps,
                                    std::vector<double> yaw_rate_rps, std::string source);

    /// Motion at time t (s, the frames' clock). Throws std::runtime_error naming the file when t lies
    /// outside the table's time span (no extrapolation).
    Motion at(double t) const;

    const std::string& source() const { return source_; }

    /// Distance driven (m) and heading change (rad) from the table's first time to t: the exact integrals of
    /// the linearly interpolated speed and yaw rate. Throws like at() outside the span.
    double distance_m(double t) const;
    double heading_rad(double t) const;
    double first_time() const { return t_.front(); }

    const std::vector<double>& times() const { return t_; }          ///< s
    const std::vector<double>& speeds() const { return speed_; }     ///< m/s
    const std::vector<double>& yaw_rates() const { return yaw_rate_; }  ///< rad/s

private:
    void integrate();  // distance_ and heading_ from the rows

    double integral(const std::vector<double>& rate, const std::vector<double>& cumulative, double t) const;

    std::string source_;
    std::vector<double> t_, speed_, yaw_rate_;
    std::vector<double> distance_, heading_;  // integrals at each row's time
};

/// The yaw rate (rad/s about the base frame's z axis) of the mean angular velocity of `samples` (sensor
/// frame) rotated into the base frame by the extrinsics; nullopt when there are no samples.
std::optional<double> imu_yaw_rate(const std::vector<ImuSample>& samples, const Extrinsics& sensor_in_base);

}  // namespace roadpreview
