// SPDX-License-Identifier: BSD-3-Clause
// Internal: the PCA plane fit shared by every ground method (docs/method.md §1), from accumulated moments.
#pragma once

#include <cstdint>
#include <optional>

#include <Eigen/Core>

#include "roadpreview/ground/ground.hpp"

namespace roadpreview {

// First and second moments of a point set, accumulated about a shift point so that the one-pass
// covariance keeps its precision far from the origin.
struct Moments {
    Eigen::Vector3d shift = Eigen::Vector3d::Zero();
    Eigen::Vector3d sum = Eigen::Vector3d::Zero();
    Eigen::Matrix3d outer = Eigen::Matrix3d::Zero();  // Σ q·qᵀ, lower triangle
    std::int64_t count = 0;

    void add(const Eigen::Vector3d& p) {
        if (count == 0) shift = p;
        const double x = p.x() - shift.x(), y = p.y() - shift.y(), z = p.z() - shift.z();
        sum += Eigen::Vector3d(x, y, z);
        // The lower triangle only (plane_fit mirrors it): the ground stages add every ROI point several times.
        outer(0, 0) += x * x;
        outer(1, 0) += y * x;
        outer(2, 0) += z * x;
        outer(1, 1) += y * y;
        outer(2, 1) += z * y;
        outer(2, 2) += z * z;
        ++count;
    }

    // The inverse of add (the same shift): a fit whose kept points change a little updates its moments by the
    // change. With none left, back to empty, so that the next point sets a fresh shift.
    void remove(const Eigen::Vector3d& p) {
        if (--count == 0) {
            *this = Moments{};
            return;
        }
        const double x = p.x() - shift.x(), y = p.y() - shift.y(), z = p.z() - shift.z();
        sum -= Eigen::Vector3d(x, y, z);
        outer(0, 0) -= x * x;
        outer(1, 0) -= y * x;
        outer(2, 0) -= z * x;
        outer(1, 1) -= y * y;
        outer(2, 1) -= z * y;
        outer(2, 2) -= z * z;
    }
};

struct PlaneFit {
    Plane plane;
    Eigen::Vector3d centre;   ///< mean of the points (on the plane)
    double flatness_m2 = 0.0; ///< smallest covariance eigenvalue: mean squared distance from the plane
    double breadth_m2 = 0.0;  ///< middle eigenvalue: the points' spread across their longest direction
};

/// PCA plane of the moments; nullopt for fewer than 3 points or collinear/coincident points.
std::optional<PlaneFit> plane_fit(const Moments& m);

/// Angle (degrees) between the plane's normal and the base frame's up axis.
double tilt_deg(const Plane& plane);

/// The paper's plane fit to accept or reject: within the tilt limit.
inline bool within_tilt(const Plane& plane, double max_tilt_deg) { return tilt_deg(plane) <= max_tilt_deg; }

}  // namespace roadpreview
