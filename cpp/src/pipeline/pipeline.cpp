// SPDX-License-Identifier: BSD-3-Clause
#include "roadpreview/pipeline/pipeline.hpp"

#include <chrono>
#include <limits>
#include <stdexcept>

#include "roadpreview/core/frames.hpp"
#include "ground/ground_pcl.hpp"
#include "obstacles/obstacles_pcl.hpp"
#include "core/roi_cloud.hpp"
#include "core/stopwatch.hpp"

namespace roadpreview {
namespace {


// Why no profile can be built for this frame, or empty when one can. A fused map that holds data stands in
// for a frame without ground (a dropout, a blinded sensor): the profiles are read from it.
std::string blocking_reason(const Result& r, const GroundFit& ground, bool map_has_data) {
    if (!map_has_data && r.points.finite == 0) return "no finite points";
    if (!map_has_data && !r.plane) return ground.reason.empty() ? "no ground" : ground.reason;
    if (r.path.status == PathStatus::Stopped) return "vehicle stopped";
    return {};
}

void mark_empty(Profile& p, const Config& cfg, const std::string& reason) {
    p.ds = cfg.profile.ds_m;
    p.s0 = 0.5 * cfg.profile.ds_m;
    p.roughness.reason = reason;
    p.roughness.iri.reason = reason;
    if (cfg.obstacles.enabled) p.obstacles.emplace();
}

// Per-ROI-point values written to their input rows (`rows`, one per input row, already holding the value for
// the rows outside the ROI). The ROI is visited in input order, so the rows are written in ascending order.
template <class T>
void to_input_rows(const RoiCloud& roi, const std::vector<T>& of_roi_point, std::vector<T>& rows) {
    if (of_roi_point.size() != roi.input_order.size())
        throw std::logic_error("a stage gave " + std::to_string(of_roi_point.size()) + " values for " +
                               std::to_string(roi.input_order.size()) + " ROI points");
    for (const std::int32_t k : roi.input_order) {
        const auto at = static_cast<std::size_t>(k);
        rows[static_cast<std::size_t>(roi.input_index[at])] = of_roi_point[at];
    }
}

// Clusters of the non-ground ROI points (none without a ground plane), labelled per input row.
Clustering cluster_frame(const RoiCloud& roi, const GroundFit& ground, const ObstaclesConfig& cfg, Result& r) {
    Clustering clustering;
    if (r.plane) clustering = find_obstacles(roi, ground.mask, *r.plane, cfg);
    if (!clustering.label.empty()) to_input_rows(roi, clustering.label, r.cluster_labels);
    r.obstacles = clustering.clusters;
    return clustering;
}

// The obstacles in each wheel's path and the profile bins they block.
struct PathCrossings {
    std::vector<PathObstacle> left, right;
    BlockedBins blocked;
};

PathCrossings cross_paths(const RoiCloud& roi, const Clustering& clustering, const Result& r, const Levelling& L,
                          const Config& cfg) {
    PathCrossings out;
    auto cross = [&](Wheel w, std::vector<PathObstacle>& obstacles, std::vector<std::uint8_t>& blocked) {
        obstacles = wheel_obstacles(roi.view(), clustering, *r.plane, L, r.path, w, cfg.tire_width,
                                    cfg.profile.preview_length_m, cfg.obstacles);
        blocked = blocked_bins(obstacles, bin_count(cfg.profile), cfg.profile.ds_m, cfg.obstacles.safety_margin_m);
    };
    cross(Wheel::Left, out.left, out.blocked.left);
    cross(Wheel::Right, out.right, out.blocked.right);
    return out;
}

}  // namespace

struct Estimator::Impl {
    Config cfg;
    RigidTransform sensor_to_base;
    RoiCloud roi;  // reused across frames
    std::int64_t frames = 0;
    std::optional<TemporalFusion> fusion;  // only with fusion.method other than "none"
};

Estimator::Estimator(const Config& cfg) : impl_(std::make_unique<Impl>()) {
    validate(cfg);
    impl_->cfg = cfg;
    impl_->sensor_to_base = to_rigid_transform(effective_extrinsics(cfg));
    if (cfg.fusion.method != FusionMethod::None) impl_->fusion.emplace(cfg);
}

void Estimator::reset() {
    if (impl_->fusion) impl_->fusion->reset();
}

Estimator::~Estimator() = default;
Estimator::Estimator(Estimator&&) noexcept = default;
Estimator& Estimator::operator=(Estimator&&) noexcept = default;

const Config& Estimator::config() const { return impl_->cfg; }

const TemporalFusion* Estimator::fusion() const { return impl_->fusion ? &*impl_->fusion : nullptr; }

std::size_t Estimator::fuse_samples(const std::vector<MapSample>& samples) {
    if (!impl_->fusion) throw std::invalid_argument("fusing samples needs a fusion map (fusion.method is \"none\")");
    return impl_->fusion->fuse_samples(samples);
}

void rate_profile(Profile& p, const Config& cfg) {
    p.roughness = analyze_roughness(p, cfg.roughness);
    p.roughness.iri = wheel_iri(p, p.roughness, cfg.iri);
}

Result Estimator::process(PointsView points, double speed_mps, double yaw_rate_rps, const std::string& source) {
    return process(points, speed_mps, yaw_rate_rps, source, FrameMotion{});
}

Result Estimator::process(const Frame& frame, double speed_mps, double yaw_rate_rps, const FrameMotion& motion) {
    const auto rows = static_cast<std::size_t>(frame.points.rows());
    if (!frame.range_variances.empty() && frame.range_variances.size() != rows)
        throw std::invalid_argument(frame.source + ": " + std::to_string(frame.range_variances.size()) +
                                    " range variances for " + std::to_string(rows) + " points");
    return process(points_view(frame.points.data(), frame.points.rows(), 4), speed_mps, yaw_rate_rps, frame.source, motion,
                   frame.range_variances.empty() ? nullptr : frame.range_variances.data());
}

Result Estimator::process(PointsView points, double speed_mps, double yaw_rate_rps, const std::string& source,
                          const FrameMotion& motion) {
    return process(points, speed_mps, yaw_rate_rps, source, motion, nullptr);
}

Result Estimator::process(PointsView points, double speed_mps, double yaw_rate_rps, const std::string& source,
                          const FrameMotion& motion, const float* range_variances_m2) {
    const Config& cfg = impl_->cfg;
    if (points.rows() > std::numeric_limits<std::int32_t>::max())
        throw std::invalid_argument("too many points in one frame: " + std::to_string(points.rows()));
    auto mark = Clock::now();
    const auto start = mark;
    Result r;
    r.path = plan_paths(speed_mps, yaw_rate_rps, cfg.track_width, cfg.path);  // validates the motion first
    r.timing_ms.path = ms_since(mark);
    r.frame = impl_->frames++;
    r.source = source;
    r.speed_mps = speed_mps;
    r.yaw_rate_rps = yaw_rate_rps;
    r.ground_method = cfg.ground.method;
    r.timestamp = motion.timestamp_s;
    r.extrinsics = effective_extrinsics(cfg);
    r.mounting_source = cfg.sensor_height || cfg.extrinsics ? "given" : "none";
    TemporalFusion* fusion = impl_->fusion ? &*impl_->fusion : nullptr;
    if (fusion) fusion->advance(speed_mps, yaw_rate_rps, motion, r.fusion.emplace());
    r.timing_ms.fusion = ms_since(mark);

    RoiCloud& roi = impl_->roi;
    crop_roi(points, impl_->sensor_to_base, roi_facing(cfg.ground, r.path.direction), roi);  // behind when reversing
    roi_height_variances(range_variances_m2, impl_->sensor_to_base, roi);
    const std::vector<float>* height_variances = roi.height_variance.empty() ? nullptr : &roi.height_variance;
    const GroundFit ground = fit_ground(roi, cfg.ground);
    r.points = {points.rows(), roi.finite, roi.size(), ground.count};
    r.plane = ground.plane;
    r.ground_mask.assign(static_cast<std::size_t>(points.rows()), 0);
    to_input_rows(roi, ground.mask, r.ground_mask);
    r.timing_ms.ground = ms_since(mark);

    r.cluster_labels.assign(static_cast<std::size_t>(points.rows()), -1);
    Clustering clustering;
    if (cfg.obstacles.enabled) clustering = cluster_frame(roi, ground, cfg.obstacles, r);
    r.timing_ms.obstacles = ms_since(mark);

    const Levelling L = levelling_for(cfg.profile.level && r.plane ? &*r.plane : nullptr);
    // Stopped: the same view again and again is not new evidence, so the map holds.
    if (fusion && r.plane && r.path.status != PathStatus::Stopped)
        fusion->fuse(roi.view(), ground.mask, L, height_variances);
    r.timing_ms.fusion += ms_since(mark);
    r.reason = blocking_reason(r, ground, fusion && fusion->frames() > 0);
    if (!r.reason.empty()) {
        for (Profile* p : {&r.left, &r.right}) mark_empty(*p, cfg, r.reason);
        r.vehicle.reason = r.reason;
        r.vehicle.iri.reason = r.reason;
        r.timing_ms.total = std::chrono::duration<double, std::milli>(Clock::now() - start).count();
        return r;
    }
    std::optional<PathCrossings> crossings;  // none without a plane (profiles from the map): nothing in the way
    if (cfg.obstacles.enabled && r.plane) crossings = cross_paths(roi, clustering, r, L, cfg);
    r.timing_ms.obstacles += ms_since(mark);

    const BlockedBins* blocked = crossings ? &crossings->blocked : nullptr;
    // Levelling by the local ground model (method.md §3); empty: by the one plane.
    const std::vector<double> local_z = cfg.profile.level && cfg.profile.level_local && r.plane
                                            ? local_ground_heights(roi.view(), ground.mask, *r.plane,
                                                                   cfg.profile.level_band_m, r.path)
                                            : std::vector<double>{};
    WheelProfiles wheels = fusion ? fusion->profiles(r.path, blocked, *r.fusion)
                                  : build_profiles(roi.view(), ground.mask, L, r.path, cfg.tire_width, cfg.profile, blocked,
                                                   local_z.empty() ? nullptr : &local_z, height_variances);
    r.left = std::move(wheels.left);
    r.right = std::move(wheels.right);
    if (cfg.obstacles.enabled) {
        r.left.obstacles = crossings ? std::move(crossings->left) : std::vector<PathObstacle>{};
        r.right.obstacles = crossings ? std::move(crossings->right) : std::vector<PathObstacle>{};
    }
    r.timing_ms.profile = ms_since(mark);

    for (Profile* p : {&r.left, &r.right}) rate_profile(*p, cfg);
    r.vehicle = vehicle_roughness(r.left, r.right, cfg.roughness);
    reconcile_vehicle(r.vehicle, r.left.roughness, r.right.roughness);
    r.vehicle.iri = vehicle_iri(r.left.roughness.iri, r.right.roughness.iri);
    r.timing_ms.roughness = ms_since(mark);
    r.timing_ms.total = std::chrono::duration<double, std::milli>(Clock::now() - start).count();
    return r;
}

}  // namespace roadpreview
