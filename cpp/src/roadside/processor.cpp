// SPDX-License-Identifier: BSD-3-Clause
// The roadside cycle: background learning, grouping scans into cycles, objects, tracking, camera association,
// prediction of every object to the cycle's common time (docs/method.md, "Roadside").
#include "roadpreview/roadside/processor.hpp"

#include <algorithm>
#include <ctime>
#include <cmath>
#include <stdexcept>

#include "core/text.hpp"

namespace roadpreview::roadside {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kDeg = kPi / 180.0;
constexpr double kCameraMemoryS = 1.0;  // a camera class stays with a track this long after its last detection

TrackerSettings tracker_settings(const RoadsideSettings& s) {
    TrackerSettings t;
    t.accel_sigma_mps2 = s.accel_sigma_mps2;
    t.position_sigma_m = s.position_sigma_m;
    t.gate_chi2 = s.gate_chi2;
    t.max_coast_s = s.max_coast_s;
    t.confirm_hits = s.confirm_hits;
    t.max_speed_mps = s.max_speed_mps;
    return t;
}

Pose2 compose(const Pose2& a, const Pose2& b) {  // b expressed in a
    const double c = std::cos(a.yaw_rad), s = std::sin(a.yaw_rad);
    return {a.x_m + c * b.x_m - s * b.y_m, a.y_m + s * b.x_m + c * b.y_m, a.yaw_rad + b.yaw_rad};
}

std::string layout_text(const ScanLayout& l) {
    return std::to_string(l.beams) + " beams from " + number_text(l.start_angle_rad / kDeg, 8) + "° every " +
           number_text(l.step_rad / kDeg, 8) + "°";
}

ScanLayout layout_of(const LaserScan& scan) { return {scan.ranges_m.size(), scan.start_angle_rad, scan.step_rad}; }

void check_layout(const LaserScan& scan, const ScannerSite& site) {
    // A scan's beams lie within one turn: angles beyond it are a unit or a field mixed up (the Python API takes
    // any dict; a step of 1e300 or NaN once made objects, or a grid of NaN metres).
    const double turn = 2.0 * kPi * (1.0 + 1e-9);
    if (!(std::abs(scan.start_angle_rad) <= turn) || !(scan.step_rad != 0.0) ||
        !(std::abs(scan.step_rad) * static_cast<double>(scan.ranges_m.size()) <= turn + std::abs(scan.step_rad)))
        throw std::runtime_error(scan.source + ": the scan's angles are no scanner's: " + layout_text(layout_of(scan)) +
                                 " (its first beam within ±360°, a nonzero step, all beams within one turn)");
    auto bad = [&](const std::string& what) {
        throw std::runtime_error(scan.source + ": scan layout disagrees with the site's scanner '" + site.name + "': " + what);
    };
    if (site.beams && static_cast<int>(scan.ranges_m.size()) != *site.beams)
        bad(std::to_string(scan.ranges_m.size()) + " beams, the site says " + std::to_string(*site.beams));
    if (site.step_deg && std::abs(scan.step_rad / kDeg - *site.step_deg) > 1e-3)
        bad("step " + number_text(scan.step_rad / kDeg, 8) + "°, the site says " + number_text(*site.step_deg, 8) +
            "°");
    if (site.start_angle_deg && std::abs(scan.start_angle_rad / kDeg - *site.start_angle_deg) > 1e-2)
        bad("first beam at " + number_text(scan.start_angle_rad / kDeg, 8) + "°, the site says " +
            number_text(*site.start_angle_deg, 8) + "°");
}

}  // namespace

Processor::Processor(Site site)
    : site_(std::move(site)), geo_(site_.origin), background_(site_.scanners.size()), status_(site_.scanners.size()),
      learn_start_s_(site_.scanners.size(), 0.0), first_layout_(site_.scanners.size()),
      tracker_(tracker_settings(site_.settings)) {
    for (std::size_t i = 0; i < status_.size(); ++i) status_[i].name = site_.scanners[i].name;
    // OpenCV sets up its parallel back end on its first dilation and labelling (about 4 ms here): done now, so that
    // the first cycle keeps to the budget of every other.
    label_points({Point2{}}, site_.settings.cell_m, site_.settings.dilation_cells);
}

Processor::~Processor() = default;

// Returns at or beyond the scanner's range (or ≤ 0, NaN) become no return. `invalid_ranges` counts them all, NaN
// included: a reader's own no-returns (a CARMEN log's maximum-range readings) count as a SICK's zeros do.
LaserScan Processor::checked(const LaserScan& input, std::int64_t* invalid_ranges) const {
    if (input.scanner < 0 || input.scanner >= static_cast<int>(site_.scanners.size()))
        throw std::runtime_error(input.source + ": scanner " + std::to_string(input.scanner) + " is not in the site file " +
                                 site_.path + " (" + std::to_string(site_.scanners.size()) + " scanners)");
    const ScannerSite& where = site_.scanners[static_cast<std::size_t>(input.scanner)];
    check_layout(input, where);
    if (!std::isfinite(input.time_s))  // it would order the cycles and the tracks' motion: nothing to guess
        throw std::runtime_error(input.source + ": the scan's time is not a finite number");
    LaserScan scan = input;
    scan.time_s += where.time_offset_s;
    for (auto& r : scan.ranges_m)
        if (!(r > 0.0f) || r >= where.max_range_m) {
            if (invalid_ranges) ++*invalid_ranges;
            r = NAN;
        }
    return scan;
}

void Processor::learn_world(const std::vector<LaserScan>& scans) {
    std::vector<LaserScan> posed;
    std::vector<Pose2> poses;
    for (const auto& input : scans) {
        if (!input.pose) continue;
        posed.push_back(checked(input));
        poses.push_back(site_pose(input));
    }
    if (posed.empty()) throw std::invalid_argument(site_.path + ": a world background needs scans with poses; none has one");
    world_.emplace(posed, poses, site_.settings.world);
}

// A scanner's layout stays what its first scan had: its background is per beam, and a beam of another step or first
// angle looks elsewhere (a site file that pins the layout catches it there; most do not).
void Processor::check_same_layout(const LaserScan& scan) const {
    const std::optional<ScanLayout>& first = first_layout_[static_cast<std::size_t>(scan.scanner)];
    const ScanLayout now = layout_of(scan);
    if (first && (first->beams != now.beams || std::abs(first->step_rad - now.step_rad) > 1e-6 * kDeg ||
        std::abs(first->start_angle_rad - now.start_angle_rad) > 1e-4 * kDeg))
        throw std::runtime_error(scan.source + ": the scanner '" + site_.scanners[static_cast<std::size_t>(scan.scanner)].name +
                                 "' changed its layout to " + layout_text(now) + " from " + layout_text(*first) +
                                 " of its first scan: its background is per beam");
}

Pose2 Processor::site_pose(const LaserScan& scan) const {
    const Pose2& mount = site_.scanners[static_cast<std::size_t>(scan.scanner)].pose;
    return scan.pose ? compose(*scan.pose, mount) : mount;
}

std::vector<bool> Processor::world_foreground(const LaserScan& input) const {
    if (!world_) throw std::invalid_argument("no world background learned (Processor::learn_world first)");
    if (!input.pose) throw std::invalid_argument(input.source + ": the scan has no pose");
    const LaserScan scan = checked(input);
    return world_->foreground(scan, site_pose(scan));
}

std::vector<Cycle> Processor::push(const LaserScan& input) {
    std::int64_t invalid = 0;
    LaserScan scan = checked(input, &invalid);
    const ScannerSite& where = site_.scanners[static_cast<std::size_t>(scan.scanner)];
    check_same_layout(scan);
    if (scan.pose && !world_)
        throw std::runtime_error(scan.source + ": the scan carries a pose (a moving scanner): learn the world "
                                 "background from the log first (Processor::learn_world; `roadside run` does)");
    if (!started_) first_time_s_ = scan.time_s, started_ = true;
    auto& st = status_[static_cast<std::size_t>(scan.scanner)];
    if (st.last_scan_s >= 0.0 && scan.time_s + 1e-9 < st.last_scan_s)
        throw std::runtime_error(scan.source + ": scan time goes backwards for scanner '" + where.name + "'");
    // Counted once the cycle this scan closes is out: that cycle's status is of the scans up to its end.
    const auto count_scan = [&] {  // the scan is taken: its scanner's layout is known from here on
        auto& layout = first_layout_[static_cast<std::size_t>(scan.scanner)];
        if (!layout) layout = layout_of(scan);
        st.last_scan_s = scan.time_s;
        ++st.scans;
        st.invalid_ranges += invalid;
    };
    std::vector<Cycle> done;
    BackgroundModel& bg = background_[static_cast<std::size_t>(scan.scanner)];
    if (!scan.pose && !bg.frozen()) {
        // Each scanner learns over its own first seconds, so a scanner that starts late still gets a background.
        double& start = learn_start_s_[static_cast<std::size_t>(scan.scanner)];
        if (bg.learned_scans() == 0) start = scan.time_s;
        if (scan.time_s - start < site_.settings.background_s) {
            bg.learn(scan);
            count_scan();
            return done;
        }
        bg.freeze();
    }
    const long long index = static_cast<long long>(std::floor((scan.time_s - first_time_s_) / site_.settings.cycle_s));
    if (index > cycle_index_ && !pending_.empty())
        done.push_back(run_cycle(first_time_s_ + static_cast<double>(cycle_index_ + 1) * site_.settings.cycle_s));
    cycle_index_ = std::max(cycle_index_, index);
    count_scan();
    pending_.push_back(std::move(scan));
    return done;
}

// CPU time of the calling thread, ms: the cycle's cost without the time other processes take the core.
static double thread_cpu_ms() {
    timespec ts{};
    clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
    return ts.tv_sec * 1e3 + ts.tv_nsec * 1e-6;
}

Cycle Processor::run_cycle(double t_end_s) {
    const double start_ms = thread_cpu_ms();
    std::vector<Point2> points;
    std::vector<Pose2> poses(site_.scanners.size());
    double t_sum = 0.0;
    for (const auto& scan : pending_) {
        const Pose2 pose = site_pose(scan);
        poses[static_cast<std::size_t>(scan.scanner)] = pose;
        const auto fg = scan.pose ? world_->foreground(scan, pose)
                                  : background_[static_cast<std::size_t>(scan.scanner)].foreground(scan, site_.settings.background_margin_m);
        scan_points(scan, pose, fg, points);
        t_sum += scan.time_s;
    }
    const double t_measured = t_sum / static_cast<double>(pending_.size());
    pending_.clear();
    const GridLabels grid = label_points(points, site_.settings.cell_m, site_.settings.dilation_cells);
    std::vector<Measurement> measurements;
    for (auto& o : grid_objects(points, grid, site_.settings.min_points)) {
        Measurement m{t_measured, o, {}};
        for (std::size_t i = 0; i < poses.size(); ++i)
            if (o.scanners & (1u << i)) m.viewpoints.push_back(poses[i]);
        measurements.push_back(std::move(m));
    }
    tracker_.update(t_measured, measurements);
    Cycle c;
    c.t_s = t_end_s;
    c.scan_objects = static_cast<int>(measurements.size());
    associate_camera(t_end_s - site_.settings.cycle_s, t_end_s, c);
    for (const auto& t : tracker_.tracks())
        if (tracker_.confirmed(t)) c.objects.push_back(output(t, t_end_s));
    for (auto& s : status_) s.active = s.last_scan_s >= 0.0 && t_end_s - s.last_scan_s <= site_.settings.scanner_timeout_s;
    c.scanners = status_;
    c.process_ms = thread_cpu_ms() - start_ms;
    return c;
}

double Processor::last_scan_s() const {
    double last = first_time_s_;
    for (const auto& st : status_) last = std::max(last, st.last_scan_s);
    return last;
}

std::size_t Processor::detections_outside_scans() const {
    if (!started_) return detections_.size();
    const double last = last_scan_s();
    return static_cast<std::size_t>(std::count_if(detections_.begin(), detections_.end(), [&](const CameraDetection& d) {
        return d.t_s < first_time_s_ - kCameraMemoryS || d.t_s > last + kCameraMemoryS;
    }));
}

std::string Processor::detections_outside_warning() const {
    const std::size_t outside = detections_outside_scans();
    if (outside == 0 || !started_) return "";
    return std::to_string(outside) + " of " + std::to_string(detections_.size()) + " camera detections lie more "
           "than 1 s outside the scans' time (t = " + number_text(first_time_s_, 10) + "–" + number_text(last_scan_s(), 10) +
           " s on the site clock) and are in no output: check the camera's time_offset_s in the site file (or a "
           "video's start time)";
}

void Processor::add_detections(const std::vector<CameraDetection>& detections) {
    if (!site_.camera) throw std::runtime_error(site_.path + ": camera detections given but the site has no camera");
    for (std::size_t i = 0; i < detections.size(); ++i)  // all or none: a bad one leaves the processor as it was
        check_detection(detections[i], "camera detection " + std::to_string(i) + " (of " +
                                           std::to_string(detections.size()) + ")");
    for (auto d : detections) {
        d.t_s += site_.camera->time_offset_s;
        detections_.push_back(d);
    }
    std::stable_sort(detections_.begin(), detections_.end(),
                     [](const CameraDetection& a, const CameraDetection& b) { return a.t_s < b.t_s; });
}

// The paper's cost between a camera object and a track: position distance (and heading difference where the
// camera gives one), weighted, as an assignment with a gate. Unmatched detections become camera-only objects.
void Processor::associate_camera(double t0_s, double t1_s, Cycle& cycle) {
    if (!site_.camera || detections_.empty()) return;
    const auto first = std::lower_bound(detections_.begin(), detections_.end(), t0_s,
                                        [](const CameraDetection& d, double t) { return d.t_s < t; });
    const auto last = std::lower_bound(first, detections_.end(), t1_s,
                                       [](const CameraDetection& d, double t) { return d.t_s < t; });
    struct Ground {
        const CameraDetection* d;
        double x_m, y_m;
    };
    std::vector<Ground> ground;
    for (auto it = first; it != last; ++it) {
        Ground g{&*it, 0.0, 0.0};  // the box's bottom centre touches the ground
        if (image_to_site(site_.camera->homography, it->x_px + it->w_px / 2.0, it->y_px + it->h_px, g.x_m, g.y_m))
            ground.push_back(g);
    }
    auto& tracks = tracker_.tracks();
    const RoadsideSettings& s = site_.settings;
    std::vector<std::vector<double>> cost(ground.size(), std::vector<double>(tracks.size()));
    for (std::size_t i = 0; i < ground.size(); ++i)
        for (std::size_t j = 0; j < tracks.size(); ++j) {
            const TrackState x = tracker_.predicted(tracks[j], ground[i].d->t_s);
            const double d = std::hypot(x(0) - ground[i].x_m, x(1) - ground[i].y_m);
            cost[i][j] = d > s.camera_gate_m ? INFINITY : s.camera_weight_position * d / s.camera_gate_m;
        }
    std::vector<bool> used(ground.size(), false);
    for (const auto& [i, j] : assign(cost, s.camera_weight_position + s.camera_weight_heading)) {
        Track& t = tracks[static_cast<std::size_t>(j)];
        const CameraDetection& d = *ground[static_cast<std::size_t>(i)].d;
        // The class most voted for over the track's life (scores summed): one wrong detection does not flip it.
        t.class_votes[d.cls] += d.score;
        double total = 0.0, best = 0.0;
        for (const auto& [cls, votes] : t.class_votes) {
            total += votes;
            if (votes > best) best = votes, t.camera_class = cls;
        }
        t.camera_score = best / total;
        t.last_camera_s = d.t_s;
        used[static_cast<std::size_t>(i)] = true;
    }
    for (std::size_t i = 0; i < ground.size(); ++i) {
        if (used[i]) continue;
        OutputObject o;
        o.id = -1;
        o.cls = ground[i].d->cls;
        o.score = ground[i].d->score;
        o.source = "camera";
        o.x_m = ground[i].x_m, o.y_m = ground[i].y_m;
        o.position = geo_.to_wgs84(o.x_m, o.y_m);
        Box b{o.x_m, o.y_m, 0.0, 0.0, 0.0};
        o.mbr_site = b.corners();
        for (int k = 0; k < 4; ++k) o.mbr_wgs84[k] = o.position;
        cycle.objects.push_back(o);
    }
}

OutputObject Processor::output(const Track& t, double t_s) const {
    OutputObject o;
    const TrackState x = tracker_.predicted(t, t_s);
    o.id = t.id;
    o.x_m = x(0), o.y_m = x(1), o.vx_mps = x(2), o.vy_mps = x(3);
    o.speed_mps = std::hypot(x(2), x(3));
    o.heading_rad = o.speed_mps > 0.5 ? std::atan2(x(3), x(2)) : t.box_heading_rad;
    o.length_m = t.length_m, o.width_m = t.width_m;
    const bool camera = !t.camera_class.empty() && t_s - t.last_camera_s <= kCameraMemoryS;
    o.source = camera ? (t_s - t.last_update_s <= site_.settings.max_coast_s ? "both" : "camera") : "laser";
    o.cls = track_class(t);
    o.score = t.camera_class.empty() ? 0.5 : t.camera_score;
    o.position = geo_.to_wgs84(o.x_m, o.y_m);
    o.mbr_site = Box{o.x_m, o.y_m, t.length_m, t.width_m, o.heading_rad}.corners();
    for (int k = 0; k < 4; ++k) o.mbr_wgs84[k] = geo_.to_wgs84(o.mbr_site[k][0], o.mbr_site[k][1]);
    o.points = t.last_object.points;
    o.age_s = t_s - t.first_seen_s;
    o.since_measured_s = std::max(0.0, t_s - t.last_update_s);  // a track coasting behind an occlusion is a guess
    return o;
}

std::vector<Cycle> Processor::finish() {
    std::vector<Cycle> done;
    if (!pending_.empty())
        done.push_back(run_cycle(first_time_s_ + static_cast<double>(cycle_index_ + 1) * site_.settings.cycle_s));
    return done;
}

}  // namespace roadpreview::roadside
