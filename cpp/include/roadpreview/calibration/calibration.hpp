// SPDX-License-Identifier: BSD-3-Clause
// Beam self-calibration (docs/method.md §8): each beam's elevation-angle offset (and range offset where the
// drive tells them apart) from the same road cells seen by different beams as the vehicle moves; the beams
// file (beams.yaml) that holds them; and applying them to points.
#pragma once

#include <cstdint>
#include <limits>
#include <stdexcept>
#include <string>
#include <vector>

#include "roadpreview/core/config.hpp"
#include "roadpreview/core/points.hpp"
#include "roadpreview/fusion/fusion.hpp"

namespace roadpreview {

/// The drive cannot determine the offsets: too short, no motion, too few beams on the ground.
class CalibrationError : public std::runtime_error {
public:
    using std::runtime_error::runtime_error;
};

/// Below this drive (m) the motion method links the far beams weakly: its offsets are unreliable and their σ
/// understated (README "Beam self-calibration": on a 9 m simulated drive offsets of up to 0.1° stayed 0.007° off,
/// and two 1.7 m halves of a real drive disagreed by 0.08° where each stated 0.003°). Runs warn below it.
inline constexpr double kShortDriveM = 15.0;
/// The warning a motion calibration of a drive of `travel_m` deserves: empty from kShortDriveM on.
std::string short_drive_warning(double travel_m);

struct CalibrationOptions {
    /// Road cells in which the beams' heights are compared. Smaller cells bias the steep beams: range noise moves
    /// a point along its ray, so which cell it falls in depends on its height error (method.md §8). 0.01–10 m.
    double cell_m = 0.2;
    int min_frames = 2;
    double min_travel_m = 0.3;         ///< the vehicle must move at least this far over the drive
    double max_sigma_deg = 0.01;       ///< a beam whose offset is less certain than this is not determined
    double max_range_sigma_m = 0.01;   ///< range offsets less certain than this are not estimated (set to 0)
    int min_beams = 3;                 ///< fewer determined beams is an error
    int min_observations = 100;        ///< a beam seen in fewer shared cells is not determined (pooled noise)
    double outlier_sigmas = 4.0;       ///< observations further off than this many robust σ are dropped
    int rounds = 3;                    ///< fits, each after dropping the previous fit's outliers
};

/// One beam's calibration. Corrected point: (r − range_offset_m) along elevation θ + elevation_offset_deg.
struct BeamOffsets {
    bool determined = false;              ///< false: the drive could not tell; both offsets are 0
    double elevation_offset_deg = 0.0;    ///< relative to the beams' fit a + b/reach (method.md §8)
    double elevation_sigma_deg = std::numeric_limits<double>::quiet_NaN();
    double range_offset_m = 0.0;          ///< 0 where not estimated
    double range_sigma_m = std::numeric_limits<double>::quiet_NaN();
    std::int64_t observations = 0;        ///< cell observations of this beam used
    double elevation_deg = std::numeric_limits<double>::quiet_NaN();  ///< index by elevation: the beam's centre
};

/// How points find their beam: the decoder's beam (laser) number, their place in a file that lists them ring by
/// ring (KITTI .bin), or their elevation angle (files in no such order).
enum class BeamIndexMethod { Decoder, Elevation, ScanOrder };

struct BeamCalibration {
    std::string sensor_model;  ///< e.g. "OS-1-128", "VLP-16", "HDL-64E"; empty when unknown
    std::string serial;        ///< empty when unknown
    int beam_count = 0;
    BeamIndexMethod index = BeamIndexMethod::Decoder;
    /// Elevation index: a point's elevation less tilt[0]·(cos φ − 1) + tilt[1]·sin φ (deg) is matched to the
    /// nearest beam centre; farther than `index_tolerance_deg` from every centre, it keeps its place.
    double tilt_deg[2] = {0.0, 0.0};
    double index_tolerance_deg = 0.0;
    std::vector<BeamOffsets> beams;
    std::int64_t frames = 0;   ///< frames of the drive it was estimated from
    double travel_m = 0.0;
    double residual_m = 0.0;   ///< robust σ of one point's height after the fit
    std::string source;        ///< the file it was read from, for messages
};

/// Reads a beams file; throws std::runtime_error naming the file on a bad or missing field.
BeamCalibration read_beam_calibration(const std::string& path);
void write_beam_calibration(const BeamCalibration& c, const std::string& path);
std::string beam_calibration_to_yaml(const BeamCalibration& c);

/// Throws std::runtime_error naming c.source when the file is for another sensor: another beam count, or
/// another serial or model where both are known.
void check_beam_calibration(const BeamCalibration& c, int beam_count, const std::string& sensor_model,
                            const std::string& serial);

/// Each beam's elevation σ as the calibration states it, for ProfileConfig::beam_sigmas_deg: what is left of the
/// beam's error once its offset is applied; `others_deg` for the beams the drive could not determine.
std::vector<double> calibrated_beam_sigmas_deg(const BeamCalibration& c, double others_deg);

/// How to find the beams of frames from a sensor that does not number its points. Scan order when every frame
/// lists exactly beam_count rings, one turn each from azimuth 0, from the top beam down (KITTI .bin); else the
/// beam centres for index-by-elevation: the peaks of the histogram of the points' elevations (front half, beyond
/// 4 m) after removing the common tilt that makes them sharpest. Fills index, tilt_deg, index_tolerance_deg and
/// beams[].elevation_deg (for scan order the rings' median elevations, for information).
void find_beam_centres(const std::vector<PointsView>& frames, int beam_count, BeamCalibration& c);
/// Beam of each point of an unnumbered frame by c's index (ScanOrder or Elevation); throws naming `name` when a
/// frame is not in the scan order c needs.
std::vector<std::int32_t> beams_of_points(PointsView points, const BeamCalibration& c, const std::string& name);
/// Gives `out`, estimated from unnumbered frames, the way find_beam_centres indexed them (`indexing`: index, tilt,
/// tolerance, each beam's elevation), so that applying it finds the same beams; nothing when `indexing` is empty.
void adopt_beam_indexing(BeamCalibration& out, const BeamCalibration& indexing);
/// Beam of each point by its elevation (c.index must be Elevation); −1 where none is near.
std::vector<std::int32_t> beams_by_elevation(PointsView points, const BeamCalibration& c);
/// Corrects the points of a file reader in place (x, y, z of each row) by their beams' offsets.
void apply_beam_calibration(float* xyz, std::int64_t rows, std::int64_t stride, const std::vector<std::int32_t>& beams,
                            const BeamCalibration& c);

/// Accumulates ground points of a drive, then solves for the offsets.
class BeamCalibrator {
public:
    BeamCalibrator(const Config& cfg, int beam_count, CalibrationOptions options = {});

    /// One frame: sensor-frame points, each one's beam (−1: unknown, skipped), which rows are ground, and the
    /// base frame's pose in the odometry frame.
    void add_frame(PointsView points, const std::vector<std::int32_t>& beams,
                   const std::vector<std::uint8_t>& ground_mask, const Pose2& pose);
    /// The same, with the ground found by the configured ground stage.
    void add_frame(PointsView points, const std::vector<std::int32_t>& beams, const Pose2& pose);
    /// Throws CalibrationError when the drive cannot determine the offsets.
    BeamCalibration solve() const;

    std::int64_t frames() const { return static_cast<std::int64_t>(poses_.size()); }

    struct Observation {  // the mean of one (cell, frame, beam) group of points
        std::int64_t i, j;
        std::int32_t frame, beam;
        double weight, z, x, y, j_elevation, j_range;
    };

private:
    Config cfg_;
    int beam_count_;
    CalibrationOptions options_;
    std::vector<Pose2> poses_;
    std::vector<Observation> observations_;
};

/// Options of the surface calibration (method.md §8, "From the road's shape").
struct SurfaceCalibrationOptions {
    double min_x_m = 3.0, max_x_m = 30.0;  ///< the stretch ahead whose road is compared (base frame)
    double half_width_m = 3.5;             ///< |y| of the corridor: the lane ahead, not the verges
    int min_points = 30;                   ///< a beam's points in one frame's corridor for a value of that frame
    int min_frames = 3;                    ///< frames that must give a beam a value for it to be determined
    double max_sigma_deg = 0.05;           ///< a beam whose offset is less certain than this is not determined
    double outlier_sigmas = 3.0;           ///< points further off the surface than this many robust σ are dropped
    int rounds = 3;                        ///< surface fits, each after dropping the previous fit's outliers
    int min_beams = 3;                     ///< fewer determined beams is an error
};

/// Per-beam elevation offsets from the road's shape, frame by frame: each frame's road in the corridor ahead is
/// fitted by a smooth surface (quadratic in x and y), and a beam's offset is the median of its points'
/// heights off that surface over their elevation Jacobian; the offsets are the median over the frames, their σ
/// from the frames' spread. Needs no motion, and frames from different places agree the better (method.md §8).
class SurfaceCalibrator {
public:
    SurfaceCalibrator(const Config& cfg, int beam_count, SurfaceCalibrationOptions options = {});
    /// One frame: sensor-frame points and each one's beam (−1: unknown, skipped); the ground is the paper's one
    /// plane, as for BeamCalibrator. A frame without enough road in the corridor adds nothing.
    void add_frame(PointsView points, const std::vector<std::int32_t>& beams);
    /// Throws CalibrationError when too few frames or beams determine the offsets.
    BeamCalibration solve() const;
    std::int64_t frames() const { return frames_; }

private:
    Config cfg_;
    int beam_count_;
    SurfaceCalibrationOptions options_;
    std::int64_t frames_ = 0;
    std::vector<std::vector<double>> values_;  // per beam: its offset (rad) in each frame that gave one
    std::vector<double> reach_sum_, reach_weight_, noise_;  // per beam: Σ −J_δ and points; per frame: σ of the road
};

/// The ground of the paper's one plane (fit, drop points more than 0.2 m above, ×3) of sensor-frame points,
/// whatever cfg.ground.method says: the smooth road every beam crosses, which calibration compares.
std::vector<std::uint8_t> one_plane_ground(PointsView points, const Config& cfg);

}  // namespace roadpreview
