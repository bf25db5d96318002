// SPDX-License-Identifier: BSD-3-Clause
// The roadside pipeline: scans (any order of scanners, increasing time) → cycles of classified, tracked objects
// in the site frame and in WGS84, every cycle's objects predicted to the cycle's common time.
#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "roadpreview/roadside/geo.hpp"
#include "roadpreview/roadside/scan.hpp"
#include "roadpreview/roadside/site.hpp"
#include "roadpreview/roadside/tracking.hpp"
#include "roadpreview/roadside/world_background.hpp"

namespace roadpreview::roadside {

/// How a scanner lays its beams: their count, the first beam's angle and the step between them.
struct ScanLayout {
    std::size_t beams = 0;
    double start_angle_rad = 0.0, step_rad = 0.0;
};

/// A camera detection: image box (px, top-left x, y, width, height), class and score, at time t.
struct CameraDetection {
    double t_s = 0.0;
    double x_px = 0.0, y_px = 0.0, w_px = 0.0, h_px = 0.0;
    std::string cls;
    double score = 0.0;
};

/// Throws, naming `where`, unless the detection's numbers are finite, its box has w, h > 0, its class is not empty
/// and its score (a detector's confidence, its vote for the class) lies in (0, 1].
void check_detection(const CameraDetection& d, const std::string& where);
/// Detections from a CSV `t,x,y,w,h,class,score` or a JSON array / JSON lines of objects with those keys.
std::vector<CameraDetection> read_detections(const std::string& path);
/// Writes detections as that CSV, every number round-tripping exactly.
void write_detections_csv(const std::vector<CameraDetection>& detections, const std::string& path);

struct OutputObject {
    int id = 0;
    std::string cls;      ///< car, pedestrian, cyclist, unknown
    double score = 0.0;
    std::string source;   ///< laser, camera, both
    double x_m = 0.0, y_m = 0.0, vx_mps = 0.0, vy_mps = 0.0, speed_mps = 0.0, heading_rad = 0.0;
    double length_m = 0.0, width_m = 0.0;
    LatLon position;
    std::array<std::array<double, 2>, 4> mbr_site{};
    std::array<LatLon, 4> mbr_wgs84{};
    int points = 0;
    double age_s = 0.0;
    double since_measured_s = 0.0;  ///< from its last measurement to the cycle's time (more than a cycle: predicted)
};

struct ScannerStatus {
    std::string name;
    std::int64_t scans = 0;           ///< scans used so far
    double last_scan_s = -1.0;        ///< site time of its last scan, −1 before the first
    bool active = false;              ///< delivered a scan within the timeout
    std::int64_t invalid_ranges = 0;  ///< NaN, ≤ 0 or at/beyond max range, so far
};

struct Cycle {
    double t_s = 0.0;  ///< the common time every object is predicted to
    std::vector<OutputObject> objects;
    std::vector<ScannerStatus> scanners;
    int scan_objects = 0;  ///< components found in this cycle
    double process_ms = 0.0;
};

class Processor {
public:
    explicit Processor(Site site);
    ~Processor();
    /// Adds a scan (scanner index into the site); returns the cycles it completed (usually 0 or 1). Scans must
    /// come in non-decreasing site time; a scan whose layout disagrees with the site throws std::runtime_error.
    std::vector<Cycle> push(const LaserScan& scan);
    /// Learns the world background of the scans that carry a pose (a moving scanner, placed by its pose composed
    /// with its site mount) from all of them at once: call before pushing them. Posed scans are classified against
    /// it instead of a per-beam background. Throws std::invalid_argument when no scan carries a pose.
    void learn_world(const std::vector<LaserScan>& scans);
    const std::optional<WorldBackground>& world() const { return world_; }
    /// Foreground flags of a scan with a pose against the world background (std::invalid_argument without either).
    std::vector<bool> world_foreground(const LaserScan& scan) const;
    /// Camera detections (any time order; they are used by the cycle whose interval holds their time).
    void add_detections(const std::vector<CameraDetection>& detections);
    /// Completes the last cycle.
    std::vector<Cycle> finish();
    /// How many of the camera detections given so far lie more than a second (the time a track keeps a detection)
    /// before the first scan or after the last, on the site clock: on another clock, most likely; in no output.
    std::size_t detections_outside_scans() const;
    /// The warning those detections deserve (empty when there are none, or no scan yet).
    std::string detections_outside_warning() const;
    const Site& site() const { return site_; }

private:
    Cycle run_cycle(double t_end_s);
    /// The scan on the site clock, its layout checked, invalid ranges made no return (and counted, if asked).
    LaserScan checked(const LaserScan& input, std::int64_t* invalid_ranges = nullptr) const;
    Pose2 site_pose(const LaserScan& scan) const;  ///< the scanner's pose: its logged pose (if any) ∘ its mount
    void check_same_layout(const LaserScan& scan) const;
    double last_scan_s() const;  ///< site time of the latest scan of any scanner (the first's before any)
    void associate_camera(double t0_s, double t1_s, Cycle& cycle);
    OutputObject output(const Track& t, double t_s) const;
    Site site_;
    SiteGeodesy geo_;
    std::vector<BackgroundModel> background_;
    std::optional<WorldBackground> world_;
    std::vector<ScannerStatus> status_;
    std::vector<double> learn_start_s_;
    std::vector<std::optional<ScanLayout>> first_layout_;  ///< per scanner: its first scan's
    Tracker tracker_;
    std::vector<LaserScan> pending_;
    std::vector<CameraDetection> detections_;
    long long cycle_index_ = -1;
    double first_time_s_ = 0.0;
    bool started_ = false;
};

/// The cycle as one JSON line (docs/output.md, "Roadside").
std::string cycle_to_json(const Cycle& cycle);
/// A GeoJSON FeatureCollection of the cycles' objects: a Point and a Polygon (the MBR) per object and cycle.
std::string cycles_to_geojson(const std::vector<Cycle>& cycles);

}  // namespace roadpreview::roadside
