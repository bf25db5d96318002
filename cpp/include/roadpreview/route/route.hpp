// SPDX-License-Identifier: BSD-3-Clause
// Route outputs (docs/method.md §10): the frames' wheel-path profiles stitched along the drive into one
// longitudinal profile per wheel, its segments classified (ISO 8608, IRI), and the files a road engineer reads:
// a segments CSV, each wheel's profile as CSV and in the ERD text format (UMTRI; read by ProVAL).
#pragma once

#include <cstdint>
#include <optional>
#include <ostream>
#include <string>
#include <vector>

#include "roadpreview/core/config.hpp"
#include "roadpreview/fusion/fusion.hpp"
#include "roadpreview/pipeline/pipeline.hpp"
#include "roadpreview/roughness/iri.hpp"
#include "roadpreview/roughness/roughness.hpp"
#include "roadpreview/route/drive_distance.hpp"

namespace roadpreview {

/// One wheel's profile along the drive: bin j covers drive distance [j·ds, (j+1)·ds) from the first frame.
struct StitchedProfile {
    double ds = 0.0;
    std::vector<double> z;              ///< m, levelled height; NaN where missing
    std::vector<std::int32_t> count;    ///< points behind the bin, summed over the frames that saw it
    std::vector<double> spread;         ///< m, spread of those points' heights; NaN below two points
    std::vector<std::int32_t> frames;   ///< frames whose profile backed the bin with points
    /// 1 where a frame saw an obstacle over the bin (its blocked bins, docs/method.md §5) and none saw road there:
    /// z is NaN and no gap is filled across it, as in a single frame's profile.
    std::vector<std::uint8_t> blocked;
};

/// One wheel's (or, for `vehicle`, both wheels') result over one segment.
struct SegmentWheel {
    Roughness roughness;           ///< §4 over the segment's longest valid stretch (noise-aware)
    Iri iri;                       ///< the quarter-car run over the whole stitched stretch, averaged over the segment
    double backed_fraction = 0.0;  ///< fraction of the segment's bins that hold points
};

struct RouteSegment {
    double length_m = 0.0;                ///< the segment length asked for
    double start_m = 0.0, end_m = 0.0;    ///< drive distance; the last segment may end short
    std::optional<Pose2> start, end;      ///< where the drive was there (with poses; none ahead of its last frame)
    SegmentWheel left, right, vehicle;
};

/// Stitches each frame's profiles into the drive's (docs/method.md §10). Feed the frames in order.
class RouteBuilder {
public:
    explicit RouteBuilder(const Config& cfg);  ///< throws std::invalid_argument on a bad config

    /// Adds one frame: its distance along the drive from `pose` (when given) or from |speed| times the time
    /// since the previous frame (its timestamps, else 1 / fusion.frame_rate_hz); a wheel with more than
    /// kMaxDrivePerWheelMetre of drive per metre of its path adds nothing. Throws std::invalid_argument, leaving
    /// the route as it was, as DriveDistance::advance (time going back, poses for some frames only, a step of
    /// more than kMaxFrameStepM) and for profiles it cannot place (see `placeable`).
    void add(const Result& r, const std::optional<Pose2>& pose = std::nullopt);

    std::size_t frames() const { return drive_.frames(); }
    double distance_m() const { return drive_.metres(); }  ///< driven by the last frame added
    /// The stitched profile with interior gaps up to profile.max_gap_m filled (filled bins keep count 0).
    StitchedProfile left() const;
    StitchedProfile right() const;
    /// Consecutive segments of `length_m` from 0 to the end of the stitched profiles (check_segment_length).
    std::vector<RouteSegment> segments(double length_m) const;
    /// Throws std::invalid_argument unless `length_m` is a finite number of at least profile.ds_m: a segment
    /// holds one bin or more (a 1 nm segment once wrote 61 MB of rows for 40 m of road, and went on).
    void check_segment_length(double length_m) const;

private:
    struct WheelSums {
        std::vector<double> weight, weighted_z, weighted_square;  // Σc, Σc·z, Σc·(spread² + z²)
        std::vector<std::int32_t> count, frames;
        std::vector<std::size_t> last_frame;  // the last frame (1-based) that added to the bin
        std::vector<std::uint8_t> blocked;     // some frame saw an obstacle over the bin (may reach past the rest)
    };
    void stitch(const Profile& p, double scale, WheelSums& w);
    StitchedProfile finished(const WheelSums& w) const;
    std::optional<Pose2> pose_at(double distance_m) const;

    Config cfg_;
    DriveDistance drive_;
    WheelSums left_, right_;
    std::vector<std::pair<double, Pose2>> track_;  // (distance, pose) of each frame, with poses only
};

/// What RouteBuilder::add reads of one output line (docs/output.md: motion.speed, and profiles unless reason is
/// set; source, timestamp and path when present), so a run's lines can be stitched after the fact; the Result's
/// other fields stay empty. Throws std::invalid_argument starting with `where` for a line that is not JSON or
/// lacks motion.speed or the profiles.
Result route_input_from_json(const std::string& line, const std::string& where = "output line");

/// The segments as CSV rows, one per segment (columns in docs/output.md, "Route outputs").
void write_segments_csv(std::ostream& out, const std::vector<RouteSegment>& segments);
/// One wheel's stitched profile as CSV: distance_m, z_m, count, frames, filled.
void write_profile_csv(std::ostream& out, const StitchedProfile& p);
/// One wheel's stitched profile in the ERD text format over its longest valid stretch (heights in mm);
/// throws std::runtime_error when there is none.
void write_profile_erd(std::ostream& out, const StitchedProfile& p, const std::string& wheel,
                       const std::string& title);

}  // namespace roadpreview
