// SPDX-License-Identifier: BSD-3-Clause
// Tracks: one constant-velocity Kalman filter per object, gated assignment of measurements (dlib's Hungarian
// solver), stable ids, velocity and heading, and an extent learned over the track so that a partly seen object's
// centre can be placed from its visible corner.
#pragma once

#include <Eigen/Core>
#include <map>
#include <string>
#include <utility>
#include <vector>

#include "roadpreview/roadside/objects.hpp"

namespace roadpreview::roadside {

/// Minimum-cost assignment of rows to columns; pairs with cost > `gate` (or not finite) are never made.
/// Returns (row, column) pairs. Solved with dlib::max_cost_assignment on a padded square matrix.
std::vector<std::pair<int, int>> assign(const std::vector<std::vector<double>>& cost, double gate);

struct Measurement {
    double t_s = 0.0;
    ScanObject object;
    std::vector<Pose2> viewpoints;  ///< positions of the scanners that saw it (for the L-shape correction)
};

/// A track's state x, y, vx, vy (site frame, m and m/s), its covariance, and a 2D offset, stored unaligned: under
/// AVX Eigen aligns a 32-byte fixed-size matrix to 32 bytes, so a Track of aligned types would lay out differently
/// in a program built with -mavx than in the library built without it.
using TrackState = Eigen::Matrix<double, 4, 1, Eigen::DontAlign>;
using TrackCovariance = Eigen::Matrix<double, 4, 4, Eigen::DontAlign>;
using TrackOffset = Eigen::Matrix<double, 2, 1, Eigen::DontAlign>;

struct Track {
    int id = 0;
    TrackState x = TrackState::Zero();      ///< x, y, vx, vy (site frame, m and m/s)
    TrackCovariance P = TrackCovariance::Identity();
    double t_s = 0.0;                                  ///< time of the state
    double last_update_s = 0.0, first_seen_s = 0.0;
    int hits = 0;
    double length_m = 0.0, width_m = 0.0, box_heading_rad = 0.0;  ///< learned extent and last box orientation
    Box last_box;
    TrackOffset visible_offset = TrackOffset::Zero();              ///< centre − visible box centre, last update
    bool corrected = false;                                        ///< the visible-corner correction is on
    ScanObject last_object;
    std::string camera_class;                                     ///< from the camera, "" when none
    double camera_score = 0.0;                                    ///< its share of the camera's votes
    std::map<std::string, double> class_votes;                    ///< summed detection scores per class
    std::map<std::string, int> shape_votes;                       ///< updates whose box and speed gave each class
    double last_camera_s = -1e300;
};

struct TrackerSettings {
    double accel_sigma_mps2 = 3.0, position_sigma_m = 0.08, gate_chi2 = 13.8, max_coast_s = 1.2;
    double sigma_per_range = 0.005;  ///< measurement σ grows by this per metre of range (beam spacing, few points)
    int confirm_hits = 6;
    /// The fastest an object may move: a measurement whose centre lies farther from a track's last one than
    /// max_speed_mps · dt + 1 m is never assigned to it (0: no limit). Matters when scans are seconds apart.
    double max_speed_mps = 0.0;
    /// Smallest extent (length, width) of each class, m: the visible-corner correction of a car seen only from
    /// its front uses the car's, not the 10 cm of it the scanners saw.
    std::map<std::string, std::pair<double, double>> class_extent_m = {
        {"car", {4.5, 1.8}}, {"cyclist", {1.75, 0.5}}, {"pedestrian", {0.0, 0.0}}};
};

/// The class of a box of this length and width moving at this speed (docs/method.md §13.9): length ≥ 2.6 m or
/// width ≥ 1.4 m is a car; length ≥ 1.2 m or faster than 2.5 m/s a cyclist; else a pedestrian.
std::string shape_class(double length_m, double width_m, double speed_mps);

/// The class of a track's size: the camera's when it has one, else the shape_class of its learned extent (the
/// largest seen) and speed. Its class's smallest extent (class_extent_m) places a partly seen object's centre.
std::string extent_class(const Track& t);

/// The class a track is reported as: the camera's when it has one, else the shape_class most of its updates gave
/// (a tie to the larger class; before any update, its extent_class). The largest extent seen is no class: two
/// people walking together for a moment made a pedestrian's track a car for good.
std::string track_class(const Track& t);

class Tracker {
public:
    explicit Tracker(TrackerSettings settings) : s_(settings) {}
    /// Predicts every track to the measurements' time, assigns, updates, starts and drops tracks.
    void update(double t_s, const std::vector<Measurement>& measurements);
    /// A track's state predicted to `t_s` (not stored).
    TrackState predicted(const Track& track, double t_s) const;
    std::vector<Track>& tracks() { return tracks_; }
    const std::vector<Track>& tracks() const { return tracks_; }
    bool confirmed(const Track& t) const { return t.hits >= s_.confirm_hits; }

private:
    void predict(Track& t, double t_s) const;
    Eigen::Vector2d measured_centre(const Track& t, const Measurement& m) const;
    Box measured_box(const Track& t, const Measurement& m) const;
    bool correcting(const Track& t) const;
    std::vector<Measurement> merge_splits(std::vector<Measurement> measurements) const;
    double cost(const Track& t, const Measurement& m) const;
    double measurement_variance(const Measurement& m) const;
    void correct(Track& t, const Measurement& m);
    TrackerSettings s_;
    std::vector<Track> tracks_;
    int next_id_ = 1;
};

}  // namespace roadpreview::roadside
