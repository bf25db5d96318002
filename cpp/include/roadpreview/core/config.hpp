// SPDX-License-Identifier: BSD-3-Clause
// Pipeline configuration: one aggregate per stage with unit-bearing names, nested in Config.
// Field names, defaults and meanings are those of python/roadpreview/config.py and docs/method.md.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "roadpreview/core/status.hpp"

namespace roadpreview {

/// Pose of the sensor in the base frame (x forward, y left, z up); R = Rz(yaw)·Ry(pitch)·Rx(roll).
struct Extrinsics {
    double x_m = 0.0;
    double y_m = 0.0;
    double z_m = 0.0;
    double roll_rad = 0.0;
    double pitch_rad = 0.0;
    double yaw_rad = 0.0;
};

enum class GroundMethod { Pca, Ransac, Zones };

struct GroundConfig {
    GroundMethod method = GroundMethod::Zones;
    double roi_x_min_m = 1.0;       ///< front region of interest, base frame
    double roi_x_max_m = 40.0;
    double roi_y_abs_max_m = 10.0;
    int pca_iterations = 3;         ///< plane fits; each drops points too far above the last plane
    double pca_threshold_m = 0.20;  ///< points more than this above the plane are not ground
    /// Points more than this below the ground model (pca: the last plane; zones: the patch's reference and planes;
    /// ransac's band is two-sided) are not ground — returns from under the road (a reflection, multipath).
    double max_depth_m = 2.0;
    double ransac_distance_m = 0.20;
    int ransac_max_iterations = 200;
    std::uint32_t ransac_seed = 1;  ///< fixed so results are reproducible
    /// Every method: a plane or patch whose normal is farther than this from the up axis of the base frame
    /// (the level the extrinsics give) is not ground. Config files may still name it ransac_max_tilt_deg.
    double max_tilt_deg = 15.0;
    // Zone ground (docs/method.md §1, method "zones"): rings × sectors of the front ROI, a plane per patch.
    std::vector<double> zone_ring_edges_m{1, 3, 5, 7, 9, 11, 13, 15.5, 18, 21, 24, 28, 32, 36, 42};
    std::vector<int> zone_sectors{16, 24, 32, 48, 56, 64, 72, 80, 96, 104, 112, 128, 144, 160};  ///< per ring, full circle
    double zone_root_m = 10.0;        ///< the paper's plane of the points nearer than this: the first reference
    int zone_min_points = 10;         ///< fewer points in a patch: no ground there
    int zone_seed_points = 20;        ///< the mean height of this many lowest points starts the fit
    double zone_max_step_m = 0.3;     ///< elevation test: ground centroid off the inner ground by at most this
    double zone_max_flatness_m = 0.08; ///< flatness test: RMS distance of the fitted points from their plane
    double zone_min_breadth_m = 0.1;   ///< breadth test: the fitted points' RMS spread across their longest direction
};

struct PathConfig {
    double straight_radius_m = 1000.0;  ///< |V/ω| above this is driven as a straight line
    double stopped_speed_mps = 0.0;     ///< |V| at or below this: stopped, no path
};

struct ProfileConfig {
    double preview_length_m = 40.0;
    double ds_m = 0.1;       ///< resampling step along the wheel path
    double max_gap_m = 1.0;  ///< interior gaps up to this length are linearly interpolated
    bool level = true;       ///< remove the fitted ground plane's tilt before reading heights
    bool level_local = true; ///< with level: heights above the local ground's plane in bands of level_band_m (§3)
    double level_band_m = 10.0;  ///< radial width of those bands; sets which long waves the levelling removes
    /// σ (degrees) of each LiDAR beam's elevation angle: an error all of a beam's points share (method.md §3), counted
    /// in the bins' and the map's noise for points whose beam is known; 0: not counted
    double beam_sigma_deg = 0.0;
    /// σ (degrees) of beam b's elevation angle at [b], in place of beam_sigma_deg for the beams it lists (e.g. each
    /// calibrated beam's stated uncertainty, BeamOffsets::elevation_sigma_deg); empty: beam_sigma_deg for every beam
    std::vector<double> beam_sigmas_deg;
};

struct RoughnessConfig {
    double band_min_cpm = 0.1;  ///< analysis band, cycles/m
    double band_max_cpm = 4.0;
    double min_length_m = 5.0;  ///< shortest valid stretch that is analysed
    double min_cycles = 2.0;    ///< the band starts no lower than min_cycles / stretch length
    int min_band_points = 5;    ///< fewest PSD ordinates in the band for a class
    bool noise_aware = true;             ///< fit signal + measurement noise; band limited by the sampling
    double min_resolved_fraction = 0.5;  ///< the band ends where the bins' spacing keeps less of the road's PSD
};

struct IriConfig {
    double min_length_m = 11.0;  ///< shortest valid stretch whose IRI is computed (ASTM E1926's 11 m lead-in)
    double min_backed_fraction = 0.25;  ///< fewest bins of the stretch holding points (the rest interpolated)
};

/// Obstacles (docs/method.md §5): Euclidean clusters of the non-ground ROI points, and where they cross
/// the wheel paths.
struct ObstaclesConfig {
    bool enabled = true;
    double voxel_m = 0.25;             ///< points are clustered by the centroids of voxels this wide; 0: every point
    double cluster_tolerance_m = 0.5;  ///< centroids closer than this are in the same cluster
    int min_cluster_points = 5;        ///< smaller clusters are dropped (isolated returns, noise)
    int max_cluster_points = 1000000;  ///< larger clusters are dropped; the default keeps every one
    double ground_search_m = 1.0;      ///< ground points this far around a cluster give its local ground
    double safety_margin_m = 0.1;      ///< widens each wheel corridor sideways and each obstacle along s
    double min_height_m = 0.1;         ///< lower clusters do not block a wheel path (ground the fit missed)
    double clearance_m = 2.5;          ///< clusters entirely higher above their local ground (canopy, signs,
                                       ///< bridges) do not block a wheel path
};

enum class FusionMethod { None, Ema, Kalman };

/// Temporal fusion (docs/method.md §7): a rolling elevation map fused over frames; "none" is the single frame.
struct FusionConfig {
    FusionMethod method = FusionMethod::None;
    double alpha = 0.5;            ///< EMA weight of the new frame, (0, 1]; 1 = the latest frame's cells
    double cell_m = 0.1;           ///< square map cells
    double map_length_m = 100.0;   ///< side of the square map around the vehicle (≥ 2 × (preview + margin))
    double point_noise_m = 0.03;   ///< σ of one point's height when no cell of a frame holds two points
    double frame_rate_hz = 10.0;   ///< frames without timestamps are 1/frame_rate_hz apart
    double max_time_gap_s = 0.5;   ///< a longer step between timestamps, or one back in time, resets the map
    double behind_m = 0.0;         ///< fused profiles start this far behind the wheels (already-driven road)
    bool align = true;             ///< remove the plane between a frame's heights and the map's before fusing
    double align_tilt_sigma = 1e-4;   ///< rad, prior σ of that plane's slopes: scarce shared cells cannot tilt a frame
    /// m: the disagreement beyond the cells' variances (the excess) is measured on the shared cells this close to
    /// the line ahead of the vehicle — the lane the profiles are read from, not the verges (method.md §7)
    double align_excess_half_width_m = 2.0;
};

/// Stereo cameras (docs/method.md §12): OpenCV StereoSGBM's settings, the disparity noise behind each point's
/// range variance, and the part of the image matched (the rows that can see the road up to max_depth_m).
struct StereoConfig {
    int min_disparity = 0;             ///< px, smallest disparity searched
    int num_disparities = 128;         ///< px, width of the search (a multiple of 16)
    int block_size = 5;                ///< px, odd, matching window
    int p1 = 600;                      ///< smoothness penalty for ±1 px disparity changes (8·3·block_size²)
    int p2 = 2400;                     ///< penalty for larger changes (32·3·block_size²), > p1
    int disp12_max_diff = 1;           ///< px, left-right consistency check; < 0 turns it off
    int pre_filter_cap = 63;
    int uniqueness_ratio = 10;         ///< %, margin of the best match over the second best
    int speckle_window_size = 100;     ///< px, largest speckle removed; 0 turns the filter off
    int speckle_range = 2;             ///< px, disparity variation within a connected component
    std::string mode = "sgbm_3way";    ///< "sgbm" (5 directions), "hh" (8), "sgbm_3way" or "hh4"
    int threads = 0;                   ///< OpenCV threads for matching; 0: OpenCV's default (all cores)
    double disparity_sigma_px = 0.4;   ///< σ_d of a matched disparity: range variance (z²·σ_d/(f·B))² per point
    /// px, how far matching errors stay correlated along a row and across rows (KITTI pair, SGBM: 15, 2):
    /// points within one tile of twice these share an error group (Frame::error_groups); 0: every pixel its own
    double error_correlation_along_px = 15.0;
    double error_correlation_across_px = 2.0;
    double max_depth_m = 40.0;         ///< farther points are dropped; rows that only see beyond it are not matched
    double road_rise_m = 2.0;          ///< the road may rise this far above the base plane at max_depth_m
};

struct Config {
    std::optional<double> sensor_height;   ///< m; shortcut for extrinsics (0, 0, h, 0, 0, 0)
    std::optional<Extrinsics> extrinsics;  ///< neither set: points are already in the base frame
    double track_width = 1.6;              ///< m, between the wheel centre lines
    double tire_width = 0.3;               ///< m, width of the corridor read per wheel
    /// Threads one frame's stages may use (the crop's runs of rows, the zone ground's azimuth groups, the obstacles
    /// beside the profiles), at most as many as the process may run at once; the answer is the same for any number.
    /// 1: the calling thread only.
    int threads = 1;
    GroundConfig ground;
    PathConfig path;
    ProfileConfig profile;
    RoughnessConfig roughness;
    ObstaclesConfig obstacles;
    IriConfig iri;
    FusionConfig fusion;
    StereoConfig stereo;
};

/// Whether the LiDAR beams' elevation errors are counted: some beam's σ (beam_sigma_deg, beam_sigmas_deg) is > 0.
bool beam_errors_counted(const ProfileConfig& p);

/// Most threads a frame may use (Config::threads).
constexpr int kMaxThreads = 64;

/// Highest sensor_height accepted, m: a mast, not a vehicle, is higher.
constexpr double kMaxSensorHeightM = 10.0;

/// Most beams ProfileConfig::beam_sigmas_deg may list (LiDARs have up to a few hundred).
constexpr std::size_t kMaxBeams = 4096;

/// Farthest the extrinsics may place the sensor from the base origin, m (a truck is 20 m long).
constexpr double kMaxMountingOffsetM = 100.0;

/// Most fits GroundConfig::pca_iterations may ask for (the paper's is 3; every fit is a pass over the points), and
/// most RANSAC iterations.
constexpr int kMaxFitIterations = 100;
constexpr int kMaxRansacIterations = 1'000'000;

/// Throws std::invalid_argument naming the first offending field.
void validate(const Config& cfg);

/// validate() without exceptions, for programs built without them: Ok, or InvalidArgument with the text validate()
/// throws. An Estimator made from a config it passes throws nothing but std::bad_alloc.
Status check_config(const Config& cfg) noexcept;

/// The extrinsics in force: sensor_height, extrinsics, or identity.
Extrinsics effective_extrinsics(const Config& cfg);

/// JSON (the field names above; missing fields keep their defaults). `source` names the input in errors.
Config config_from_json(const std::string& text, const std::string& source = "config");
std::string config_to_json(const Config& cfg);
/// A .json, .yaml or .yml file of the same fields. Throws std::invalid_argument naming the file.
Config config_from_file(const std::string& path);

const char* to_string(GroundMethod method);
const char* to_string(FusionMethod method);

}  // namespace roadpreview
