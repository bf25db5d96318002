// SPDX-License-Identifier: BSD-3-Clause
#include "roadpreview/pipeline/pipeline.hpp"

#include <chrono>
#include <cmath>
#include <limits>
#include <stdexcept>

#include "roadpreview/core/frames.hpp"
#include "ground/ground_pcl.hpp"
#include "obstacles/obstacles_pcl.hpp"
#include "core/parallel.hpp"
#include "core/roi_cloud.hpp"
#include "core/stopwatch.hpp"
#include "core/without_exceptions.hpp"
#include "profile/profile_scratch.hpp"
#include "roughness/roughness_scratch.hpp"

namespace roadpreview {
namespace {


// Why no profile can be built for this frame, or Ok when one can. A fused map that holds data stands in
// for a frame without ground (a dropout, a blinded sensor): the profiles are read from it.
FrameStatus blocking_status(const Result& r, const GroundFit& ground, bool map_has_data) {
    if (!map_has_data && r.points.finite == 0) return FrameStatus::NoFinitePoints;
    if (!map_has_data && r.points.roi == 0) return FrameStatus::NoRoiPoints;  // the sensor looks elsewhere
    if (!map_has_data && !r.plane) return ground.status == GroundStatus::TiltedGround ? FrameStatus::TiltedGround : FrameStatus::NoGround;
    if (r.path.status == PathStatus::Stopped) return FrameStatus::VehicleStopped;
    return FrameStatus::Ok;
}

// Roughness and IRI declined for the frame's status, with its text.
void mark_declined(Roughness& r, FrameStatus status) {
    clear(r);
    const auto set = [&](RoughnessReason roughness, IriReason iri) { r.reason = roughness, r.iri.reason = iri; };
    switch (status) {
        case FrameStatus::Ok: break;
        case FrameStatus::NoFinitePoints: set(RoughnessReason::NoFinitePoints, IriReason::NoFinitePoints); break;
        case FrameStatus::NoRoiPoints: set(RoughnessReason::NoRoiPoints, IriReason::NoRoiPoints); break;
        case FrameStatus::NoGround: set(RoughnessReason::NoGround, IriReason::NoGround); break;
        case FrameStatus::TiltedGround: set(RoughnessReason::TiltedGround, IriReason::TiltedGround); break;
        case FrameStatus::VehicleStopped: set(RoughnessReason::VehicleStopped, IriReason::VehicleStopped); break;
    }
}

// A profile without bins, declined for the frame's `status`; its buffers kept.
void mark_empty(Profile& p, const Config& cfg, FrameStatus status) {
    for (auto* v : {&p.s, &p.z, &p.spread}) v->clear();
    p.count.clear();
    p.blocked.clear();
    p.ds = cfg.profile.ds_m;
    p.s0 = 0.5 * cfg.profile.ds_m;
    mark_declined(p.roughness, status);
    if (!cfg.obstacles.enabled) p.obstacles.reset();
    else if (p.obstacles) p.obstacles->clear();
    else p.obstacles.emplace();
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

// The obstacles in each wheel's path and the profile bins they block.
struct PathCrossings {
    std::vector<PathObstacle> left, right;
    BlockedBins blocked;
};

void cross_paths(const RoiCloud& roi, const Clustering& clustering, const Result& r, const Levelling& L,
                 const Config& cfg, PathCrossings& out) {
    auto cross = [&](Wheel w, std::vector<PathObstacle>& obstacles, std::vector<std::uint8_t>& blocked) {
        wheel_obstacles(roi.view(), clustering, *r.plane, L, r.path, w, cfg.tire_width, cfg.profile.preview_length_m,
                        cfg.obstacles, obstacles);
        blocked_bins(obstacles, bin_count(cfg.profile), cfg.profile.ds_m, cfg.obstacles.safety_margin_m, blocked);
    };
    cross(Wheel::Left, out.left, out.blocked.left);
    cross(Wheel::Right, out.right, out.blocked.right);
}

}  // namespace

struct Estimator::Impl {
    Config cfg;
    int threads = 1;  // cfg.threads, at most the cores the process may use
    RigidTransform sensor_to_base;
    GroundConfig roi_ahead, roi_behind;  // the region of interest driving forward and reversing
    BeamErrors beam_errors;  // the LiDAR beams' elevation σ, where counted
    RoiCloud roi;  // reused across frames
    std::int64_t frames = 0;
    std::size_t bins = 0;  // of a profile: its largest stretch
    std::optional<TemporalFusion> fusion;  // only with fusion.method other than "none"
    // Per-stage scratch, kept so that a stream of frames allocates nothing once the buffers have grown.
    GroundScratch ground_scratch;
    GroundFit ground;
    ObstacleScratch obstacle_scratch;
    Clustering clustering;
    PathCrossings crossings;
    ProfileScratch profile_scratch;
    RoughnessScratch roughness_scratch;

    void run(PointsView points, double speed_mps, double yaw_rate_rps, const std::string& source,
             const FrameMotion& motion, const PointErrors& errors, Result& r);
    void start_frame(double speed_mps, double yaw_rate_rps, const std::string& source, const FrameMotion& motion,
                     Result& r);
    void find_ground(PointsView points, const PointErrors& errors, Result& r);
    void find_obstacles_in(Result& r);
    void collect_corridors(const Result& r, const Levelling& L, const std::vector<float>* height_variances,
                           const std::vector<std::int32_t>* error_groups);
    void fuse_frame(const Result& r, const Levelling& L, const std::vector<float>* height_variances,
                    const std::vector<std::int32_t>* error_groups);
    void build_wheel_profiles(Result& r);
    void rate(Result& r);
};

Estimator::Estimator(const Config& cfg) : impl_(std::make_unique<Impl>()) {
    validate(cfg);
    impl_->cfg = cfg;
    impl_->threads = usable_threads(cfg.threads);
    impl_->sensor_to_base = to_rigid_transform(effective_extrinsics(cfg));
    impl_->roi_ahead = roi_facing(cfg.ground, 1.0);
    impl_->roi_behind = roi_facing(cfg.ground, -1.0);
    impl_->beam_errors = BeamErrors(cfg.profile);
    impl_->bins = bin_count(cfg.profile) + static_cast<std::size_t>(std::ceil(cfg.fusion.behind_m / cfg.profile.ds_m));
    impl_->roughness_scratch.plan_ffts(impl_->bins);
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

void Estimator::Impl::start_frame(double speed_mps, double yaw_rate_rps, const std::string& source,
                                  const FrameMotion& motion, Result& r) {
    r.path = plan_paths(speed_mps, yaw_rate_rps, cfg.track_width, cfg.path);
    r.frame = frames++;
    r.source.assign(source);
    r.speed_mps = speed_mps;
    r.yaw_rate_rps = yaw_rate_rps;
    r.ground_method = cfg.ground.method;
    r.timestamp = motion.timestamp_s;
    r.extrinsics = effective_extrinsics(cfg);
    r.mounting_source.assign(cfg.sensor_height || cfg.extrinsics ? "given" : "none");
    r.yaw_rate_source.clear();
    r.status = FrameStatus::Ok;
}

void Estimator::Impl::find_ground(PointsView points, const PointErrors& errors, Result& r) {
    crop_roi(points, sensor_to_base, r.path.direction < 0.0 ? roi_behind : roi_ahead, roi, threads);  // or reversing
    roi_point_errors(errors, sensor_to_base, beam_errors, roi);
    fit_ground(roi, cfg.ground, ground_scratch, ground, threads);
    r.points = {points.rows(), roi.finite, roi.size(), ground.count};
    r.plane = ground.plane;
    r.ground_mask.assign(static_cast<std::size_t>(points.rows()), 0);
    to_input_rows(roi, ground.mask, r.ground_mask);
}

// Clusters of the non-ground ROI points (none without a ground plane), labelled per input row.
void Estimator::Impl::find_obstacles_in(Result& r) {
    clustering.clusters.clear();
    clustering.label.clear();
    if (r.plane) find_obstacles(roi, ground.mask, *r.plane, cfg.obstacles, obstacle_scratch, clustering);
    if (!clustering.label.empty()) to_input_rows(roi, clustering.label, r.cluster_labels);
    if (!r.obstacles) r.obstacles.emplace();
    r.obstacles->assign(clustering.clusters.begin(), clustering.clusters.end());
}

// The first half of the profile stage without a map: each wheel's corridor points at their heights, levelled by the
// local ground model (method.md §3) or, without it, by the one plane.
void Estimator::Impl::collect_corridors(const Result& r, const Levelling& L, const std::vector<float>* height_variances,
                                        const std::vector<std::int32_t>* error_groups) {
    const bool local = cfg.profile.level && cfg.profile.level_local;
    if (local) fit_local_ground(roi.view(), ground.mask, *r.plane, cfg.profile.level_band_m, r.path, profile_scratch);
    collect_profile_hits(roi.view(), ground.mask, L, r.path, cfg.tire_width, cfg.profile, local, height_variances,
                         error_groups, profile_scratch);
}

// The ground points into the map, with the local ground model the map's profiles are read above (method.md §7).
void Estimator::Impl::fuse_frame(const Result& r, const Levelling& L, const std::vector<float>* height_variances,
                                 const std::vector<std::int32_t>* error_groups) {
    const bool local = cfg.profile.level && cfg.profile.level_local;
    if (local) fit_local_ground(roi.view(), ground.mask, *r.plane, cfg.profile.level_band_m, r.path, profile_scratch);
    fusion->fuse(roi.view(), ground.mask, L, height_variances, error_groups, local ? &profile_scratch.ground : nullptr);
}

// The second half: the profiles from the map, or from the corridor points, outside the bins obstacles block.
void Estimator::Impl::build_wheel_profiles(Result& r) {
    const bool crossed = cfg.obstacles.enabled && r.plane;  // without a plane (profiles from the map): none
    const BlockedBins* blocked = crossed ? &crossings.blocked : nullptr;
    if (fusion) fusion->profiles(r.path, blocked, *r.fusion, r.left, r.right);
    else bin_profile_hits(cfg.profile, blocked, profile_scratch, r.left, r.right);
    if (!cfg.obstacles.enabled) {  // null, not empty, also in a Result an estimator with obstacles filled before
        r.left.obstacles.reset();
        r.right.obstacles.reset();
        return;
    }
    for (auto [p, in_path] : {std::pair{&r.left, &crossings.left}, std::pair{&r.right, &crossings.right}}) {
        if (!p->obstacles) p->obstacles.emplace();
        if (crossed)
            p->obstacles->assign(in_path->begin(), in_path->end());
        else
            p->obstacles->clear();
    }
}

// Room for the longest fusion reset text (docs/output.md), so that a text longer than any before does not allocate.
constexpr std::size_t kReasonCapacity = 64;

// The roughness results' vectors at their largest (a stretch of every bin), so that a longer stretch than any
// before does not grow them; a no-op once they are.
void reserve_roughness(Roughness& r, std::size_t bins) {
    for (auto* v : {&r.spectrum.n, &r.spectrum.psd, &r.noise_psd}) v->reserve(bins / 2 + 1);
    r.octave_centers.reserve(9);  // ISO 8608's octaves 2^−6 … 2^2 cycles/m
    r.octave_gd.reserve(9);
}

void Estimator::Impl::rate(Result& r) {
    for (Profile* p : {&r.left, &r.right}) {
        analyze_roughness(*p, cfg.roughness, roughness_scratch, p->roughness);
        wheel_iri(*p, p->roughness, cfg.iri, roughness_scratch, p->roughness.iri);
    }
    vehicle_roughness(r.left, r.right, cfg.roughness, roughness_scratch, r.vehicle);
    reconcile_vehicle(r.vehicle, r.left.roughness, r.right.roughness);
    vehicle_iri(r.left.roughness.iri, r.right.roughness.iri, r.vehicle.iri);
}

void Estimator::Impl::run(PointsView points, double speed_mps, double yaw_rate_rps, const std::string& source,
                          const FrameMotion& motion, const PointErrors& errors, Result& r) {
    auto mark = Clock::now();
    const auto start = mark;
    r.timing_ms = {};
    for (Roughness* x : {&r.left.roughness, &r.right.roughness, &r.vehicle}) reserve_roughness(*x, bins);
    start_frame(speed_mps, yaw_rate_rps, source, motion, r);
    r.timing_ms.path = ms_since(mark);
    if (fusion) {
        if (!r.fusion) r.fusion.emplace();
        r.fusion->reset.clear();
        r.fusion->reset.reserve(kReasonCapacity);
        r.fusion->coverage = r.fusion->frame_coverage = 0.0;
        fusion->advance(speed_mps, yaw_rate_rps, motion, *r.fusion);
    } else {
        r.fusion.reset();
    }
    r.timing_ms.fusion = ms_since(mark);

    find_ground(points, errors, r);
    const std::vector<float>* height_variances = roi.height_variance.empty() ? nullptr : &roi.height_variance;
    const std::vector<std::int32_t>* error_groups = roi.error_group.empty() ? nullptr : &roi.error_group;
    r.timing_ms.ground = ms_since(mark);

    const Levelling L = levelling_for(cfg.profile.level && r.plane ? &*r.plane : nullptr);
    // The obstacles, and the ground's way into the profiles (the map, or each wheel's corridor points): neither
    // needs the other, so they run side by side when the frame may use two threads. Stopped: the same view again
    // and again is not new evidence, so the map holds.
    const bool moving = r.path.status != PathStatus::Stopped;
    double ground_side_ms = 0.0;
    run_both(threads > 1, [&] {
        auto started = Clock::now();
        r.cluster_labels.assign(static_cast<std::size_t>(points.rows()), -1);
        if (cfg.obstacles.enabled) find_obstacles_in(r);
        else r.obstacles.reset();
        r.timing_ms.obstacles = ms_since(started);
    }, [&] {
        auto started = Clock::now();
        if (fusion && r.plane && moving) fuse_frame(r, L, height_variances, error_groups);
        if (!fusion && r.plane && moving) collect_corridors(r, L, height_variances, error_groups);
        ground_side_ms = ms_since(started);
    });
    (fusion ? r.timing_ms.fusion : r.timing_ms.profile) += ground_side_ms;
    mark = Clock::now();
    r.status = blocking_status(r, ground, fusion && fusion->frames() > 0);
    if (r.status != FrameStatus::Ok) {
        for (Profile* p : {&r.left, &r.right}) mark_empty(*p, cfg, r.status);
        mark_declined(r.vehicle, r.status);
    } else {
        if (cfg.obstacles.enabled && r.plane) cross_paths(roi, clustering, r, L, cfg, crossings);
        r.timing_ms.obstacles += ms_since(mark);
        build_wheel_profiles(r);
        r.timing_ms.profile += ms_since(mark);
        rate(r);
        r.timing_ms.roughness = ms_since(mark);
    }
    r.timing_ms.total = std::chrono::duration<double, std::milli>(Clock::now() - start).count();
}

const char* to_string(FrameStatus status) noexcept {
    switch (status) {
        case FrameStatus::Ok: return "";
        // One text per status: the one its profiles' roughness reason gives (mark_declined).
        case FrameStatus::NoFinitePoints: return to_string(RoughnessReason::NoFinitePoints);
        case FrameStatus::NoRoiPoints: return to_string(RoughnessReason::NoRoiPoints);
        case FrameStatus::NoGround: return to_string(RoughnessReason::NoGround);
        case FrameStatus::TiltedGround: return to_string(RoughnessReason::TiltedGround);
        case FrameStatus::VehicleStopped: return to_string(RoughnessReason::VehicleStopped);
    }
    return "?";
}

namespace {

// What process() refuses, as a Status (try_process returns it, process() throws its message).
Status check_input(PointsView points, double speed_mps, double yaw_rate_rps, const FrameMotion& motion,
                   const PointErrors& errors) noexcept {
    // A view made by hand (points_view) can claim what no buffer holds: rows overlapping or read backwards.
    if (points.rows() < 0)
        return Status::error(StatusCode::InvalidArgument, "points: a negative row count (%lld)",
                             static_cast<long long>(points.rows()));
    if (points.rows() > 0 && (points.outerStride() < 3 || points.data() == nullptr))
        return Status::error(StatusCode::InvalidArgument,
                             "points: each row must hold x, y, z, so its stride must be at least 3 floats (got %lld%s)",
                             static_cast<long long>(points.outerStride()), points.data() ? "" : ", and no data");
    if (points.rows() > std::numeric_limits<std::int32_t>::max())
        return Status::error(StatusCode::InvalidArgument, "too many points in one frame: %lld",
                             static_cast<long long>(points.rows()));
    if (Status s = check_motion(speed_mps, yaw_rate_rps); !s) return s;
    // A point's stated variance weighs it: NaN, infinite or negative would make it exact (or the bin's noise NaN).
    if (errors.range_variances_m2)
        for (Eigen::Index i = 0; i < points.rows(); ++i) {
            const double v = errors.range_variances_m2[i];
            if (!(v >= 0.0 && v < std::numeric_limits<double>::infinity()) && points.row(i).allFinite())
                return Status::error(StatusCode::InvalidArgument,
                                     "range variance of point %lld must be finite and >= 0 m², got %g",
                                     static_cast<long long>(i), v);
        }
    return check_frame_motion(motion);
}

Status check_frame(const Frame& frame) noexcept {
    const auto rows = static_cast<std::size_t>(frame.points.rows());
    if (!frame.range_variances.empty() && frame.range_variances.size() != rows)
        return Status::error(StatusCode::InvalidArgument, "%s: %zu range variances for %zu points",
                             frame.source.c_str(), frame.range_variances.size(), rows);
    if (!frame.error_groups.empty() && frame.error_groups.size() != rows)
        return Status::error(StatusCode::InvalidArgument, "%s: %zu error groups for %zu points",
                             frame.source.c_str(), frame.error_groups.size(), rows);
    if (!frame.beams.empty() && frame.beams.size() != rows)
        return Status::error(StatusCode::InvalidArgument, "%s: %zu beams for %zu points", frame.source.c_str(),
                             frame.beams.size(), rows);
    return {};
}

void throw_unless_ok(const Status& s) {
    if (!s) throw std::invalid_argument(s.message());
}

PointErrors errors_of(const Frame& frame) {
    return {frame.range_variances.empty() ? nullptr : frame.range_variances.data(),
            frame.error_groups.empty() ? nullptr : frame.error_groups.data(),
            frame.beams.empty() ? nullptr : frame.beams.data()};
}

PointsView points_of(const Frame& frame) { return points_view(frame.points.data(), frame.points.rows(), 4); }

// The motion a frame is processed with: the frame's own timestamp unless `given` has one (the fusion spaces frames
// by their timestamps; without any, by 1/fusion.frame_rate_hz).
FrameMotion motion_of(const Frame& frame, const FrameMotion& given) {
    FrameMotion m = given;
    if (!m.timestamp_s) m.timestamp_s = frame.timestamp;
    return m;
}

}  // namespace

Result Estimator::process(PointsView points, double speed_mps, double yaw_rate_rps, const std::string& source) {
    return process(points, speed_mps, yaw_rate_rps, source, FrameMotion{});
}

Result Estimator::process(const Frame& frame, double speed_mps, double yaw_rate_rps, const FrameMotion& motion) {
    Result r;
    process(frame, speed_mps, yaw_rate_rps, motion, r);
    return r;
}

Result Estimator::process(PointsView points, double speed_mps, double yaw_rate_rps, const std::string& source,
                          const FrameMotion& motion) {
    return process(points, speed_mps, yaw_rate_rps, source, motion, nullptr);
}

Result Estimator::process(PointsView points, double speed_mps, double yaw_rate_rps, const std::string& source,
                          const FrameMotion& motion, const PointErrors& errors) {
    Result r;
    process(points, speed_mps, yaw_rate_rps, source, motion, errors, r);
    return r;
}

void Estimator::process(PointsView points, double speed_mps, double yaw_rate_rps, Result& out) {
    process(points, speed_mps, yaw_rate_rps, std::string(), FrameMotion{}, nullptr, out);
}

void Estimator::process(PointsView points, double speed_mps, double yaw_rate_rps, const std::string& source,
                        const FrameMotion& motion, Result& out) {
    process(points, speed_mps, yaw_rate_rps, source, motion, nullptr, out);
}

void Estimator::process(const Frame& frame, double speed_mps, double yaw_rate_rps, const FrameMotion& motion,
                        Result& out) {
    throw_unless_ok(check_frame(frame));
    process(points_of(frame), speed_mps, yaw_rate_rps, frame.source, motion_of(frame, motion), errors_of(frame), out);
}

void Estimator::process(PointsView points, double speed_mps, double yaw_rate_rps, const std::string& source,
                        const FrameMotion& motion, const PointErrors& errors, Result& out) {
    throw_unless_ok(check_input(points, speed_mps, yaw_rate_rps, motion, errors));
    impl_->run(points, speed_mps, yaw_rate_rps, source, motion, errors, out);
}

Status Estimator::try_process(PointsView points, double speed_mps, double yaw_rate_rps, Result& out) noexcept {
    static const std::string no_source;
    return try_process(points, speed_mps, yaw_rate_rps, no_source, FrameMotion{}, nullptr, out);
}

Status Estimator::try_process(PointsView points, double speed_mps, double yaw_rate_rps, const std::string& source,
                              const FrameMotion& motion, Result& out) noexcept {
    return try_process(points, speed_mps, yaw_rate_rps, source, motion, nullptr, out);
}

Status Estimator::try_process(const Frame& frame, double speed_mps, double yaw_rate_rps, const FrameMotion& motion,
                              Result& out) noexcept {
    Status s = check_frame(frame);
    if (!s) return s;
    return try_process(points_of(frame), speed_mps, yaw_rate_rps, frame.source, motion_of(frame, motion),
                       errors_of(frame), out);
}

Status Estimator::try_process(PointsView points, double speed_mps, double yaw_rate_rps, const std::string& source,
                              const FrameMotion& motion, const PointErrors& errors, Result& out) noexcept {
    Status s = check_input(points, speed_mps, yaw_rate_rps, motion, errors);
    if (!s) return s;
    return without_exceptions(
        [&] { impl_->run(points, speed_mps, yaw_rate_rps, source, motion, errors, out); });
}

}  // namespace roadpreview
