// SPDX-License-Identifier: BSD-3-Clause
#include "roadpreview/paths/motion.hpp"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <sstream>
#include <stdexcept>

#include "roadpreview/core/frames.hpp"
#include "roadpreview/paths/path.hpp"
#include "core/csv.hpp"
#include "core/input_file.hpp"
#include "core/text.hpp"

namespace roadpreview {
namespace {

std::string csv_number(double v) { return number_text(v, 15); }

}  // namespace

MotionTable MotionTable::read_csv(const std::string& path) {
    require_input_file<std::runtime_error>(path, "motion file");
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
                if (it == cells.end())
                    throw std::runtime_error(path + ": the motion table needs the header t,speed,yaw_rate (line " +
                                             std::to_string(number) + " has no column '" + name + "')");
                column.push_back(static_cast<int>(it - cells.begin()));
            }
            continue;
        }
        double v[3];
        for (int k = 0; k < 3; ++k) {
            const auto c = static_cast<std::size_t>(column[static_cast<std::size_t>(k)]);
            const std::optional<double> cell = c < cells.size() ? parse_number(cells[c]) : std::nullopt;
            if (!cell || !std::isfinite(*cell))
                fail(number, "expected a finite number in every column, got \"" + line + "\"");
            v[k] = *cell;
        }
        if (const Status s = check_motion(v[1], v[2]); !s) fail(number, s.message());
        if (!table.t_.empty() && v[0] <= table.t_.back())
            throw std::runtime_error(path + ": the motion table's times must increase (line " +
                                     std::to_string(number) + ": t " + csv_number(v[0]) + " after " +
                                     csv_number(table.t_.back()) + ")");
        table.t_.push_back(v[0]);
        table.speed_.push_back(v[1]);
        table.yaw_rate_.push_back(v[2]);
    }
    if (column.empty() || table.t_.size() < 2) fail(number, "need a header t,speed,yaw_rate and at least two rows");
    table.integrate();
    return table;
}

MotionTable MotionTable::from_samples(std::vector<double> t, std::vector<double> speed_mps,
                                      std::vector<double> yaw_rate_rps, std::string source) {
    if (t.size() != speed_mps.size() || t.size() != yaw_rate_rps.size())
        throw std::runtime_error(source + ": the motion table's columns differ in length (t " +
                                 std::to_string(t.size()) + ", speed " + std::to_string(speed_mps.size()) +
                                 ", yaw rate " + std::to_string(yaw_rate_rps.size()) + ")");
    if (t.size() < 2) throw std::runtime_error(source + ": the motion table needs at least two rows");
    const auto finite = [](const std::vector<double>& v) {
        return std::all_of(v.begin(), v.end(), [](double x) { return std::isfinite(x); });
    };
    if (!finite(t) || !finite(speed_mps) || !finite(yaw_rate_rps))
        throw std::runtime_error(source + ": the motion table holds a non-finite value");
    for (std::size_t i = 0; i < t.size(); ++i)
        if (const Status s = check_motion(speed_mps[i], yaw_rate_rps[i]); !s)
            throw std::runtime_error(source + ": the motion table's row " + std::to_string(i) + ": " + s.message());
    for (std::size_t i = 1; i < t.size(); ++i)
        if (!(t[i] > t[i - 1]))
            throw std::runtime_error(source + ": the motion table's times must increase (row " + std::to_string(i) +
                                     ": t " + csv_number(t[i]) + " after " + csv_number(t[i - 1]) + ")");
    MotionTable table;
    table.source_ = std::move(source);
    table.t_ = std::move(t);
    table.speed_ = std::move(speed_mps);
    table.yaw_rate_ = std::move(yaw_rate_rps);
    table.integrate();
    return table;
}

void MotionTable::integrate() {
    distance_.assign(1, 0.0);
    heading_.assign(1, 0.0);
    for (std::size_t i = 1; i < t_.size(); ++i) {
        const double dt = t_[i] - t_[i - 1];
        distance_.push_back(distance_.back() + 0.5 * dt * (speed_[i - 1] + speed_[i]));
        heading_.push_back(heading_.back() + 0.5 * dt * (yaw_rate_[i - 1] + yaw_rate_[i]));
    }
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
        throw std::runtime_error(source_ + ": frame time " + csv_number(t) + " s lies outside the table's span [" +
                                 csv_number(t_.front()) + ", " + csv_number(t_.back()) +
                                 "] s (a motion table's t column must use the frames' clock)");
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
