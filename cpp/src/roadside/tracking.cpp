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

Eigen::Vector4d Tracker::predicted(const Track& track, double t_s) const {
    Track copy = track;
    predict(copy, t_s);
    return copy.x;
}

// The object's centre: the L-shape box, grown to the track's learned extent away from the scanner that saw it,
// so that a car seen on one or two sides is not placed at the middle of what is visible.
Eigen::Vector2d Tracker::measured_centre(const Track& t, const Measurement& m) const {
    Box b = m.object.l_shape;
    Eigen::Vector2d centre(b.x_m, b.y_m);
    if (t.hits == 0 || m.viewpoints.empty()) return centre;
    const double along = std::hypot(t.x(2), t.x(3)) > kMovingMps ? std::atan2(t.x(3), t.x(2)) : t.box_heading_rad;
    if (std::abs(wrap_half_turn(b.heading_rad - along)) > kPi / 4.0) {  // the visible length runs across the motion
        std::swap(b.length_m, b.width_m);
        b.heading_rad += kPi / 2.0;
    }
    const Eigen::Vector2d u(std::cos(b.heading_rad), std::sin(b.heading_rad)), v(-u.y(), u.x());
    const Pose2* view = &m.viewpoints[0];
    for (const auto& p : m.viewpoints)
        if (std::hypot(p.x_m - b.x_m, p.y_m - b.y_m) < std::hypot(view->x_m - b.x_m, view->y_m - b.y_m)) view = &p;
    const Eigen::Vector2d away = centre - Eigen::Vector2d(view->x_m, view->y_m);
    const double grow_l = std::max(0.0, t.length_m - b.length_m) / 2.0, grow_w = std::max(0.0, t.width_m - b.width_m) / 2.0;
    centre += (away.dot(u) >= 0 ? 1.0 : -1.0) * grow_l * u + (away.dot(v) >= 0 ? 1.0 : -1.0) * grow_w * v;
    return centre;
}

void Tracker::correct(Track& t, const Measurement& m) {
    const Eigen::Vector2d z = measured_centre(t, m);
    const double r = s_.position_sigma_m * s_.position_sigma_m;
    const Eigen::Matrix2d S = t.P.topLeftCorner<2, 2>() + r * Eigen::Matrix2d::Identity();
    const Eigen::Matrix<double, 4, 2> K = t.P.leftCols<2>() * S.inverse();
    t.x += K * (z - t.x.head<2>());
    t.P = (Eigen::Matrix4d::Identity() - K * (Eigen::Matrix<double, 2, 4>() << 1, 0, 0, 0, 0, 1, 0, 0).finished()) * t.P;
    // Learned extent: along and across the motion (or the box) — the largest seen, not beyond a plausible size.
    const Box& b = m.object.l_shape;
    const bool moving = std::hypot(t.x(2), t.x(3)) > kMovingMps;
    const double along = moving ? std::atan2(t.x(3), t.x(2)) : b.heading_rad;
    const bool crossed = std::abs(wrap_half_turn(b.heading_rad - along)) > kPi / 4.0;
    const double len = crossed ? b.width_m : b.length_m, wid = crossed ? b.length_m : b.width_m;
    if (len < kMaxExtentM && wid < kMaxExtentM) {
        t.length_m = std::max(t.length_m, len);
        t.width_m = std::max(t.width_m, wid);
    }
    t.box_heading_rad = wrap_half_turn(along);
    t.last_box = b;
    t.last_object = m.object;
    t.last_update_s = m.t_s;
    ++t.hits;
}

void Tracker::update(double t_s, const std::vector<Measurement>& measurements) {
    for (auto& t : tracks_) predict(t, t_s);
    const double r = s_.position_sigma_m * s_.position_sigma_m;
    std::vector<std::vector<double>> cost(tracks_.size(), std::vector<double>(measurements.size()));
    for (std::size_t i = 0; i < tracks_.size(); ++i) {
        const Eigen::Matrix2d S_inv = (tracks_[i].P.topLeftCorner<2, 2>() + r * Eigen::Matrix2d::Identity()).inverse();
        for (std::size_t j = 0; j < measurements.size(); ++j) {
            const Eigen::Vector2d d = measured_centre(tracks_[i], measurements[j]) - tracks_[i].x.head<2>();
            cost[i][j] = d.dot(S_inv * d);
        }
    }
    std::vector<bool> used(measurements.size(), false);
    for (const auto& [i, j] : assign(cost, s_.gate_chi2)) {
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
        t.P = Eigen::Vector4d(r, r, 100.0, 100.0).asDiagonal();  // velocity unknown: σ 10 m/s
        correct(t, measurements[j]);
        t.x.head<2>() << measurements[j].object.l_shape.x_m, measurements[j].object.l_shape.y_m;
        tracks_.push_back(t);
    }
}

}  // namespace roadpreview::roadside
