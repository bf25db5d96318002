// SPDX-License-Identifier: BSD-3-Clause
// Constant-velocity Kalman tracks, gated Hungarian assignment (dlib), and the visible-corner centre correction.
#include "roadpreview/roadside/tracking.hpp"

#include <dlib/optimization/max_cost_assignment.h>

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <limits>

namespace roadpreview::roadside {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kCostScale = 1000.0;   // dlib solves integer costs: 1/1000 of the cost unit
constexpr double kMaxExtentM = 20.0;    // a component longer than this is a merge, not one object's extent
constexpr double kMovingMps = 1.0;      // faster: the velocity tells which box side is the length

double wrap_half_turn(double a) {  // to (−π/2, π/2]: box axes have no direction
    while (a > kPi / 2.0) a -= kPi;
    while (a <= -kPi / 2.0) a += kPi;
    return a;
}

}  // namespace

std::vector<std::pair<int, int>> assign(const std::vector<std::vector<double>>& cost, double gate) {
    const auto rows = static_cast<long>(cost.size());
    const long cols = rows ? static_cast<long>(cost[0].size()) : 0;
    std::vector<std::pair<int, int>> out;
    if (rows == 0 || cols == 0) return out;
    const long n = std::max(rows, cols);
    // Profit = big − cost for gated pairs, 0 otherwise: with big above any sum of costs, the solver first makes
    // as many gated pairs as possible and among those minimises the total cost.
    const long gate_units = static_cast<long>(std::ceil(gate * kCostScale)) + 1;
    const long big = gate_units * (n + 1);
    dlib::matrix<long> profit(n, n);
    profit = 0;
    for (long r = 0; r < rows; ++r)
        for (long c = 0; c < cols; ++c) {
            const double v = cost[static_cast<std::size_t>(r)][static_cast<std::size_t>(c)];
            if (std::isfinite(v) && v <= gate) profit(r, c) = big - static_cast<long>(std::llround(std::max(v, 0.0) * kCostScale));
        }
    const std::vector<long> match = dlib::max_cost_assignment(profit);
    for (long r = 0; r < rows; ++r)
        if (match[static_cast<std::size_t>(r)] < cols && profit(r, match[static_cast<std::size_t>(r)]) > 0)
            out.emplace_back(static_cast<int>(r), static_cast<int>(match[static_cast<std::size_t>(r)]));
    return out;
}

void Tracker::predict(Track& t, double t_s) const {
    const double dt = t_s - t.t_s;
    if (dt <= 0.0) return;
    Eigen::Matrix4d F = Eigen::Matrix4d::Identity();
    F(0, 2) = F(1, 3) = dt;
    const double q = s_.accel_sigma_mps2 * s_.accel_sigma_mps2;
    Eigen::Matrix4d Q = Eigen::Matrix4d::Zero();
    Q(0, 0) = Q(1, 1) = q * dt * dt * dt * dt / 4.0;
    Q(0, 2) = Q(2, 0) = Q(1, 3) = Q(3, 1) = q * dt * dt * dt / 2.0;
    Q(2, 2) = Q(3, 3) = q * dt * dt;
    t.x = F * t.x;
    t.P = F * t.P * F.transpose() + Q;
    t.t_s = t_s;
}

TrackState Tracker::predicted(const Track& track, double t_s) const {
    Track copy = track;
    predict(copy, t_s);
    return copy.x;
}

std::string shape_class(double length_m, double width_m, double speed_mps) {
    if (length_m >= 2.6 || width_m >= 1.4) return "car";
    if (length_m >= 1.2 || speed_mps > 2.5) return "cyclist";
    return "pedestrian";
}

std::string extent_class(const Track& t) {
    if (!t.camera_class.empty()) return t.camera_class;
    return shape_class(t.length_m, t.width_m, std::hypot(t.x(2), t.x(3)));
}

std::string track_class(const Track& t) {
    if (!t.camera_class.empty()) return t.camera_class;
    std::string best;
    int most = 0;
    for (const char* cls : {"car", "cyclist", "pedestrian"}) {  // a tie goes to the larger class
        const auto it = t.shape_votes.find(cls);
        if (it != t.shape_votes.end() && it->second > most) most = it->second, best = cls;
    }
    return most > 0 ? best : extent_class(t);
}

// The measured box, length along the track's motion: for a moving track the extent of the points along and
// across its velocity (robust on a few far points), else the L-shape box.
bool Tracker::correcting(const Track& t) const {
    return t.hits >= s_.confirm_hits && std::hypot(t.x(2), t.x(3)) > kMovingMps;
}

Box Tracker::measured_box(const Track& t, const Measurement& m) const {
    Box b = m.object.l_shape;
    if (!correcting(t) || m.object.members.empty()) {
        if (t.hits > 0 && std::abs(wrap_half_turn(b.heading_rad - t.box_heading_rad)) > kPi / 4.0) {
            std::swap(b.length_m, b.width_m);
            b.heading_rad += kPi / 2.0;
        }
        return b;
    }
    const double h = std::atan2(t.x(3), t.x(2)), c = std::cos(h), s = std::sin(h);
    double lo1 = INFINITY, hi1 = -INFINITY, lo2 = INFINITY, hi2 = -INFINITY;
    for (const auto& p : m.object.members) {
        const double c1 = c * p.x_m + s * p.y_m, c2 = -s * p.x_m + c * p.y_m;
        lo1 = std::min(lo1, c1), hi1 = std::max(hi1, c1), lo2 = std::min(lo2, c2), hi2 = std::max(hi2, c2);
    }
    const double m1 = (lo1 + hi1) / 2.0, m2 = (lo2 + hi2) / 2.0;
    return {c * m1 - s * m2, s * m1 + c * m2, hi1 - lo1, hi2 - lo2, h};
}

// The object's centre: the measured box grown to the track's extent (learned, at least its class's) away from
// the scanner that saw it, so that a car seen on one or two sides is not placed in the middle of what is visible.
Eigen::Vector2d Tracker::measured_centre(const Track& t, const Measurement& m) const {
    const Box b = measured_box(t, m);
    Eigen::Vector2d centre(b.x_m, b.y_m);
    if (!correcting(t) || m.viewpoints.empty()) return centre;
    double length = t.length_m, width = t.width_m;
    const auto prior = s_.class_extent_m.find(extent_class(t));
    if (prior != s_.class_extent_m.end()) length = std::max(length, prior->second.first), width = std::max(width, prior->second.second);
    const Eigen::Vector2d u(std::cos(b.heading_rad), std::sin(b.heading_rad)), v(-u.y(), u.x());
    const Pose2* view = &m.viewpoints[0];
    for (const auto& p : m.viewpoints)
        if (std::hypot(p.x_m - b.x_m, p.y_m - b.y_m) < std::hypot(view->x_m - b.x_m, view->y_m - b.y_m)) view = &p;
    const Eigen::Vector2d away = centre - Eigen::Vector2d(view->x_m, view->y_m);
    const double grow_l = std::max(0.0, length - b.length_m) / 2.0, grow_w = std::max(0.0, width - b.width_m) / 2.0;
    centre += (away.dot(u) >= 0 ? 1.0 : -1.0) * grow_l * u + (away.dot(v) >= 0 ? 1.0 : -1.0) * grow_w * v;
    return centre;
}

double Tracker::measurement_variance(const Measurement& m) const {
    double range = 0.0;  // to the nearest scanner that saw it
    for (const auto& p : m.viewpoints) {
        const double d = std::hypot(p.x_m - m.object.l_shape.x_m, p.y_m - m.object.l_shape.y_m);
        range = range == 0.0 ? d : std::min(range, d);
    }
    const double sigma = s_.position_sigma_m + s_.sigma_per_range * range;
    return sigma * sigma;
}

// Squared Mahalanobis distance of a measurement to a track: the smaller of its corrected centre against the
// predicted centre and its visible centre against the predicted one less the last offset (so that neither the
// correction switching on nor a side coming into view breaks the track).
double Tracker::cost(const Track& t, const Measurement& m) const {
    constexpr double kCentreJumpM = 1.0;  // a partly seen object's centre moves by about its size between views
    if (s_.max_speed_mps > 0.0 &&
        std::hypot(m.object.centroid_x_m - t.last_object.centroid_x_m, m.object.centroid_y_m - t.last_object.centroid_y_m) >
            s_.max_speed_mps * (m.t_s - t.last_update_s) + kCentreJumpM)
        return INFINITY;
    const Eigen::Matrix2d S_inv = (t.P.topLeftCorner<2, 2>() + measurement_variance(m) * Eigen::Matrix2d::Identity()).inverse();
    const Box b = measured_box(t, m);
    const Eigen::Vector2d d1 = measured_centre(t, m) - t.x.head<2>();
    const Eigen::Vector2d d2 = Eigen::Vector2d(b.x_m, b.y_m) + t.visible_offset - t.x.head<2>();
    return std::min(d1.dot(S_inv * d1), d2.dot(S_inv * d2));
}

void Tracker::correct(Track& t, const Measurement& m) {
    const Eigen::Vector2d z = measured_centre(t, m);
    const Box visible = measured_box(t, m);
    const Eigen::Vector2d offset = z - Eigen::Vector2d(visible.x_m, visible.y_m);
    if (correcting(t) && !t.corrected) {  // the correction switches on: move the state with it, once
        t.x.head<2>() += offset - t.visible_offset;
        t.corrected = true;
    }
    t.visible_offset = offset;
    const double r = measurement_variance(m);
    const Eigen::Matrix2d S = t.P.topLeftCorner<2, 2>() + r * Eigen::Matrix2d::Identity();
    const Eigen::Matrix<double, 4, 2> K = t.P.leftCols<2>() * S.inverse();
    t.x += K * (z - t.x.head<2>());
    t.P = (Eigen::Matrix4d::Identity() - K * (Eigen::Matrix<double, 2, 4>() << 1, 0, 0, 0, 0, 1, 0, 0).finished()) * t.P;
    // Learned extent along and across the motion: the largest seen, not beyond a plausible size.
    const Box b = measured_box(t, m);
    if (b.length_m < kMaxExtentM && b.width_m < kMaxExtentM) {
        t.length_m = std::max(t.length_m, b.length_m);
        t.width_m = std::max(t.width_m, b.width_m);
        ++t.shape_votes[shape_class(b.length_m, b.width_m, std::hypot(t.x(2), t.x(3)))];
    }
    t.box_heading_rad = wrap_half_turn(b.heading_rad);
    t.last_box = b;
    t.last_object = m.object;
    t.last_update_s = m.t_s;
    ++t.hits;
}

// An object split in two by an occlusion shadow (a pole, another road user) gives two components: the components
// whose centroids fall in a moving track's predicted box (its extent, at least its class's, + 0.5 m) are one.
std::vector<Measurement> Tracker::merge_splits(std::vector<Measurement> measurements) const {
    constexpr double kMarginM = 0.5;
    std::vector<bool> gone(measurements.size(), false);
    for (const auto& t : tracks_) {
        if (!correcting(t)) continue;
        double length = t.length_m, width = t.width_m;
        const auto prior = s_.class_extent_m.find(extent_class(t));
        if (prior != s_.class_extent_m.end()) length = std::max(length, prior->second.first), width = std::max(width, prior->second.second);
        const double h = std::atan2(t.x(3), t.x(2)), c = std::cos(h), s = std::sin(h);
        std::vector<std::size_t> inside;
        for (std::size_t j = 0; j < measurements.size(); ++j) {
            if (gone[j]) continue;
            const double dx = measurements[j].object.centroid_x_m - t.x(0), dy = measurements[j].object.centroid_y_m - t.x(1);
            if (std::abs(c * dx + s * dy) <= (length + kMarginM) / 2.0 && std::abs(-s * dx + c * dy) <= (width + kMarginM) / 2.0)
                inside.push_back(j);
        }
        if (inside.size() < 2) continue;
        Measurement& into = measurements[inside[0]];
        for (std::size_t k = 1; k < inside.size(); ++k) {
            const Measurement& from = measurements[inside[k]];
            into.object.members.insert(into.object.members.end(), from.object.members.begin(), from.object.members.end());
            into.object.scanners |= from.object.scanners;
            into.object.cells += from.object.cells;
            for (const auto& v : from.viewpoints) into.viewpoints.push_back(v);
            gone[inside[k]] = true;
        }
        ScanObject& o = into.object;
        o.points = static_cast<int>(o.members.size());
        o.centroid_x_m = o.centroid_y_m = 0.0;
        for (const auto& p : o.members) o.centroid_x_m += p.x_m / o.points, o.centroid_y_m += p.y_m / o.points;
        o.l_shape = fit_l_shape(o.members);
    }
    std::vector<Measurement> out;
    for (std::size_t j = 0; j < measurements.size(); ++j)
        if (!gone[j]) out.push_back(std::move(measurements[j]));
    return out;
}

void Tracker::update(double t_s, const std::vector<Measurement>& input) {
    for (auto& t : tracks_) predict(t, t_s);
    const std::vector<Measurement> measurements = merge_splits(input);
    std::vector<std::vector<double>> costs(tracks_.size(), std::vector<double>(measurements.size()));
    for (std::size_t i = 0; i < tracks_.size(); ++i)
        for (std::size_t j = 0; j < measurements.size(); ++j) costs[i][j] = cost(tracks_[i], measurements[j]);
    std::vector<bool> used(measurements.size(), false);
    for (const auto& [i, j] : assign(costs, s_.gate_chi2)) {
        correct(tracks_[static_cast<std::size_t>(i)], measurements[static_cast<std::size_t>(j)]);
        used[static_cast<std::size_t>(j)] = true;
    }
    tracks_.erase(std::remove_if(tracks_.begin(), tracks_.end(),
                                 [&](const Track& t) { return t_s - t.last_update_s > s_.max_coast_s; }),
                  tracks_.end());
    for (std::size_t j = 0; j < measurements.size(); ++j) {
        if (used[j]) continue;
        Track t;
        t.id = next_id_++;
        t.t_s = t.first_seen_s = t_s;
        t.x << measurements[j].object.l_shape.x_m, measurements[j].object.l_shape.y_m, 0.0, 0.0;
        const double r = measurement_variance(measurements[j]);
        t.P = Eigen::Vector4d(r, r, 100.0, 100.0).asDiagonal();  // velocity unknown: σ 10 m/s
        correct(t, measurements[j]);
        t.x.head<2>() << measurements[j].object.l_shape.x_m, measurements[j].object.l_shape.y_m;
        tracks_.push_back(t);
    }
}

}  // namespace roadpreview::roadside
