// SPDX-License-Identifier: BSD-3-Clause
// Beam offsets from the road's shape (docs/method.md §8, "From the road's shape"): in every frame a beam's points
// sit off the smooth road by its offset times their elevation Jacobian; the road's own relief differs from frame
// to frame, the beam's offset does not, so the median over frames keeps the offset.
#include <algorithm>
#include <cmath>
#include <limits>

#include <Eigen/Dense>

#include "roadpreview/calibration/calibration.hpp"
#include "roadpreview/core/frames.hpp"

#include "core/median.hpp"
#include "core/text.hpp"

#include "beam_geometry.hpp"

namespace roadpreview {
namespace {

using detail::deg;
using detail::rad;

constexpr int kTerms = 6;         // 1, x, y, x², xy, y²
constexpr double kScaleM = 10.0;  // x and y in tens of metres: a well-conditioned normal matrix
constexpr double kMadToSigma = 1.4826;
constexpr double kMedianEfficiency = 1.2533;  // σ of a median of n Gaussians ≈ 1.2533·σ/√n

// core/median.hpp's median of a copy; NaN for none.
double median(std::vector<double> v) {
    return v.empty() ? std::numeric_limits<double>::quiet_NaN() : roadpreview::median(v.begin(), v.end());
}

Eigen::Matrix<double, kTerms, 1> terms(double x, double y) {
    const double u = x / kScaleM, v = y / kScaleM;
    Eigen::Matrix<double, kTerms, 1> t;
    t << 1.0, u, v, u * u, u * v, v * v;
    return t;
}

// A corridor point: base-frame x, y, z, its beam and its elevation Jacobian J (height change per radian).
struct RoadPoint {
    double x, y, z, jacobian;
    std::int32_t beam;
};

// The surface's height residual of every point, fitted to the points `keep` marks.
std::vector<double> surface_residuals(const std::vector<RoadPoint>& pts, const std::vector<char>& keep) {
    Eigen::Matrix<double, kTerms, kTerms> normal = Eigen::Matrix<double, kTerms, kTerms>::Zero();
    Eigen::Matrix<double, kTerms, 1> rhs = Eigen::Matrix<double, kTerms, 1>::Zero();
    for (std::size_t k = 0; k < pts.size(); ++k) {
        if (!keep[k]) continue;
        const auto t = terms(pts[k].x, pts[k].y);
        normal += t * t.transpose();
        rhs += t * pts[k].z;
    }
    const Eigen::Matrix<double, kTerms, 1> c = normal.ldlt().solve(rhs);
    std::vector<double> e(pts.size());
    for (std::size_t k = 0; k < pts.size(); ++k) e[k] = pts[k].z - terms(pts[k].x, pts[k].y).dot(c);
    return e;
}

// Robust σ of the residuals of the kept points.
double robust_sigma(const std::vector<double>& e, const std::vector<char>& keep) {
    std::vector<double> a;
    for (std::size_t k = 0; k < e.size(); ++k)
        if (keep[k]) a.push_back(e[k]);
    const double m = median(a);
    for (double& v : a) v = std::abs(v - m);
    return kMadToSigma * median(a);
}

}  // namespace

SurfaceCalibrator::SurfaceCalibrator(const Config& cfg, int beam_count, SurfaceCalibrationOptions options)
    : cfg_(cfg), beam_count_(beam_count), options_(options),
      values_(static_cast<std::size_t>(std::max(beam_count, 0))),
      reach_sum_(static_cast<std::size_t>(std::max(beam_count, 0)), 0.0),
      reach_weight_(static_cast<std::size_t>(std::max(beam_count, 0)), 0.0) {
    if (beam_count < 1)
        throw std::invalid_argument("beam calibration needs a beam count >= 1, got " + std::to_string(beam_count));
    if (!(options.max_x_m > options.min_x_m) || !(options.half_width_m > 0) || options.min_points < 1 ||
        options.min_frames < 1 || options.rounds < 1 || !(options.outlier_sigmas > 0) || !(options.max_sigma_deg > 0) ||
        options.min_beams < 1)
        throw std::invalid_argument("surface calibration options: need max_x_m > min_x_m, half_width_m > 0, "
                                    "min_points, min_frames, rounds, min_beams >= 1, outlier_sigmas, max_sigma_deg > 0");
}

void SurfaceCalibrator::add_frame(PointsView points, const std::vector<std::int32_t>& beams) {
    const auto n = static_cast<std::size_t>(points.rows());
    if (beams.size() != n)
        throw std::invalid_argument("beam calibration: frame " + std::to_string(frames_) + " has " + std::to_string(n) +
                                    " points but " + std::to_string(beams.size()) + " beam indices");
    const std::vector<std::uint8_t> ground = one_plane_ground(points, cfg_);
    const RigidTransform T = to_rigid_transform(effective_extrinsics(cfg_));
    std::vector<RoadPoint> road;
    for (std::size_t k = 0; k < n; ++k) {
        const std::int32_t beam = beams[k];
        if (!ground[k] || beam < 0) continue;
        detail::check_beam_index(beam, beam_count_);
        const auto row = static_cast<Eigen::Index>(k);
        const double p[3] = {points(row, 0), points(row, 1), points(row, 2)};
        const double r = std::sqrt(p[0] * p[0] + p[1] * p[1] + p[2] * p[2]);
        double b[3];
        transform_point(T, p, b);
        if (!(r > 0) || !std::isfinite(r) || b[0] < options_.min_x_m || b[0] > options_.max_x_m ||
            std::abs(b[1]) > options_.half_width_m)
            continue;
        road.push_back({b[0], b[1], b[2], detail::elevation_jacobian(p, r, T), beam});
    }
    ++frames_;
    if (road.size() < static_cast<std::size_t>(options_.min_points * kTerms)) return;  // too little road
    std::vector<char> keep(road.size(), 1);
    std::vector<double> e;
    for (int round = 0; round < options_.rounds; ++round) {
        e = surface_residuals(road, keep);
        const double sigma = robust_sigma(e, keep);
        if (!(sigma > 0)) break;  // a road without noise: nothing is an outlier
        for (std::size_t k = 0; k < road.size(); ++k) keep[k] = std::abs(e[k]) <= options_.outlier_sigmas * sigma;
    }
    e = surface_residuals(road, keep);
    noise_.push_back(robust_sigma(e, keep));
    std::vector<std::vector<double>> offsets(static_cast<std::size_t>(beam_count_));
    for (std::size_t k = 0; k < road.size(); ++k) {
        if (!keep[k] || road[k].jacobian == 0.0) continue;
        const auto b = static_cast<std::size_t>(road[k].beam);
        offsets[b].push_back(e[k] / road[k].jacobian);
        reach_sum_[b] -= road[k].jacobian;
        reach_weight_[b] += 1.0;
    }
    for (std::size_t b = 0; b < offsets.size(); ++b)
        if (static_cast<int>(offsets[b].size()) >= options_.min_points) values_[b].push_back(median(offsets[b]));
}

BeamCalibration SurfaceCalibrator::solve() const {
    if (frames_ < options_.min_frames)
        throw CalibrationError("too short: " + std::to_string(frames_) + " frame(s), the surface calibration needs at "
                               "least " + std::to_string(options_.min_frames));
    std::vector<int> determined;
    std::vector<double> delta(static_cast<std::size_t>(beam_count_), 0.0), sigma(delta.size(), 0.0);
    for (std::size_t b = 0; b < values_.size(); ++b) {
        const std::vector<double>& v = values_[b];
        if (static_cast<int>(v.size()) < options_.min_frames) continue;
        delta[b] = median(v);
        std::vector<double> spread;
        for (double x : v) spread.push_back(std::abs(x - delta[b]));
        sigma[b] = kMedianEfficiency * kMadToSigma * median(spread) / std::sqrt(static_cast<double>(v.size()));
        if (sigma[b] <= rad(options_.max_sigma_deg)) determined.push_back(static_cast<int>(b));
    }
    if (static_cast<int>(determined.size()) < options_.min_beams)
        throw CalibrationError("too few beams on the ground: " + std::to_string(determined.size()) +
                               " beam(s) seen in " + std::to_string(options_.min_frames) + " frames' road within " +
                               number_text(options_.max_sigma_deg) + " deg, calibration needs at least " +
                               std::to_string(options_.min_beams));
    // Relative, as BeamCalibrator's: less the least-squares fit a + b·mean/reach + c·reach/mean over the beams
    // determined (a pitch, a height and a sag of the road, which the ground cannot tell from offsets).
    std::vector<double> reach(values_.size(), std::numeric_limits<double>::quiet_NaN());  // mean −J: its range
    for (std::size_t b = 0; b < reach.size(); ++b)
        if (reach_weight_[b] > 0) reach[b] = reach_sum_[b] / reach_weight_[b];
    const Eigen::MatrixXd basis = detail::gauge_columns(reach, determined);
    Eigen::VectorXd d(static_cast<Eigen::Index>(determined.size()));
    for (std::size_t k = 0; k < determined.size(); ++k)
        d[static_cast<Eigen::Index>(k)] = delta[static_cast<std::size_t>(determined[k])];
    const Eigen::VectorXd relative = d - basis * basis.colPivHouseholderQr().solve(d);

    BeamCalibration out;
    out.beam_count = beam_count_;
    out.beams.assign(static_cast<std::size_t>(beam_count_), BeamOffsets{});
    out.frames = frames_;
    out.residual_m = noise_.empty() ? 0.0 : median(noise_);
    for (std::size_t b = 0; b < values_.size(); ++b)
        out.beams[b].observations = static_cast<std::int64_t>(values_[b].size());
    for (std::size_t k = 0; k < determined.size(); ++k) {
        BeamOffsets& o = out.beams[static_cast<std::size_t>(determined[k])];
        o.determined = true;
        o.elevation_offset_deg = deg(relative[static_cast<Eigen::Index>(k)]);
        o.elevation_sigma_deg = deg(sigma[static_cast<std::size_t>(determined[k])]);
    }
    return out;
}

}  // namespace roadpreview
