// SPDX-License-Identifier: BSD-3-Clause
#include "roadpreview/fusion/fusion.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <sstream>

#include <Eigen/Cholesky>
#include <limits>
#include <optional>
#include <stdexcept>
#include <string>

#include "core/input_file.hpp"
#include "core/median.hpp"
#include "core/text.hpp"
#include "roadpreview/roughness/support.hpp"
#include "roughness/roughness_scratch.hpp"

namespace roadpreview {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr double kMedianVarianceFactor = M_PI / 2;  // Var(median of n Gaussians) ≈ (π/2)σ²/n
constexpr double kMinVariance = 1e-12;              // m²; keeps a noise-free cell's Kalman gain defined
constexpr std::size_t kMinAlignCells = 10;  // fewer cells shared with the map leave the frame as it is
// The excess is a variance estimated from n cells, uncertain by about √(2/n) of itself: the lane alone measures it
// when it holds this many (±10 %), else all shared cells do (a sparse sensor's lane holds a few rings' cells).
constexpr std::ptrdiff_t kMinExcessCells = 200;
constexpr double kMadToSigma = 1.4826;        // σ of a Gaussian from its median absolute deviation
constexpr double kOutlierSigmas = 3.0;        // cells farther than this from the alignment plane are outliers
// Single points take the pooled variance of their 5 m band of range: a point's height error is its range error
// times the sine of its ray's depression, which shrinks with range (method.md §7, step 2). Cells spread over
// kPoolMaxSpread × their band's typical spread (pooled_variances: no more than a nearer band's) stay out of its
// pool: the foot of a wall (ground up to 0.2 m high) says nothing of the road's noise, and far out, where the
// road's cells hold one point, it may be most of a band's cells of several. Two points' spread is σ·|N(0, 1)|:
// 3× the median of a band of pairs would leave out 4 % of honest ones and bias its pool 22 % low, 4× leaves
// 0.7 % (6 % low), and 7 % of the cells of a foot spread 10× the road's still pass. A band's own pool needs
// kMinPoolCells: beyond 20 m the few cells of several points are mostly kerb faces (1–4 per band, spread
// 10–20 cm, on the bundled OS1-128 recording).
constexpr double kPoolBandM = 5.0;
constexpr double kPoolMaxSpread = 4.0;
constexpr std::size_t kMinPoolCells = 10;

std::int64_t floor_index(double v, double cell) { return static_cast<std::int64_t>(std::floor(v / cell)); }

std::int64_t wrap(std::int64_t i, std::int64_t n) { return ((i % n) + n) % n; }

// One observation of a cell: height z with variance r, from points whose mean offset from the cell's centre is
// (dx, dy); the offset takes the height's weight.
void fuse_cell(MapCell& c, double z, double r, double dx, double dy, std::int32_t points, std::int32_t frame,
               const FusionConfig& cfg) {
    double weight = 1.0;  // of the new observation
    if (c.observations == 0) {
        c.height = static_cast<float>(z);
        c.variance = static_cast<float>(r);
    } else if (cfg.method == FusionMethod::Ema) {
        const double a = cfg.alpha, h = c.height, p = c.variance;
        weight = a;
        c.height = static_cast<float>(a * z + (1.0 - a) * h);
        c.variance = static_cast<float>(a * a * r + (1.0 - a) * (1.0 - a) * p);
    } else {  // Kalman: a static height observed with variance r
        const double p = c.variance;
        weight = p / (p + r);
        c.height = static_cast<float>(c.height + weight * (z - c.height));
        c.variance = static_cast<float>(p * r / (p + r));
    }
    c.dx = static_cast<float>(c.dx + weight * (dx - c.dx));
    c.dy = static_cast<float>(c.dy + weight * (dy - c.dy));
    ++c.observations;
    c.points += points;
    c.last_update = frame;
}

// The spread that makes the roughness stage's bin variance ((π/2)·spread²/count, spread²/2 for two points,
// spread² for one) equal the map's variance v of the bin.
double spread_for_variance(double v, std::int32_t count) {
    if (count >= 3) return std::sqrt(v * count / kMedianVarianceFactor);
    return std::sqrt(count == 2 ? 2.0 * v : v);
}

}  // namespace

Pose2 integrate_motion(const Pose2& p, double v, double w, double dt) {
    const double turn = w * dt;
    if (turn == 0.0) return {p.x_m + v * dt * std::cos(p.yaw_rad), p.y_m + v * dt * std::sin(p.yaw_rad), p.yaw_rad};
    const double radius = v / w, yaw = p.yaw_rad + turn;
    return {p.x_m + radius * (std::sin(yaw) - std::sin(p.yaw_rad)),
            p.y_m + radius * (std::cos(p.yaw_rad) - std::cos(yaw)), yaw};
}

Pose2 pose_from_matrix(const double (&m)[12]) { return {m[3], m[7], std::atan2(m[4], m[0])}; }

std::vector<Pose2> read_kitti_poses(const std::string& path) {
    require_input_file<std::runtime_error>(path, "poses file");
    std::ifstream in(path);
    if (!in) throw std::runtime_error(path + ": cannot open poses file");
    std::vector<Pose2> poses;
    std::string line;
    for (int number = 1; std::getline(in, line); ++number) {
        if (line.find_first_not_of(" \t\r") == std::string::npos) continue;
        std::istringstream fields(line);
        double m[12];
        int read = 0;
        for (std::string token; fields >> token; ++read) {
            const std::optional<double> v = read < 12 ? parse_number(token) : std::nullopt;
            if (!v || !std::isfinite(*v)) break;
            m[read] = *v;
        }
        if (read != 12 || !fields.eof())
            throw std::runtime_error(path + ":" + std::to_string(number) + ": a pose needs 12 finite numbers (3x4 [R|t])");
        poses.push_back(pose_from_matrix(m));
        if (const Status s = check_frame_motion({std::nullopt, poses.back()}); !s)
            throw std::runtime_error(path + ":" + std::to_string(number) + ": " + s.message());
    }
    return poses;
}

// ---------------------------------------------------------------------------------------------------------
ElevationMap::ElevationMap(double cell_m, double length_m)
    : cell_(cell_m), n_(static_cast<std::int64_t>(std::ceil(length_m / cell_m - 1e-9))) {
    cells_.assign(static_cast<std::size_t>(n_ * n_), MapCell{});
    i0_ = j0_ = -n_ / 2;
}

void ElevationMap::clear() { std::fill(cells_.begin(), cells_.end(), MapCell{}); }

void ElevationMap::clear_rows(std::int64_t first, std::int64_t last, bool along_x) {
    for (std::int64_t g = first; g < last; ++g) {
        const std::int64_t k = wrap(g, n_);
        for (std::int64_t o = 0; o < n_; ++o) cells_[static_cast<std::size_t>(along_x ? k * n_ + o : o * n_ + k)] = {};
    }
}

bool ElevationMap::move_to(double x_m, double y_m) {
    const std::int64_t i0 = floor_index(x_m, cell_) - n_ / 2, j0 = floor_index(y_m, cell_) - n_ / 2;
    const bool beyond = std::abs(i0 - i0_) >= n_ || std::abs(j0 - j0_) >= n_;
    if (beyond) {
        clear();
    } else {  // the rows and columns that enter take the slots of those that leave
        if (i0 > i0_) clear_rows(i0_ + n_, i0 + n_, true);
        if (i0 < i0_) clear_rows(i0, i0_, true);
        if (j0 > j0_) clear_rows(j0_ + n_, j0 + n_, false);
        if (j0 < j0_) clear_rows(j0, j0_, false);
    }
    i0_ = i0;
    j0_ = j0;
    return beyond;
}

std::int64_t ElevationMap::slot(double x_m, double y_m) const {
    const std::int64_t i = floor_index(x_m, cell_), j = floor_index(y_m, cell_);
    if (i < i0_ || i >= i0_ + n_ || j < j0_ || j >= j0_ + n_) return -1;
    return wrap(i, n_) * n_ + wrap(j, n_);
}

std::array<double, 2> ElevationMap::centre(std::int64_t slot) const {
    const std::int64_t i = i0_ + wrap(slot / n_ - i0_, n_), j = j0_ + wrap(slot % n_ - j0_, n_);
    return {(static_cast<double>(i) + 0.5) * cell_, (static_cast<double>(j) + 0.5) * cell_};
}

MapCell* ElevationMap::at(double x_m, double y_m) {
    const std::int64_t k = slot(x_m, y_m);
    return k < 0 ? nullptr : &cells_[static_cast<std::size_t>(k)];
}

const MapCell* ElevationMap::at(double x_m, double y_m) const { return const_cast<ElevationMap*>(this)->at(x_m, y_m); }

Status check_frame_motion(const FrameMotion& motion) noexcept {
    if (motion.timestamp_s && !std::isfinite(*motion.timestamp_s))
        return Status::error(StatusCode::InvalidArgument, "timestamp must be finite, got %g", *motion.timestamp_s);
    if (!motion.pose) return {};
    const Pose2& p = *motion.pose;
    if (!(std::abs(p.x_m) <= kMaxPoseM && std::abs(p.y_m) <= kMaxPoseM && std::abs(p.yaw_rad) <= kMaxPoseYawRad))
        return Status::error(StatusCode::InvalidArgument,
                             "pose (%g m, %g m, %g rad) must be finite and within ±%g m of the odometry frame's origin "
                             "(poses in metres?) and ±%g rad", p.x_m, p.y_m, p.yaw_rad, kMaxPoseM, kMaxPoseYawRad);
    return {};
}

// ---------------------------------------------------------------------------------------------------------
TemporalFusion::TemporalFusion(const Config& cfg)
    : cfg_(cfg), map_(cfg.fusion.cell_m, cfg.fusion.map_length_m) {
    head_.assign(static_cast<std::size_t>(map_.side() * map_.side()), -1);
}

void TemporalFusion::reset() {
    map_.clear();
    pose_ = {};
    last_time_.reset();
    fused_ = 0;
    started_ = false;
    map_has_excess_ = false;
    readout_.set = false;
}

void TemporalFusion::advance(double speed_mps, double yaw_rate_rps, const FrameMotion& motion, FusionStatus& status) {
    status.method = cfg_.fusion.method;
    double dt = started_ ? 1.0 / cfg_.fusion.frame_rate_hz : 0.0;
    if (motion.timestamp_s && last_time_) {
        dt = *motion.timestamp_s - *last_time_;
        char text[96] = "";
        // to the millisecond; a step back of less (a clock's jitter) in three digits, not as "0.000"
        if (dt < 0.0)
            std::snprintf(text, sizeof text, -dt >= 5e-4 ? "time went back by %.3f s" : "time went back by %.3g s", -dt);
        if (dt > cfg_.fusion.max_time_gap_s) std::snprintf(text, sizeof text, "time gap of %.3f s", dt);
        if (text[0]) {
            reset();
            status.reset = text;
            dt = 0.0;
        }
    }
    last_time_ = motion.timestamp_s;  // none: the next frame's dt is 1/frame_rate_hz too (one of the two is missing)
    if (motion.pose) {
        pose_ = *motion.pose;
    } else if (started_) {
        pose_ = integrate_motion(pose_, speed_mps, yaw_rate_rps, dt);
    }
    started_ = true;
    ++frame_;
    if (map_.move_to(pose_.x_m, pose_.y_m) && fused_ > 0) {  // a jump of the pose past the whole map
        fused_ = 0;
        map_has_excess_ = false;
        readout_.set = false;
        status.reset = "moved beyond the map";
    }
    status.pose = pose_;
    status.frames = fused_;
}

// A frame touches at most one cell per point: buffers that large grow only with a larger frame than any before.
void TemporalFusion::reserve_cells(std::size_t cells) {
    touched_.reserve(cells);
    for (auto* v : {&medians_, &spreads_, &cell_z_, &variances_, &pooled_, &deviations_}) v->reserve(cells);
    cell_groups_.reserve(cells);
    offsets_.reserve(cells);
    counts_.reserve(cells);
    measurements_.reserve(cells);
    bands_.reserve(cells);
    // no cell lies farther from the vehicle than the map's half-diagonal, less than its side
    pool_buffers_.reserve(static_cast<std::size_t>(map_.side() * map_.cell_m() / kPoolBandM) + 1, cells);
    align_v_.reserve(cells);
    shared_.reserve(cells);
}

void TemporalFusion::link(std::int64_t slot, std::size_t i) {
    auto& head = head_[static_cast<std::size_t>(slot)];
    if (head < 0) touched_.push_back(slot);
    next_[i] = head;
    head = static_cast<std::int32_t>(i);
}

void TemporalFusion::fuse(PointsView points, const std::vector<std::uint8_t>& mask, const Levelling& L,
                          const std::vector<float>* height_variances,
                          const std::vector<std::int32_t>* error_groups, const LocalGround* ground) {
    if (height_variances && height_variances->size() != mask.size())
        throw std::invalid_argument("fuse: height_variances and mask differ in length");
    if (error_groups && error_groups->size() != mask.size())
        throw std::invalid_argument("fuse: error_groups and mask differ in length");
    const double cos_yaw = std::cos(pose_.yaw_rad), sin_yaw = std::sin(pose_.yaw_rad);
    next_.assign(static_cast<std::size_t>(points.rows()), -1);
    std::vector<std::int64_t>& touched = touched_;
    touched.clear();
    reserve_cells(static_cast<std::size_t>(points.rows()));
    z_.resize(static_cast<std::size_t>(points.rows()));
    xy_.resize(static_cast<std::size_t>(points.rows()));
    variance_.assign(static_cast<std::size_t>(points.rows()), 0.0f);
    for (Eigen::Index i = 0; i < points.rows(); ++i) {  // per-slot linked lists: linear, no sort
        if (!mask[static_cast<std::size_t>(i)]) continue;
        const auto [x, y, z] = L.apply(points(i, 0), points(i, 1), points(i, 2));
        const std::array<double, 2> xy{pose_.x_m + cos_yaw * x - sin_yaw * y, pose_.y_m + sin_yaw * x + cos_yaw * y};
        const std::int64_t k = map_.slot(xy[0], xy[1]);
        if (k < 0) continue;
        link(k, static_cast<std::size_t>(i));
        xy_[static_cast<std::size_t>(i)] = xy;
        z_[static_cast<std::size_t>(i)] = z;
        if (height_variances) variance_[static_cast<std::size_t>(i)] = (*height_variances)[static_cast<std::size_t>(i)];
    }
    // Per cell: the median of its points, their count and spread, and its range band.
    const std::size_t cells = touched.size();
    std::vector<double>&medians = medians_, &spreads = spreads_, &cell_z = cell_z_;
    medians.resize(cells);
    spreads.resize(cells);
    offsets_.resize(cells);
    counts_.resize(cells);
    measurements_.resize(cells);
    bands_.resize(cells);
    for (std::size_t c = 0; c < cells; ++c) {
        cell_z.clear();
        cell_groups_.clear();
        double variance_sum = 0.0, x_sum = 0.0, y_sum = 0.0;
        auto& head = head_[static_cast<std::size_t>(touched[c])];
        for (std::int32_t i = head; i >= 0; i = next_[static_cast<std::size_t>(i)]) {
            cell_z.push_back(z_[static_cast<std::size_t>(i)]);
            if (error_groups) cell_groups_.push_back((*error_groups)[static_cast<std::size_t>(i)]);
            variance_sum += variance_[static_cast<std::size_t>(i)];
            x_sum += xy_[static_cast<std::size_t>(i)][0];
            y_sum += xy_[static_cast<std::size_t>(i)][1];
        }
        head = -1;
        counts_[c] = static_cast<std::int32_t>(cell_z.size());
        measurements_[c] = static_cast<std::int32_t>(
            error_groups ? distinct_count(cell_groups_.begin(), cell_groups_.end()) : cell_z.size());
        const double n = counts_[c];
        // One point: the variance its sensor states (as a profile bin of one point, docs/method.md §12), if any.
        spreads[c] = n >= 2 ? noise_spread(sample_spread(cell_z.begin(), cell_z.end()), variance_sum / n)
                            : variance_sum > 0.0 ? std::sqrt(variance_sum) : kNaN;
        medians[c] = median(cell_z.begin(), cell_z.end());
        const auto [x, y] = map_.centre(touched[c]);
        offsets_[c] = {x_sum / n - x, y_sum / n - y};
        const double dx = x - pose_.x_m, dy = y - pose_.y_m;  // sqrt, not hypot: metres, and every cell of a frame
        bands_[c] = static_cast<std::int32_t>(std::sqrt(dx * dx + dy * dy) / kPoolBandM);
    }
    // Each median's variance r as the roughness stage rates a bin's, with the pooled point variance of the cell's
    // range band (pooled_variances) for a single point that states no variance, and as a floor under a cell's own
    // spread (a single point's stated one included): r is a weight
    // in the Kalman gain and the alignment, where two points that happen to agree would outweigh a hundred. The
    // median counts as many measurements as the cell holds error groups (its points without groups).
    const bool pooled = pooled_variances(counts_.data(), spreads.data(), bands_.data(), cells, kPoolMaxSpread,
                                         kMinPoolCells, pool_buffers_, pooled_);
    const double single_point = cfg_.fusion.point_noise_m * cfg_.fusion.point_noise_m;  // no spread anywhere
    variances_.resize(cells);
    for (std::size_t c = 0; c < cells; ++c) {
        const double point = pooled ? pooled_[c] : single_point;
        const double own = std::isnan(spreads[c]) ? point : std::max(point, spreads[c] * spreads[c]);
        const double n = measurements_[c], of_median = n >= 3 ? kMedianVarianceFactor / n : 1.0 / n;  // 1, 2: mean
        variances_[c] = std::max(of_median * own, kMinVariance);
    }
    readout_.alignment.setZero();
    if (cfg_.fusion.align) align(touched, variances_, medians);
    readout_.set = ground != nullptr;
    if (ground) {
        readout_.model = *ground;  // reuses the model's buffers
        readout_.pose = pose_;
        readout_.cos_yaw = cos_yaw, readout_.sin_yaw = sin_yaw;
        readout_.L = L;
    }
    for (std::size_t c = 0; c < cells; ++c)
        fuse_cell(map_.cell(touched[c]), medians[c], variances_[c], offsets_[c][0], offsets_[c][1], counts_[c], frame_,
                  cfg_.fusion);
    ++fused_;
}

// Samples binned by the per-slot lists fuse() uses (no map, no allocation once next_ and touched_ have grown),
// then one inverse-variance weighted observation per cell.
std::size_t TemporalFusion::fuse_samples(const std::vector<MapSample>& samples) {
    if (samples.size() > static_cast<std::size_t>(std::numeric_limits<std::int32_t>::max()))
        throw std::invalid_argument("fuse_samples: more than 2^31 - 1 samples (" + std::to_string(samples.size()) + ")");
    next_.assign(samples.size(), -1);
    std::vector<std::int64_t>& touched = touched_;
    touched.clear();
    for (std::size_t i = 0; i < samples.size(); ++i) {
        const MapSample& m = samples[i];
        const std::int64_t k = map_.slot(m.x_m, m.y_m);
        if (k >= 0 && std::isfinite(m.z_m) && m.variance_m2 >= 0) link(k, i);
    }
    for (const std::int64_t k : touched) {
        double weight = 0.0, z = 0.0, x = 0.0, y = 0.0;
        std::int32_t count = 0;
        auto& head = head_[static_cast<std::size_t>(k)];
        for (std::int32_t i = head; i >= 0; i = next_[static_cast<std::size_t>(i)], ++count) {
            const MapSample& m = samples[static_cast<std::size_t>(i)];
            const double w = 1.0 / std::max(m.variance_m2, kMinVariance);
            weight += w, z += w * m.z_m, x += w * m.x_m, y += w * m.y_m;
        }
        head = -1;
        const auto [cx, cy] = map_.centre(k);
        fuse_cell(map_.cell(k), z / weight, 1.0 / weight, x / weight - cx, y / weight - cy, count, frame_, cfg_.fusion);
    }
    return touched.size();
}

void TemporalFusion::align(const std::vector<std::int64_t>& slots, std::vector<double>& variances,
                           std::vector<double>& medians) {
    std::vector<Eigen::Vector3d>& v = align_v_;  // (1, x, y) about the vehicle, for a well-conditioned fit
    v.resize(slots.size());
    shared_.clear();
    for (std::size_t c = 0; c < slots.size(); ++c) {
        const auto [x, y] = map_.centre(slots[c]);
        v[c] = Eigen::Vector3d(1.0, x - pose_.x_m, y - pose_.y_m);
        const MapCell& cell = map_.cell(slots[c]);
        if (cell.observations > 0)
            shared_.push_back({c, medians[c] - cell.height,
                               variances[c] + std::max<double>(cell.variance, kMinVariance), true});
    }
    if (shared_.size() < kMinAlignCells) return;
    mark_disagreeing_cells();
    const Eigen::Vector3d plane = fit_alignment_plane();
    readout_.alignment = plane;
    for (const SharedCell& s : shared_)
        if (!s.inlier) variances[s.index] += std::pow(s.difference - plane.dot(v[s.index]), 2);
    double excess = excess_disagreement(plane);
    if (!map_has_excess_) {  // the map's cells come from frames never compared: half the excess is theirs
        excess /= 2.0;
        for (std::int64_t k = 0; k < map_.side() * map_.side(); ++k) {
            MapCell& cell = map_.cell(k);
            if (cell.observations > 0) cell.variance = static_cast<float>(cell.variance + excess);
        }
        map_has_excess_ = true;
    }
    for (std::size_t c = 0; c < slots.size(); ++c) {
        medians[c] -= plane.dot(v[c]);
        variances[c] += excess;
    }
}

// Cells that disagree far beyond the others (the foot of a wall, a moving object) leave the fit, and their
// disagreement joins their own variance. They are judged against the median difference: a least-squares
// plane would tilt towards them (many shared cells outweigh the slope prior) and hide them.
void TemporalFusion::mark_disagreeing_cells() {
    std::vector<double>& deviations = deviations_;
    deviations.clear();
    for (const SharedCell& s : shared_) deviations.push_back(s.difference);
    const double offset = median(deviations.begin(), deviations.end());
    for (std::size_t i = 0; i < shared_.size(); ++i) deviations[i] = std::abs(shared_[i].difference - offset);
    const double scale = kMadToSigma * median(deviations.begin(), deviations.end());
    std::size_t inliers = 0;
    for (SharedCell& s : shared_) {
        s.inlier = std::abs(s.difference - offset) <= kOutlierSigmas * std::max(scale, std::sqrt(s.variance));
        inliers += s.inlier;
    }
    if (inliers < kMinAlignCells)
        for (SharedCell& s : shared_) s.inlier = true;
}

// Weighted least squares (weights 1 / variance) of the agreeing cells' differences with a zero-mean prior of
// σ = align_tilt_sigma on the slopes: a few shared cells along one ring fix the offset but must not tilt the frame.
Eigen::Vector3d TemporalFusion::fit_alignment_plane() const {
    const double prior = 1.0 / (cfg_.fusion.align_tilt_sigma * cfg_.fusion.align_tilt_sigma);
    Eigen::Matrix3d normal = Eigen::Vector3d(0.0, prior, prior).asDiagonal();
    Eigen::Vector3d rhs = Eigen::Vector3d::Zero();
    for (const SharedCell& s : shared_) {
        if (!s.inlier) continue;
        const Eigen::Vector3d weighted = align_v_[s.index] / s.variance;
        normal.noalias() += weighted * align_v_[s.index].transpose();
        rhs += weighted * s.difference;
    }
    return Eigen::Vector3d(normal.ldlt().solve(rhs));
}

// Disagreement of the agreeing cells beyond their variances (per-beam offsets, seams between frames) is error
// common to every frame that no cell's spread sees. Measured on the real OS1-128 and HDL-64E recordings it is the
// same at every range (method.md §7), so one variance, the excess, joins every cell of the frame. It is measured in
// the lane ahead, where the profiles are read: a verge's vegetation disagrees from frame to frame by centimetres
// more than a road does (KITTI) and is no measure of the road's cells.
double TemporalFusion::excess_disagreement(const Eigen::Vector3d& plane) const {
    const std::vector<Eigen::Vector3d>& v = align_v_;
    const double cos_yaw = std::cos(pose_.yaw_rad), sin_yaw = std::sin(pose_.yaw_rad);
    const auto in_lane = [&](const SharedCell& s) {  // |lateral offset| from the line ahead
        return std::abs(-sin_yaw * v[s.index][1] + cos_yaw * v[s.index][2]) <= cfg_.fusion.align_excess_half_width_m;
    };
    const bool lane_only = std::count_if(shared_.begin(), shared_.end(), [&](const SharedCell& s) {
                               return s.inlier && in_lane(s);
                           }) >= kMinExcessCells;
    double weighted = 0.0, weights = 0.0;
    for (const SharedCell& s : shared_) {
        if (!s.inlier || (lane_only && !in_lane(s))) continue;
        const double residual = s.difference - plane.dot(v[s.index]), weight = 1.0 / (s.variance * s.variance);
        weighted += weight * (residual * residual - s.variance);
        weights += weight;
    }
    return std::max(0.0, weighted / weights);
}

void TemporalFusion::sample(const WheelPaths& paths, Wheel w, const std::vector<std::uint8_t>* blocked,
                            std::size_t& ahead, std::size_t& ahead_now, Profile& p) const {
    const ProfileConfig& pc = cfg_.profile;
    const std::size_t bins_ahead = bin_count(pc);
    const auto behind = static_cast<std::size_t>(std::ceil(cfg_.fusion.behind_m / pc.ds_m - 1e-9));
    const std::size_t bins = behind + bins_ahead;
    const int lanes = std::max(1, static_cast<int>(std::lround(cfg_.tire_width / map_.cell_m())));
    const double c = std::cos(pose_.yaw_rad), sn = std::sin(pose_.yaw_rad);
    const double y_w = paths.wheel_y(w), r_w = paths.radius(w);

    p.ds = pc.ds_m;
    p.s0 = (0.5 - static_cast<double>(behind)) * pc.ds_m;
    p.s.resize(bins);
    p.z.assign(bins, kNaN);
    p.count.assign(bins, 0);
    p.spread.assign(bins, kNaN);
    p.blocked.assign(bins, 0);
    if (blocked) std::copy(blocked->begin(), blocked->end(), p.blocked.begin() + static_cast<std::ptrdiff_t>(behind));
    for (std::size_t k = 0; k < bins; ++k) {
        // (k + ½ − B)·ds, as method.md writes it (and the reference computes it): a pose half a cell off the
        // grid then puts both on the same side of every cell boundary.
        const double s = (static_cast<double>(k) + 0.5 - static_cast<double>(behind)) * pc.ds_m;
        p.s[k] = s;
        double sum = 0.0, variance = 0.0;
        int valid = 0;
        bool now = false;
        for (int lane = 0; lane < lanes; ++lane) {  // lanes across the tire, one cell apart
            const double offset = (lane + 0.5) * cfg_.tire_width / lanes - 0.5 * cfg_.tire_width;
            double x, y;
            if (paths.status == PathStatus::Straight) {
                x = paths.direction * s, y = y_w + offset;
            } else {  // rotate the wheel about the ICR by s / r_w in the sense of rotation; offset radially
                if (r_w <= 0.0) continue;
                const double phi = paths.rotation * s / r_w, u = (y_w - paths.icr_y) / r_w, r = r_w + offset;
                x = -std::sin(phi) * u * r, y = paths.icr_y + std::cos(phi) * u * r;
            }
            const double x_o = pose_.x_m + c * x - sn * y, y_o = pose_.y_m + sn * x + c * y;
            const MapCell* cell = map_.at(x_o, y_o);
            if (!cell || cell->observations == 0) continue;
            sum += readout_.set ? above_local_ground(x_o, y_o, cell->height) : cell->height;
            variance += cell->variance, ++valid;
            p.count[k] += cell->points;
            now = now || cell->last_update == frame_;
        }
        if (valid == 0) continue;
        if (k >= behind) ahead += 1, ahead_now += now ? 1 : 0;
        if (p.blocked[k]) continue;  // an obstacle's points are not road
        p.z[k] = sum / valid;
        p.spread[k] = spread_for_variance(variance / (valid * valid), p.count[k]);
    }
    fill_gaps(p.z, pc.ds_m, pc.max_gap_m, &p.blocked);
}

// Into the frame the model was fitted in: its datum (its alignment took its heights to the map's), its vehicle
// axes, its base frame (Lᵀ, L a rotation); then the height above its model, as a single frame's point's.
double TemporalFusion::above_local_ground(double x, double y, double height) const {
    const ReadoutGround& g = readout_;
    const double dx = x - g.pose.x_m, dy = y - g.pose.y_m;
    const double u = g.cos_yaw * dx + g.sin_yaw * dy, v = -g.sin_yaw * dx + g.cos_yaw * dy;
    const double z = height + g.alignment.dot(Eigen::Vector3d(1.0, dx, dy));
    const auto& R = g.L.R;
    return g.model.height(R[0][0] * u + R[1][0] * v + R[2][0] * z, R[0][1] * u + R[1][1] * v + R[2][1] * z,
                          R[0][2] * u + R[1][2] * v + R[2][2] * z);
}

void TemporalFusion::profiles(const WheelPaths& paths, const BlockedBins* blocked, FusionStatus& status,
                              Profile& left, Profile& right) const {
    std::size_t ahead = 0, ahead_now = 0;
    sample(paths, Wheel::Left, blocked ? &blocked->left : nullptr, ahead, ahead_now, left);
    sample(paths, Wheel::Right, blocked ? &blocked->right : nullptr, ahead, ahead_now, right);
    const double total = 2.0 * static_cast<double>(bin_count(cfg_.profile));
    status.coverage = static_cast<double>(ahead) / total;
    status.frame_coverage = static_cast<double>(ahead_now) / total;
    status.frames = fused_;
}

WheelProfiles TemporalFusion::profiles(const WheelPaths& paths, const BlockedBins* blocked,
                                       FusionStatus& status) const {
    WheelProfiles out;
    profiles(paths, blocked, status, out.left, out.right);
    return out;
}

}  // namespace roadpreview
