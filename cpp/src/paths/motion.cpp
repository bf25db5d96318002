// SPDX-License-Identifier: BSD-3-Clause
#include "roadpreview/paths/motion.hpp"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <sstream>
#include <stdexcept>

#include "roadpreview/core/frames.hpp"
#include "core/csv.hpp"

namespace roadpreview {
MotionTable MotionTable::read_csv(const std::string& path) {
    std::ifstream in(path);
    if (!in) throw std::runtime_error(path + ": cannot open motion file");
    const auto fail = [&](int line, const std::string& what) {
        throw std::runtime_error(path + ":" + std::to_string(line) + ": " + what);
    };
    MotionTable table;
    table.source_ = path;
    std::string line;
    int number = 0;
    std::vector<int> column;  // index of t, speed, yaw_rate in a row
    while (std::getline(in, line)) {
        ++number;
        if (csv::skipped(line)) continue;
        const auto cells = csv::split(line);
        if (column.empty()) {
            for (const char* name : {"t", "speed", "yaw_rate"}) {
                const auto it = std::find(cells.begin(), cells.end(), name);
                if (it == cells.end()) fail(number, std::string("the header has no column '") + name + "' (need t,speed,yaw_rate)");
                column.push_back(static_cast<int>(it - cells.begin()));
            }
            continue;
        }
        double v[3];
        for (int k = 0; k < 3; ++k) {
            const auto c = static_cast<std::size_t>(column[static_cast<std::size_t>(k)]);
            char* end = nullptr;
            v[k] = c < cells.size() ? std::strtod(cells[c].c_str(), &end) : NAN;
            if (c >= cells.size() || end == cells[c].c_str() || *end != '\0' || !std::isfinite(v[k]))
                fail(number, "expected a finite number in every column, got \"" + line + "\"");
        }
        if (!table.t_.empty() && v[0] <= table.t_.back()) fail(number, "t must increase from row to row");
        table.t_.push_back(v[0]);
        table.speed_.push_back(v[1]);
        table.yaw_rate_.push_back(v[2]);
    }
    if (column.empty() || table.t_.size() < 2) fail(number, "need a header t,speed,yaw_rate and at least two rows");
    table.distance_.assign(1, 0.0);
    table.heading_.assign(1, 0.0);
    for (std::size_t i = 1; i < table.t_.size(); ++i) {
        const double dt = table.t_[i] - table.t_[i - 1];
        table.distance_.push_back(table.distance_.back() + 0.5 * dt * (table.speed_[i - 1] + table.speed_[i]));
        table.heading_.push_back(table.heading_.back() + 0.5 * dt * (table.yaw_rate_[i - 1] + table.yaw_rate_[i]));
    }
    return table;
}

double MotionTable::integral(const std::vector<double>& rate, const std::vector<double>& cumulative, double t) const {
    at(t);  // the span check and its message
    const auto hi = static_cast<std::size_t>(std::upper_bound(t_.begin(), t_.end(), t) - t_.begin());
    const std::size_t i = std::min(hi, t_.size() - 1) - 1;
    const double dt = t - t_[i];
    const double rate_t = rate[i] + dt / (t_[i + 1] - t_[i]) * (rate[i + 1] - rate[i]);
    return cumulative[i] + 0.5 * dt * (rate[i] + rate_t);
}

double MotionTable::distance_m(double t) const { return integral(speed_, distance_, t); }
double MotionTable::heading_rad(double t) const { return integral(yaw_rate_, heading_, t); }

Motion MotionTable::at(double t) const {
    if (!(t >= t_.front() && t <= t_.back())) {
        std::ostringstream msg;
        msg.precision(15);
        msg << source_ << ": frame time " << t << " s lies outside the motion table's span [" << t_.front() << ", "
            << t_.back() << "] s (the t column must use the frames' clock)";
        throw std::runtime_error(msg.str());
    }
    const auto hi = static_cast<std::size_t>(std::upper_bound(t_.begin(), t_.end(), t) - t_.begin());
    const std::size_t i = std::min(hi, t_.size() - 1) - 1;
    const double w = (t - t_[i]) / (t_[i + 1] - t_[i]);
    return {speed_[i] + w * (speed_[i + 1] - speed_[i]), yaw_rate_[i] + w * (yaw_rate_[i + 1] - yaw_rate_[i])};
}

std::optional<double> imu_yaw_rate(const std::vector<ImuSample>& samples, const Extrinsics& sensor_in_base) {
    if (samples.empty()) return std::nullopt;
    double mean[3] = {0, 0, 0};
    for (const ImuSample& s : samples)
        for (int k = 0; k < 3; ++k) mean[k] += s.angular_velocity[static_cast<std::size_t>(k)] / samples.size();
    const RigidTransform T = to_rigid_transform(sensor_in_base);
    return T.R[2][0] * mean[0] + T.R[2][1] * mean[1] + T.R[2][2] * mean[2];
}

}  // namespace roadpreview
