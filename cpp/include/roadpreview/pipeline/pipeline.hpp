// SPDX-License-Identifier: BSD-3-Clause
// The pipeline: points → ground → wheel paths → obstacles → profiles → roughness, one frame per process() call.
#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <stdexcept>
#include <type_traits>
#include <string>
#include <vector>

#include "roadpreview/core/config.hpp"
#include "roadpreview/core/status.hpp"
#include "roadpreview/fusion/fusion.hpp"
#include "roadpreview/ground/ground.hpp"
#include "roadpreview/io/frame_source.hpp"
#include "roadpreview/obstacles/obstacles.hpp"
#include "roadpreview/paths/path.hpp"
#include "roadpreview/core/points.hpp"
#include "roadpreview/profile/profile.hpp"
#include "roadpreview/roughness/roughness.hpp"

namespace roadpreview {

struct PointCounts {
    std::int64_t input = 0;   ///< rows given
    std::int64_t finite = 0;  ///< rows with finite x, y, z
    std::int64_t roi = 0;     ///< finite rows inside the front region of interest
    std::int64_t ground = 0;  ///< ROI rows classified as ground
};

struct TimingMs {
    double ground = 0.0;  ///< includes the frame transform and ROI crop
    double path = 0.0;
    double profile = 0.0;
    double roughness = 0.0;
    double obstacles = 0.0;  ///< clustering and the wheel-path crossings
    double fusion = 0.0;     ///< moving the map and fusing the frame (sampling the map counts as profile)
    double total = 0.0;
};

/// Why a frame has no profiles (Ok: it has them). to_string gives the text of the output line's `reason`.
enum class FrameStatus {
    Ok,
    NoFinitePoints,   ///< "no finite points": empty, or every row has a NaN or infinite coordinate
    NoRoiPoints,      ///< "no points in the region of interest": none ahead (behind when reversing) to fit ground to
    NoGround,         ///< "no ground"
    TiltedGround,     ///< "no ground within the tilt limit" (kTiltedGround)
    VehicleStopped,   ///< "vehicle stopped": |speed| at or below path.stopped_speed_mps
};

/// The documented text ("vehicle stopped", ...); "" for Ok.
const char* to_string(FrameStatus status) noexcept;

struct Result {
    std::int64_t frame = 0;  ///< 0-based count of process() calls on this estimator
    std::string source;      ///< where the points came from (file name), may be empty
    std::optional<double> timestamp;  ///< s, when the caller knows it
    double speed_mps = 0.0;           ///< the motion the paths were planned from
    double yaw_rate_rps = 0.0;
    PointCounts points;
    GroundMethod ground_method = GroundMethod::Pca;
    std::vector<std::uint8_t> ground_mask;  ///< one entry per input row, 1 = ground
    std::optional<Plane> plane;             ///< base frame; nullopt when no ground was found
    WheelPaths path;
    Profile left, right;
    Roughness vehicle;
    std::optional<std::vector<Cluster>> obstacles;  ///< every cluster (base frame); nullopt: clustering is off
    std::vector<std::int32_t> cluster_labels;        ///< one entry per input row: its cluster's id, −1 for none
    TimingMs timing_ms;
    FrameStatus status = FrameStatus::Ok;  ///< why profiles are empty (to_string: the output line's `reason`)
    /// Where the yaw rate came from ("option", "motion", "imu", "default"), set by the caller; when set, the
    /// output line's `path` is an object for every motion status and carries it (docs/output.md).
    std::string yaw_rate_source;
    std::optional<FusionStatus> fusion;  ///< nullopt when fusion.method is "none" (docs/method.md §7)
    Extrinsics extrinsics;               ///< the sensor's pose the points were moved into the base frame by
    /// Where the extrinsics came from: "given" (sensor_height or extrinsics in the config), "none" (neither:
    /// the points are taken as base-frame points), or the caller's word, e.g. "estimated" (see estimate_mounting).
    std::string mounting_source;
};

/// Runs the pipeline. Reuses its ROI buffer (the frame's one copy of the cloud) and every stage's scratch
/// between frames; not thread-safe — use one Estimator per thread.
///
/// Real time: the overloads taking `Result& out` write into `out` and reuse its capacity (vectors are cleared,
/// not freed), so that a stream of frames into the same `out` allocates nothing once the buffers have grown
/// (tests/cpp/realtime_test.cpp counts). try_process is the same without exceptions: bad input gives a Status
/// with the message process() would have thrown, and `out` is then left unspecified.
class Estimator {
public:
    explicit Estimator(const Config& cfg = Config{});  ///< throws std::invalid_argument on a bad config
    ~Estimator();
    Estimator(Estimator&&) noexcept;
    Estimator& operator=(Estimator&&) noexcept;

    /// speed in m/s (negative when reversing), yaw rate in rad/s (positive turning left).
    /// Throws std::invalid_argument for non-finite speed or yaw rate.
    Result process(PointsView points, double speed_mps, double yaw_rate_rps, const std::string& source = {});
    /// The same with the frame's timestamp (copied to the result) and, optionally, its pose for the fusion.
    Result process(PointsView points, double speed_mps, double yaw_rate_rps, const std::string& source,
                   const FrameMotion& motion);
    /// The same with what the source states about its points' errors (see PointErrors; a `const float*` of range
    /// variances converts to it). A LiDAR frame's beams count only with ProfileConfig::beam_sigma_deg > 0.
    Result process(PointsView points, double speed_mps, double yaw_rate_rps, const std::string& source,
                   const FrameMotion& motion, const PointErrors& errors);
    /// A frame of a FrameSource: its points, source, range variances, error groups and beams (checked: one per point
    /// or none), and its timestamp unless `motion` gives one.
    Result process(const Frame& frame, double speed_mps, double yaw_rate_rps, const FrameMotion& motion = {});

    /// The real-time forms of the above: the result goes into `out`, reusing its buffers.
    void process(PointsView points, double speed_mps, double yaw_rate_rps, Result& out);
    void process(PointsView points, double speed_mps, double yaw_rate_rps, const std::string& source,
                 const FrameMotion& motion, Result& out);
    void process(PointsView points, double speed_mps, double yaw_rate_rps, const std::string& source,
                 const FrameMotion& motion, const PointErrors& errors, Result& out);
    void process(const Frame& frame, double speed_mps, double yaw_rate_rps, const FrameMotion& motion, Result& out);

    /// The real-time forms without exceptions: Ok, or the code and message of what process() would have thrown
    /// (StatusCode::OutOfMemory for std::bad_alloc). Nothing escapes them.
    Status try_process(PointsView points, double speed_mps, double yaw_rate_rps, Result& out) noexcept;
    Status try_process(PointsView points, double speed_mps, double yaw_rate_rps, const std::string& source,
                       const FrameMotion& motion, Result& out) noexcept;
    Status try_process(PointsView points, double speed_mps, double yaw_rate_rps, const std::string& source,
                       const FrameMotion& motion, const PointErrors& errors, Result& out) noexcept;
    Status try_process(const Frame& frame, double speed_mps, double yaw_rate_rps, const FrameMotion& motion,
                       Result& out) noexcept;

    /// Forgets the fused map, the pose and the clock (the frame counter keeps counting).
    void reset();

    /// Any row-major float Eigen matrix, map or ref with 3 or more columns (N×3, N×4 KITTI), read in place.
    template <typename Derived>
    Result process(const Eigen::DenseBase<Derived>& points, double speed_mps, double yaw_rate_rps,
                   const std::string& source = {}, const FrameMotion& motion = {}) {
        static_assert(std::is_same_v<typename Derived::Scalar, float>, "points must be float32");
        static_assert(Derived::IsRowMajor || Derived::ColsAtCompileTime == 1, "points must be row-major");
        if (points.cols() < 3) throw std::invalid_argument("points need at least 3 columns (x, y, z)");
        const auto& m = points.derived();
        return process(points_view(m.data(), m.rows(), m.outerStride()), speed_mps, yaw_rate_rps, source, motion);
    }

    const Config& config() const;
    /// The fused map and pose; nullptr when fusion.method is "none".
    const TemporalFusion* fusion() const;
    /// Fuses height samples (odometry frame; e.g. point range sensors') into the map, so the next frame's
    /// profiles carry them. Throws std::invalid_argument when fusion.method is "none". Returns the cells updated.
    std::size_t fuse_samples(const std::vector<MapSample>& samples);

private:
    struct Impl;
    std::unique_ptr<Impl> impl_;
};

/// One output line (JSON object, no newline) as documented in docs/output.md.
std::string result_to_json(const Result& r);

class ProfileReadout;  // roadpreview/route/readout.hpp

/// What an output line may leave out, restate or add.
struct LineOptions {
    std::optional<std::int64_t> frame;  ///< the frame's number instead of the estimator's count (a recording's index)
    bool timing = true;                 ///< false: no `timing_ms` and no `fusion.time_ms` (lines that must repeat)
    const ProfileReadout* readout = nullptr;  ///< adds `readout`: its state after this frame was added
};

/// The output line with `options` applied.
std::string result_to_json(const Result& r, const LineOptions& options);

/// A wheel's roughness (§4) and IRI (§6) from its profile, as the pipeline rates each wheel.
void rate_profile(Profile& p, const Config& cfg);

}  // namespace roadpreview
