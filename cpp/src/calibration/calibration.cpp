// SPDX-License-Identifier: BSD-3-Clause
// Beam self-calibration (docs/method.md §8): per (cell, frame, beam) means of the ground points' heights, the
// cells' heights eliminated by centring each cell's observations, the beams' elevation (and range) offsets and
// each frame's plane by weighted least squares with weak priors and two gauge constraints.
#include "roadpreview/calibration/calibration.hpp"

#include <algorithm>
#include <cmath>
#include <map>
#include <numeric>
#include <sstream>
#include <tuple>

#include <Eigen/Dense>

#include "roadpreview/core/frames.hpp"
#include "roadpreview/ground/ground.hpp"

#include "beam_geometry.hpp"
#include "core/text.hpp"

namespace roadpreview {
namespace {

using detail::deg;
using detail::gauge_columns;
using detail::kPi;
using detail::rad;

constexpr double kPriorElevationRad = 0.5 * kPi / 180.0;  // the priors only regularise what the data leave open
constexpr double kPriorRangeM = 0.1;
constexpr double kPriorOffsetM = 0.5;
constexpr double kPriorSlope = 0.02;
constexpr double kGaugePrecision = 1e12;  // 1/rad²: holds the two gauge directions at zero

using Obs = BeamCalibrator::Observation;

struct Problem {
    std::vector<Obs> obs;                 // sorted by cell; only cells with two or more observations
    std::vector<std::size_t> cell_start;  // obs index where each cell starts, plus the end
    int beams = 0, frames = 0;
    std::vector<int> range_column;        // per beam: its range offset's column, or −1
    int columns() const {
        return beams + static_cast<int>(std::count_if(range_column.begin(), range_column.end(),
                                                      [](int c) { return c >= 0; })) + 3 * frames;
    }
    int frame_column(int f) const { return columns() - 3 * frames + 3 * f; }
};

struct Fit {
    Eigen::VectorXd theta;
    Eigen::MatrixXd covariance;
    std::vector<double> residual;  // centred, per observation; 0 for observations left out
};

// The sparse regressor row of one observation: (column, value) pairs.
int row_entries(const Problem& p, const Obs& o, int frame0, std::pair<int, double> out[5]) {
    int n = 0;
    out[n++] = {o.beam, o.j_elevation};
    if (p.range_column[static_cast<std::size_t>(o.beam)] >= 0)
        out[n++] = {p.range_column[static_cast<std::size_t>(o.beam)], o.j_range};
    const int f = frame0 + 3 * o.frame;
    out[n++] = {f, 1.0};
    out[n++] = {f + 1, o.x};
    out[n++] = {f + 2, o.y};
    return n;
}

// Per beam: the weighted mean of −J_δ (for a level sensor, the beam's mean horizontal range on the ground).
std::vector<double> beam_reach(const std::vector<Obs>& obs, int beams) {
    std::vector<double> weight(static_cast<std::size_t>(beams), 0.0), sum(static_cast<std::size_t>(beams), 0.0);
    for (const Obs& o : obs) {
        weight[static_cast<std::size_t>(o.beam)] += o.weight;
        sum[static_cast<std::size_t>(o.beam)] -= o.weight * o.j_elevation;
    }
    std::vector<double> reach(static_cast<std::size_t>(beams), INFINITY);
    for (std::size_t b = 0; b < reach.size(); ++b)
        if (weight[b] > 0) reach[b] = sum[b] / weight[b];
    return reach;
}

// The offsets the ground cannot tell from the mounting or the road's shape (method.md §8): a common one (tilts
// every ring like a pitch), one ∝ 1/reach (lifts every ring by one height, like the sensor's height) and one
// ∝ reach (bends the rings' heights by reach², like a sag or crest driven straight over). Zero for beams never seen.
Eigen::MatrixXd gauge_basis(const std::vector<double>& reach) {
    std::vector<int> seen;
    for (std::size_t b = 0; b < reach.size(); ++b)
        if (std::isfinite(reach[b])) seen.push_back(static_cast<int>(b));
    const Eigen::MatrixXd columns = gauge_columns(reach, seen);
    Eigen::MatrixXd basis = Eigen::MatrixXd::Zero(static_cast<Eigen::Index>(reach.size()), 3);
    for (std::size_t k = 0; k < seen.size(); ++k) basis.row(seen[k]) = columns.row(static_cast<Eigen::Index>(k));
    return basis;
}

Eigen::VectorXd prior_precision(const Problem& p) {
    Eigen::VectorXd prior(p.columns());
    const int frame0 = p.frame_column(0);
    for (int k = 0; k < p.beams; ++k) prior[k] = 1.0 / (kPriorElevationRad * kPriorElevationRad);
    for (int k = p.beams; k < frame0; ++k) prior[k] = 1.0 / (kPriorRangeM * kPriorRangeM);
    for (int f = 0; f < p.frames; ++f) {
        prior[frame0 + 3 * f] = 1.0 / (kPriorOffsetM * kPriorOffsetM);
        prior[frame0 + 3 * f + 1] = prior[frame0 + 3 * f + 2] = 1.0 / (kPriorSlope * kPriorSlope);
    }
    return prior;
}

// Adds one cell's centred observations (those in `keep`) to the normal equations.
void add_cell(const Problem& p, std::size_t first, std::size_t last, const std::vector<char>& keep, double noise2,
              Eigen::MatrixXd& normal, Eigen::VectorXd& rhs) {
    const int frame0 = p.frame_column(0);
    std::map<int, double> mean;  // the cell's weighted mean regressor row, by column
    double weight = 0.0, z_mean = 0.0;
    std::pair<int, double> e[5];
    for (std::size_t k = first; k < last; ++k) {
        if (!keep[k]) continue;
        const Obs& o = p.obs[k];
        weight += o.weight;
        z_mean += o.weight * o.z;
        for (int n = row_entries(p, o, frame0, e), q = 0; q < n; ++q) mean[e[q].first] += o.weight * e[q].second;
    }
    if (weight <= 0) return;
    z_mean /= weight;
    std::vector<int> cols;
    std::vector<double> mean_row;
    for (const auto& [c, v] : mean) cols.push_back(c), mean_row.push_back(v / weight);
    std::vector<double> row(cols.size());
    for (std::size_t k = first; k < last; ++k) {
        if (!keep[k]) continue;
        const Obs& o = p.obs[k];
        for (std::size_t q = 0; q < cols.size(); ++q) row[q] = -mean_row[q];
        for (int n = row_entries(p, o, frame0, e), q = 0; q < n; ++q)
            row[static_cast<std::size_t>(std::lower_bound(cols.begin(), cols.end(), e[q].first) - cols.begin())] +=
                e[q].second;
        const double w = o.weight / noise2;
        for (std::size_t a = 0; a < cols.size(); ++a) {
            rhs[cols[a]] += w * row[a] * (o.z - z_mean);
            for (std::size_t b = 0; b < cols.size(); ++b) normal(cols[a], cols[b]) += w * row[a] * row[b];
        }
    }
}

// The centred residual of every kept observation under theta.
std::vector<double> residuals(const Problem& p, const std::vector<char>& keep, const Eigen::VectorXd& theta) {
    std::vector<double> out(p.obs.size(), 0.0);
    const int frame0 = p.frame_column(0);
    std::pair<int, double> e[5];
    for (std::size_t c = 0; c + 1 < p.cell_start.size(); ++c) {
        double weight = 0.0, mean = 0.0;
        for (std::size_t k = p.cell_start[c]; k < p.cell_start[c + 1]; ++k) {
            if (!keep[k]) continue;
            double predicted = 0.0;
            for (int n = row_entries(p, p.obs[k], frame0, e), q = 0; q < n; ++q) predicted += theta[e[q].first] * e[q].second;
            out[k] = p.obs[k].z - predicted;
            weight += p.obs[k].weight;
            mean += p.obs[k].weight * out[k];
        }
        for (std::size_t k = p.cell_start[c]; k < p.cell_start[c + 1]; ++k)
            if (keep[k]) out[k] -= mean / weight;
    }
    return out;
}

Fit fit(const Problem& p, const std::vector<char>& keep, double noise_m, const Eigen::MatrixXd& gauge) {
    const int n = p.columns();
    Eigen::MatrixXd normal = Eigen::MatrixXd::Zero(n, n);
    Eigen::VectorXd rhs = Eigen::VectorXd::Zero(n);
    for (std::size_t c = 0; c + 1 < p.cell_start.size(); ++c)
        add_cell(p, p.cell_start[c], p.cell_start[c + 1], keep, noise_m * noise_m, normal, rhs);
    normal.diagonal() += prior_precision(p);
    normal.topLeftCorner(p.beams, p.beams) += kGaugePrecision * gauge * gauge.transpose();
    Fit out;
    out.covariance = normal.ldlt().solve(Eigen::MatrixXd::Identity(n, n));
    out.theta = out.covariance * rhs;
    out.residual = residuals(p, keep, out.theta);
    return out;
}

double median(std::vector<double> v) {
    if (v.empty()) return 0.0;
    const auto mid = v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2);
    std::nth_element(v.begin(), mid, v.end());
    return *mid;
}

// fit() repeated: the point noise from the residuals' median, observations beyond outlier_sigmas dropped.
Fit robust_fit(const Problem& p, const CalibrationOptions& o, const Eigen::MatrixXd& gauge, double& noise) {
    std::vector<char> keep(p.obs.size(), 1);
    noise = 0.02;
    Fit f;
    for (int round = 0; round < o.rounds; ++round) {
        f = fit(p, keep, noise, gauge);
        std::vector<double> scaled, kept;
        for (std::size_t k = 0; k < p.obs.size(); ++k) {
            scaled.push_back(std::abs(f.residual[k]) * std::sqrt(p.obs[k].weight));
            if (keep[k]) kept.push_back(scaled.back());
        }
        noise = std::max(1.4826 * median(kept), 1e-4);
        for (std::size_t k = 0; k < p.obs.size(); ++k) keep[k] = scaled[k] <= o.outlier_sigmas * noise;
    }
    return f;
}

// Offsets of `members` less their best fit by the gauge columns, and their σ (rad).
void relative_offsets(const Fit& f, const std::vector<int>& members, const std::vector<double>& reach,
                      Eigen::VectorXd& delta, Eigen::VectorXd& sigma) {
    const auto m = static_cast<Eigen::Index>(members.size());
    const Eigen::MatrixXd basis = gauge_columns(reach, members);
    Eigen::VectorXd theta(m);
    Eigen::MatrixXd cov(m, m);
    for (Eigen::Index a = 0; a < m; ++a) {
        theta[a] = f.theta[members[static_cast<std::size_t>(a)]];
        for (Eigen::Index b = 0; b < m; ++b)
            cov(a, b) = f.covariance(members[static_cast<std::size_t>(a)], members[static_cast<std::size_t>(b)]);
    }
    const Eigen::MatrixXd P = Eigen::MatrixXd::Identity(m, m) -
                              basis * basis.completeOrthogonalDecomposition().pseudoInverse();
    delta = P * theta;
    sigma = (P * cov * P.transpose()).diagonal().cwiseMax(0.0).cwiseSqrt();
}

[[noreturn]] void too_few_beams(std::size_t n, const std::string& what, int needed) {
    throw CalibrationError("too few beams on the ground: " + std::to_string(n) + " beam(s) " + what +
                           ", calibration needs at least " + std::to_string(needed));
}

// Beams with at least min_observations observations in cells another beam also saw: only these can be compared,
// and a beam seen in a handful of cells has a σ the pooled noise understates.
std::vector<int> shared_beams(const Problem& p, int min_observations) {
    std::vector<int> shared(static_cast<std::size_t>(p.beams), 0);
    for (std::size_t c = 0; c + 1 < p.cell_start.size(); ++c) {
        const std::size_t a = p.cell_start[c], b = p.cell_start[c + 1];
        const bool several = std::any_of(p.obs.begin() + static_cast<std::ptrdiff_t>(a),
                                         p.obs.begin() + static_cast<std::ptrdiff_t>(b),
                                         [&](const Obs& o) { return o.beam != p.obs[a].beam; });
        if (several)
            for (std::size_t k = a; k < b; ++k) ++shared[static_cast<std::size_t>(p.obs[k].beam)];
    }
    std::vector<int> out;
    for (int b = 0; b < p.beams; ++b)
        if (shared[static_cast<std::size_t>(b)] >= min_observations) out.push_back(b);
    return out;
}

Problem make_problem(std::vector<Obs> obs, int beams, int frames) {
    std::sort(obs.begin(), obs.end(), [](const Obs& a, const Obs& b) { return std::tie(a.i, a.j) < std::tie(b.i, b.j); });
    Problem p;
    p.beams = beams;
    p.frames = frames;
    p.range_column.assign(static_cast<std::size_t>(beams), -1);
    for (std::size_t a = 0; a < obs.size();) {
        std::size_t b = a;
        while (b < obs.size() && obs[b].i == obs[a].i && obs[b].j == obs[a].j) ++b;
        if (b - a >= 2) {  // a cell seen once compares nothing
            p.cell_start.push_back(p.obs.size());
            p.obs.insert(p.obs.end(), obs.begin() + static_cast<std::ptrdiff_t>(a), obs.begin() + static_cast<std::ptrdiff_t>(b));
        }
        a = b;
    }
    p.cell_start.push_back(p.obs.size());
    return p;
}

double travel(const std::vector<Pose2>& poses) {
    double sum = 0.0;
    for (std::size_t k = 1; k < poses.size(); ++k) sum += std::hypot(poses[k].x_m - poses[k - 1].x_m, poses[k].y_m - poses[k - 1].y_m);
    return sum;
}

std::string fixed(double v, int digits) {
    std::ostringstream s;
    s.precision(digits);
    s << std::fixed << v;
    return s.str();
}

}  // namespace

BeamCalibrator::BeamCalibrator(const Config& cfg, int beam_count, CalibrationOptions options)
    : cfg_(cfg), beam_count_(beam_count), options_(options) {
    if (beam_count < 1) throw std::invalid_argument("beam calibration needs a beam count >= 1, got " + std::to_string(beam_count));
    // Cells of 1 cm to 10 m: finer, the road's cells outnumber what an integer index holds (1e-300 m once did).
    if (!(options.cell_m >= 0.01 && options.cell_m <= 10.0) || options.rounds < 1 || options.min_beams < 1 ||
        !(options.max_sigma_deg > 0))
        throw std::invalid_argument("calibration options: need 0.01 <= cell_m <= 10 m (got " +
                                    number_text(options.cell_m) + "), rounds >= 1, min_beams >= 1, max_sigma_deg > 0");
}

void BeamCalibrator::add_frame(PointsView points, const std::vector<std::int32_t>& beams,
                               const std::vector<std::uint8_t>& ground_mask, const Pose2& pose) {
    const auto n = static_cast<std::size_t>(points.rows());
    if (beams.size() != n || ground_mask.size() != n)
        throw std::invalid_argument("beam calibration: frame " + std::to_string(poses_.size()) + " has " +
                                    std::to_string(n) + " points but " + std::to_string(beams.size()) + " beam indices and " +
                                    std::to_string(ground_mask.size()) + " ground flags");
    const RigidTransform T = to_rigid_transform(effective_extrinsics(cfg_));
    const double c = std::cos(pose.yaw_rad), s = std::sin(pose.yaw_rad);
    const auto frame = static_cast<std::int32_t>(poses_.size());
    std::map<std::tuple<std::int64_t, std::int64_t, std::int32_t>, std::size_t> group;  // (cell, beam) → observation
    const std::size_t first = observations_.size();
    for (std::size_t k = 0; k < n; ++k) {
        const std::int32_t beam = beams[k];
        if (!ground_mask[k] || beam < 0) continue;
        detail::check_beam_index(beam, beam_count_);
        const double p[3] = {points(static_cast<Eigen::Index>(k), 0), points(static_cast<Eigen::Index>(k), 1),
                             points(static_cast<Eigen::Index>(k), 2)};
        const double r = std::sqrt(p[0] * p[0] + p[1] * p[1] + p[2] * p[2]);
        if (!(r > 0) || !std::isfinite(r)) continue;
        // reported at r along u(θ, φ); the true point lies at p − ρ·u + r·δ·∂u/∂θ (method.md §8)
        double base[3];
        transform_point(T, p, base);
        const double j_el = detail::elevation_jacobian(p, r, T);
        const double j_r = (T.R[2][0] * p[0] + T.R[2][1] * p[1] + T.R[2][2] * p[2]) / r;
        const double ox = pose.x_m + c * base[0] - s * base[1], oy = pose.y_m + s * base[0] + c * base[1];
        const auto i = static_cast<std::int64_t>(std::floor(ox / options_.cell_m));
        const auto j = static_cast<std::int64_t>(std::floor(oy / options_.cell_m));
        const auto [it, fresh] = group.try_emplace(std::make_tuple(i, j, beam), observations_.size());
        if (fresh) observations_.push_back({i, j, frame, beam, 0, 0, 0, 0, 0, 0});
        Obs& o = observations_[it->second];
        o.weight += 1;
        o.z += base[2], o.x += base[0], o.y += base[1], o.j_elevation += j_el, o.j_range += j_r;
    }
    for (std::size_t k = first; k < observations_.size(); ++k) {
        Obs& o = observations_[k];
        o.z /= o.weight, o.x /= o.weight, o.y /= o.weight, o.j_elevation /= o.weight, o.j_range /= o.weight;
    }
    poses_.push_back(pose);
}

std::vector<std::uint8_t> one_plane_ground(PointsView points, const Config& cfg) {
    const RigidTransform T = to_rigid_transform(effective_extrinsics(cfg));
    Eigen::Matrix<float, Eigen::Dynamic, 3, Eigen::RowMajor> base(points.rows(), 3);
    for (Eigen::Index k = 0; k < points.rows(); ++k) {
        const double p[3] = {points(k, 0), points(k, 1), points(k, 2)};
        double b[3];
        transform_point(T, p, b);
        for (int c = 0; c < 3; ++c) base(k, c) = static_cast<float>(b[c]);
    }
    // Not the zone ground: it also follows the verges and pavements (method.md §8: KITTI's residual 17.7 mm with
    // zones, 10.7 mm with the one plane).
    GroundConfig one_plane = cfg.ground;
    one_plane.method = GroundMethod::Pca;
    return fit_ground(points_view(base.data(), base.rows(), 3), one_plane).mask;
}

void BeamCalibrator::add_frame(PointsView points, const std::vector<std::int32_t>& beams, const Pose2& pose) {
    add_frame(points, beams, one_plane_ground(points, cfg_), pose);
}

std::string short_drive_warning(double travel_m) {
    if (travel_m >= kShortDriveM) return "";
    return "a drive of " + fixed(travel_m, 2) + " m is short for the motion method (" + fixed(kShortDriveM, 0) +
           " m or more): its offsets are unreliable and their σ understated; the surface method needs no motion";
}

BeamCalibration BeamCalibrator::solve() const {
    const auto frames = static_cast<int>(poses_.size());
    if (frames < options_.min_frames)
        throw CalibrationError("too short: " + std::to_string(frames) + " frame(s), calibration needs at least " +
                               std::to_string(options_.min_frames));
    const double moved = travel(poses_);
    if (moved < options_.min_travel_m)
        throw CalibrationError("no motion: the vehicle moved " + fixed(moved, 3) + " m over " + std::to_string(frames) +
                               " frames, calibration needs at least " + fixed(options_.min_travel_m, 2) + " m");
    Problem p = make_problem(observations_, beam_count_, frames);
    std::vector<int> determined = shared_beams(p, options_.min_observations);
    if (static_cast<int>(determined.size()) < options_.min_beams)
        too_few_beams(determined.size(), "share " + std::to_string(options_.min_observations) +
                      " road cells with others", options_.min_beams);
    const std::vector<double> reach = beam_reach(p.obs, beam_count_);
    const Eigen::MatrixXd gauge = gauge_basis(reach);
    double noise = 0.0;
    const Fit f = robust_fit(p, options_, gauge, noise);
    Eigen::VectorXd delta, sigma;
    for (int pass = 0; pass < 2; ++pass) {  // each offset's σ depends on the beams the fit a + b/reach is over
        relative_offsets(f, determined, reach, delta, sigma);
        std::vector<int> kept;
        for (std::size_t k = 0; k < determined.size(); ++k)
            if (sigma[static_cast<Eigen::Index>(k)] <= rad(options_.max_sigma_deg)) kept.push_back(determined[k]);
        determined = kept;
        if (static_cast<int>(determined.size()) < options_.min_beams)
            too_few_beams(determined.size(), "determined within " + fixed(options_.max_sigma_deg, 4) + " deg",
                          options_.min_beams);
    }
    relative_offsets(f, determined, reach, delta, sigma);

    BeamCalibration out;
    out.beam_count = beam_count_;
    out.beams.assign(static_cast<std::size_t>(beam_count_), BeamOffsets{});
    out.frames = frames;
    out.travel_m = moved;
    out.residual_m = noise;
    for (const Obs& o : p.obs) out.beams[static_cast<std::size_t>(o.beam)].observations += 1;
    for (std::size_t k = 0; k < determined.size(); ++k) {
        BeamOffsets& b = out.beams[static_cast<std::size_t>(determined[k])];
        b.determined = true;
        b.elevation_offset_deg = deg(delta[static_cast<Eigen::Index>(k)]);
        b.elevation_sigma_deg = deg(sigma[static_cast<Eigen::Index>(k)]);
    }
    // range offsets where the drive tells them from the elevation offsets (a beam seen at one range cannot)
    int column = beam_count_;
    for (int b : determined) p.range_column[static_cast<std::size_t>(b)] = column++;
    double joint_noise = 0.0;
    const Fit joint = robust_fit(p, options_, gauge, joint_noise);
    for (int b : determined) {
        const int col = p.range_column[static_cast<std::size_t>(b)];
        const double s = std::sqrt(std::max(joint.covariance(col, col), 0.0));
        if (s > options_.max_range_sigma_m) continue;
        out.beams[static_cast<std::size_t>(b)].range_offset_m = joint.theta[col];
        out.beams[static_cast<std::size_t>(b)].range_sigma_m = s;
    }
    return out;
}

}  // namespace roadpreview
