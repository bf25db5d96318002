// SPDX-License-Identifier: BSD-3-Clause
// Distance calibration d = a1·c + a2 (docs/method.md §11.2): least squares with outlier rejection.
#include <algorithm>
#include <cmath>
#include <fstream>
#include <stdexcept>

#include <Eigen/Dense>

#include "core/csv.hpp"
#include "core/input_file.hpp"
#include "core/text.hpp"
#include "roadpreview/range_sensor/range_sensor.hpp"

namespace roadpreview {
namespace {

constexpr double kOutlierSigmas = 3.5;  // |residual| beyond this many robust σ is an outlier
constexpr int kMaxRounds = 10;

double median_of(std::vector<double> v) {
    const auto mid = v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2);
    std::nth_element(v.begin(), mid, v.end());
    if (v.size() % 2) return *mid;
    return 0.5 * (*mid + *std::max_element(v.begin(), mid));
}

// Least squares of d = a1·c + a2 over the kept pairs, with standard errors and R².
void fit_line(const std::vector<double>& c, const std::vector<double>& d, const std::vector<char>& keep,
              DistanceCalibration& out) {
    const auto n = static_cast<Eigen::Index>(std::count(keep.begin(), keep.end(), 1));
    Eigen::MatrixXd A(n, 2);
    Eigen::VectorXd y(n);
    Eigen::Index row = 0;
    for (std::size_t i = 0; i < c.size(); ++i)
        if (keep[i]) {
            A(row, 0) = c[i];
            A(row, 1) = 1.0;
            y(row++) = d[i];
        }
    const Eigen::Vector2d p = A.colPivHouseholderQr().solve(y);
    const Eigen::VectorXd r = y - A * p;
    const double sse = r.squaredNorm();
    const double sst = (y.array() - y.mean()).square().sum();
    out.a1 = p(0);
    out.a2 = p(1);
    out.used = n;
    out.rms_m = std::sqrt(sse / static_cast<double>(n));
    out.r_squared = sst > 0 ? 1.0 - sse / sst : 1.0;
    const double s2 = n > 2 ? sse / static_cast<double>(n - 2) : 0.0;
    const Eigen::Matrix2d cov = s2 * (A.transpose() * A).inverse();
    out.a1_sigma = std::sqrt(cov(0, 0));
    out.a2_sigma = std::sqrt(cov(1, 1));
}

}  // namespace

std::string implausible(const DistanceCalibration& cal) {
    if (!(cal.a1 > 0.0) || !std::isfinite(cal.a1))
        return "a1 must be a finite number of metres per count > 0, got " + number_text(cal.a1);
    if (!(std::abs(cal.a2) <= kMaxRangeOffsetM))
        return "a2 must lie within ±" + number_text(kMaxRangeOffsetM) + " m, got " + number_text(cal.a2);
    return {};
}

DistanceCalibration calibrate_distance(const std::vector<double>& counts, const std::vector<double>& distances) {
    if (counts.size() != distances.size()) throw std::invalid_argument("counts and distances differ in length");
    std::vector<double> c, d;
    for (std::size_t i = 0; i < counts.size(); ++i)
        if (std::isfinite(counts[i]) && std::isfinite(distances[i])) {
            c.push_back(counts[i]);
            d.push_back(distances[i]);
        }
    if (c.size() < 3)
        throw std::invalid_argument("distance calibration needs at least 3 finite (count, distance) pairs");
    if (*std::min_element(c.begin(), c.end()) == *std::max_element(c.begin(), c.end()))
        throw std::invalid_argument("distance calibration needs readings at two or more distinct counts");
    DistanceCalibration cal;
    std::vector<char> keep(c.size(), 1);
    for (int round = 0; round < kMaxRounds; ++round) {
        fit_line(c, d, keep, cal);
        std::vector<double> abs_res(c.size());
        for (std::size_t i = 0; i < c.size(); ++i) abs_res[i] = std::abs(d[i] - cal.a1 * c[i] - cal.a2);
        std::vector<double> kept_res;
        for (std::size_t i = 0; i < c.size(); ++i)
            if (keep[i]) kept_res.push_back(abs_res[i]);
        // 1.4826·MAD, with a floor so exact data (MAD 0) rejects nothing but gross errors.
        const double sigma = std::max(1.4826 * median_of(kept_res), 1e-9 + 1e-9 * std::abs(cal.a2));
        bool changed = false;
        for (std::size_t i = 0; i < c.size(); ++i) {
            const char k = abs_res[i] <= kOutlierSigmas * sigma ? 1 : 0;
            changed |= k != keep[i];
            keep[i] = k;
        }
        if (!changed || std::count(keep.begin(), keep.end(), 1) < 3) break;
    }
    if (std::count(keep.begin(), keep.end(), 1) >= 3) fit_line(c, d, keep, cal);
    cal.rejected = static_cast<std::int64_t>(c.size()) - cal.used;
    if (const std::string why = implausible(cal); !why.empty())
        throw std::invalid_argument("the bench readings give no usable line: " + why);
    return cal;
}

void read_bench_csv(const std::string& path, std::vector<double>& counts, std::vector<double>& distances) {
    require_input_file<std::runtime_error>(path, "bench file");
    std::ifstream in(path);
    if (!in) throw std::runtime_error(path + ": cannot open the bench file");
    csv::Header header;
    std::string line;
    std::int64_t number = 0;
    while (std::getline(in, line)) {
        ++number;
        if (csv::skipped(line)) continue;
        const auto cells = csv::split(line);
        const std::string where = path + ":" + std::to_string(number);
        if (header.empty()) {
            header = csv::Header(cells, {"count", "distance"}, where);
            continue;
        }
        counts.push_back(csv::finite_cell(cells, header.at("count"), where, "count"));
        distances.push_back(csv::finite_cell(cells, header.at("distance"), where, "distance"));
    }
    if (header.empty()) throw std::runtime_error(path + ": empty file, expected a header count,distance");
    if (counts.size() < 3) throw std::runtime_error(path + ": need at least 3 readings, got "
        + std::to_string(counts.size()));
}

}  // namespace roadpreview
