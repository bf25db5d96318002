// SPDX-License-Identifier: BSD-3-Clause
// Tracks: one constant-velocity Kalman filter per object, gated assignment of measurements (dlib's Hungarian
// solver), stable ids, velocity and heading, and an extent learned over the track so that a partly seen object's
// centre can be placed from its visible corner.
#pragma once

#include <Eigen/Core>
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

struct Track {
    int id = 0;
    Eigen::Vector4d x = Eigen::Vector4d::Zero();      ///< x, y, vx, vy (site frame, m and m/s)
    Eigen::Matrix4d P = Eigen::Matrix4d::Identity();
    double t_s = 0.0;                                  ///< time of the state
    double last_update_s = 0.0, first_seen_s = 0.0;
    int hits = 0;
    double length_m = 0.0, width_m = 0.0, box_heading_rad = 0.0;  ///< learned extent and last box orientation
    Box last_box;
    ScanObject last_object;
    std::string camera_class;                                     ///< from the camera, "" when none
    double camera_score = 0.0;
    double last_camera_s = -1e300;
};

struct TrackerSettings {
    double accel_sigma_mps2 = 3.0, position_sigma_m = 0.08, gate_chi2 = 13.8, max_coast_s = 0.6;
    int confirm_hits = 3;
};

class Tracker {
public:
    explicit Tracker(TrackerSettings settings) : s_(settings) {}
    /// Predicts every track to the measurements' time, assigns, updates, starts and drops tracks.
    void update(double t_s, const std::vector<Measurement>& measurements);
    /// A track's state predicted to `t_s` (not stored).
    Eigen::Vector4d predicted(const Track& track, double t_s) const;
    std::vector<Track>& tracks() { return tracks_; }
    const std::vector<Track>& tracks() const { return tracks_; }
    bool confirmed(const Track& t) const { return t.hits >= s_.confirm_hits; }

private:
    void predict(Track& t, double t_s) const;
    Eigen::Vector2d measured_centre(const Track& t, const Measurement& m) const;
    void correct(Track& t, const Measurement& m);
    TrackerSettings s_;
    std::vector<Track> tracks_;
    int next_id_ = 1;
};

}  // namespace roadpreview::roadside
