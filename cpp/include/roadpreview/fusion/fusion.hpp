// SPDX-License-Identifier: BSD-3-Clause
// Temporal fusion (docs/method.md §7): a rolling elevation map in a local odometry frame that fuses the
// levelled ground points of every frame, and the wheel-path profiles sampled from it.
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "roadpreview/core/config.hpp"
#include "roadpreview/paths/path.hpp"
#include "roadpreview/core/points.hpp"
#include "roadpreview/core/status.hpp"
#include "roadpreview/profile/profile.hpp"
#include "roadpreview/roughness/support.hpp"

namespace roadpreview {

/// Planar pose of the base frame in the odometry frame (m, m, rad; yaw counter-clockwise from odometry x).
struct Pose2 {
    double x_m = 0.0;
    double y_m = 0.0;
    double yaw_rad = 0.0;
};

/// What the caller knows about a frame's time and place; both optional.
struct FrameMotion {
    std::optional<double> timestamp_s;  ///< s; frames without one are 1/fusion.frame_rate_hz apart
    std::optional<Pose2> pose;          ///< given pose (e.g. from a KITTI poses file); else integrated
};

/// A given pose further than this from the odometry frame's origin (100,000 km; poses in millimetres?) is refused:
/// the fused map's cell indices would no longer hold it.
constexpr double kMaxPoseM = 1e8;
/// A given heading beyond this many radians (1,600 turns, unwrapped) is no heading: its cosine is noise.
constexpr double kMaxPoseYawRad = 1e4;

/// A timestamp that is not finite, a pose not finite or beyond ±kMaxPoseM (±kMaxPoseYawRad):
/// StatusCode::InvalidArgument.
Status check_frame_motion(const FrameMotion& motion) noexcept;

/// Rigid planar motion at constant speed and yaw rate for dt seconds (an arc; a line when ω·dt = 0).
Pose2 integrate_motion(const Pose2& pose, double speed_mps, double yaw_rate_rps, double dt_s);

/// Pose of a 3×4 row-major [R | t] matrix (KITTI poses) seen from above: t's x, y and the heading of R's x axis.
Pose2 pose_from_matrix(const double (&m)[12]);

/// One planar pose per line of a KITTI poses file (12 numbers, a 3×4 row-major [R | t] each); throws
/// std::runtime_error naming the file and line for a line that is not 12 finite numbers.
std::vector<Pose2> read_kitti_poses(const std::string& path);

/// A height sample in the odometry frame with its variance, e.g. a point range sensor's (docs/method.md §11).
struct MapSample {
    double x_m = 0.0, y_m = 0.0;  ///< odometry frame
    double z_m = 0.0;             ///< height on the map's datum (the road at rest below the vehicle)
    double variance_m2 = 0.0;     ///< of z_m
};

struct MapCell {
    float height = 0.0f;           ///< m, fused height (levelled frames)
    float variance = 0.0f;         ///< m², estimated variance of `height`
    /// m, where in the cell that height lies: the offset from the cell's centre of the points it was fused from,
    /// fused with the same weights. A cell's points are rarely spread evenly (a LiDAR ring crosses it at one
    /// place), and on a slope its height belongs there, not at the centre (docs/method.md §7).
    float dx = 0.0f, dy = 0.0f;
    std::int32_t observations = 0; ///< frames fused into the cell; 0 = empty
    std::int32_t points = 0;       ///< points fused into the cell
    std::int32_t last_update = 0;  ///< frame number of the last update (age = current frame − this)
};

/// A square grid of side `length_m` centred near the vehicle, cells `cell_m` wide, aligned with the odometry
/// axes. Cell (i, j) covers [i·cell, (i+1)·cell) × [j·cell, (j+1)·cell) and lives in slot (i mod n, j mod n):
/// moving the map clears the slots of the cells that enter and copies nothing (a circular buffer).
class ElevationMap {
public:
    ElevationMap(double cell_m, double length_m);

    /// Centres the window on (x, y); cells that leave it are forgotten. True when the window moved by its side or
    /// more: every cell left it.
    bool move_to(double x_m, double y_m);
    void clear();

    /// The cell at (x, y), nullptr outside the window. An empty cell has observations == 0.
    MapCell* at(double x_m, double y_m);
    const MapCell* at(double x_m, double y_m) const;
    /// Slot of the cell at (x, y), or −1 outside the window.
    std::int64_t slot(double x_m, double y_m) const;
    MapCell& cell(std::int64_t slot) { return cells_[static_cast<std::size_t>(slot)]; }
    const MapCell& cell(std::int64_t slot) const { return cells_[static_cast<std::size_t>(slot)]; }
    /// Odometry x, y of the centre of the cell in this slot.
    std::array<double, 2> centre(std::int64_t slot) const;

    std::int64_t side() const { return n_; }
    double cell_m() const { return cell_; }
    std::size_t bytes() const { return cells_.size() * sizeof(MapCell); }

private:
    void clear_rows(std::int64_t first, std::int64_t last, bool along_x);

    double cell_;
    std::int64_t n_;
    std::int64_t i0_ = 0, j0_ = 0;  // global index of the window's first row and column
    std::vector<MapCell> cells_;
};

struct FusionStatus {
    FusionMethod method = FusionMethod::None;
    std::int64_t frames = 0;     ///< frames fused since the last reset
    double coverage = 0.0;       ///< fraction of both profiles' bins ahead (0 ≤ s < preview) with map data
    double frame_coverage = 0.0; ///< the same, counting only cells this frame observed
    std::string reset;           ///< why the map was cleared before this frame; empty when it was not
    Pose2 pose;                  ///< the vehicle in the odometry frame
};

/// The map plus the vehicle's pose and clock; one per Estimator.
class TemporalFusion {
public:
    explicit TemporalFusion(const Config& cfg);

    void reset();
    /// Moves the vehicle to this frame's pose and the map with it. Resets the map (saying why in
    /// status.reset) when time runs backwards or jumps by more than fusion.max_time_gap_s.
    void advance(double speed_mps, double yaw_rate_rps, const FrameMotion& motion, FusionStatus& status);
    /// Fuses the ground points (`mask`) of a base-frame cloud, levelled by L, into the map. With
    /// `height_variances` (m² per point) a cell's spread is at least the root of its points' mean (noise_spread),
    /// and with `error_groups` (one per point, see PointErrors) its median counts as one measurement per group.
    /// With `ground`, the frame's local ground model (fit to the same points, docs/method.md §3), the profiles are
    /// read as heights above it (§7) until a frame is fused without one; without, as the map's heights.
    void fuse(PointsView points, const std::vector<std::uint8_t>& mask, const Levelling& L,
              const std::vector<float>* height_variances = nullptr,
              const std::vector<std::int32_t>* error_groups = nullptr, const LocalGround* ground = nullptr);
    /// Fuses height samples into the map: per cell the inverse-variance mean of its samples and that mean's
    /// variance, fused like a frame's cell (not aligned: the samples carry their own datum). Samples outside the
    /// window are skipped; returns the cells updated.
    std::size_t fuse_samples(const std::vector<MapSample>& samples);
    /// Both wheels' profiles sampled from the map along the paths, from −fusion.behind_m to the preview length;
    /// `blocked` (bins 0 ≤ s < preview) as in build_profiles. Fills status.coverage and frame_coverage.
    WheelProfiles profiles(const WheelPaths& paths, const BlockedBins* blocked, FusionStatus& status) const;
    /// The same into `left` and `right`, reusing their buffers.
    void profiles(const WheelPaths& paths, const BlockedBins* blocked, FusionStatus& status, Profile& left,
                  Profile& right) const;

    const ElevationMap& map() const { return map_; }
    /// Frames fused since the last reset (0: the map is empty).
    std::int64_t frames() const { return fused_; }
    const Pose2& pose() const { return pose_; }

private:
    /// Removes from the frame's cell medians the plane of their differences to the map and adds the excess
    /// disagreement to the variances (method.md §7); the first time, half of it to the map's cells.
    void align(const std::vector<std::int64_t>& slots, std::vector<double>& variances, std::vector<double>& medians);
    void mark_disagreeing_cells();                                      // align's steps, on shared_
    Eigen::Vector3d fit_alignment_plane() const;                        // (offset, x slope, y slope)
    double excess_disagreement(const Eigen::Vector3d& plane) const;     // m², beyond the cells' variances
    void reserve_cells(std::size_t cells);
    // Puts item `i` (a point of fuse(), a sample of fuse_samples()) on the list of `slot`, noting a slot new this call.
    void link(std::int64_t slot, std::size_t i);
    void sample(const WheelPaths& paths, Wheel w, const std::vector<std::uint8_t>* blocked, std::size_t& ahead,
                std::size_t& ahead_now, Profile& p) const;
    double above_local_ground(double x, double y, double height) const;  // a map height at odometry (x, y)

    // The last fused frame's local ground model and what takes a map height into that frame: the frame's pose
    // (and its yaw's cosine and sine), its alignment plane (offset, x slope, y slope about the vehicle: its heights
    // minus that plane are the map's) and its levelling.
    struct ReadoutGround {
        bool set = false;  // false: the profiles read the map's heights
        LocalGround model;
        Pose2 pose;
        double cos_yaw = 1.0, sin_yaw = 0.0;
        Eigen::Vector3d alignment = Eigen::Vector3d::Zero();
        Levelling L{};
    };

    struct SharedCell {  // a cell of the frame that the map holds too: what align fits
        std::size_t index;
        double difference, variance;
        bool inlier = true;
    };

    Config cfg_;
    ElevationMap map_;
    Pose2 pose_;
    std::optional<double> last_time_;
    std::int32_t frame_ = 0;  // frames seen (the cells' clock)
    std::int64_t fused_ = 0;
    bool started_ = false;
    bool map_has_excess_ = false;  // the map's variances carry an excess disagreement (an alignment has run)
    ReadoutGround readout_;
    std::vector<std::int32_t> head_, next_;  // per-slot lists of this frame's points (reused)
    std::vector<double> z_;
    std::vector<float> variance_;  // this frame's point height variances, by point (reused)
    std::vector<std::int32_t> cell_groups_;  // the error groups of one cell's points (reused)
    std::vector<std::array<double, 2>> xy_;  // this frame's points in the odometry frame, by point (reused)
    // Per cell of the frame (reused): its slot, median, spread, count, variance, and the heights of one cell.
    std::vector<std::int64_t> touched_;
    std::vector<double> medians_, spreads_, cell_z_, variances_, pooled_;
    std::vector<std::array<double, 2>> offsets_;  // each touched cell's points' mean offset from its centre
    std::vector<std::int32_t> counts_, bands_;
    std::vector<std::int32_t> measurements_;  // each touched cell's independent measurements: its error groups
    PoolBuffers pool_buffers_;
    std::vector<Eigen::Vector3d> align_v_;  // align's scratch
    std::vector<SharedCell> shared_;
    std::vector<double> deviations_;
};

}  // namespace roadpreview
