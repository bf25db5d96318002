// SPDX-License-Identifier: BSD-3-Clause
// Extrinsic calibration of one scanner against another from a static scene: 2-D scan registration (PCL ICP with
// a 2-D rigid transformation estimate) of the two scanners' background scans in the site frame.
#pragma once

#include <vector>

#include "roadpreview/roadside/scan.hpp"

namespace roadpreview::roadside {

struct ExtrinsicsResult {
    Pose2 pose;                  ///< the refined pose of the moving scanner in the site frame
    double fitness_m2 = 0.0;     ///< PCL's fitness score: mean squared distance of the points matched within the
                                 ///< finest gate (max_distance_m / 16), m²
    int matched_points = 0;
    bool converged = false;
};

/// Refines `moving_pose` so that the moving scanner's static scans fall on the fixed scanner's (at `fixed_pose`).
/// Each list's per-beam median range is used (moving objects fade out). `max_distance_m` bounds the
/// correspondences of the first of three ICP passes (then / 4 and / 16; start well within it of the truth). Throws std::invalid_argument when either side has fewer
/// than 20 points or the layouts within a list disagree.
ExtrinsicsResult register_scanners(const std::vector<LaserScan>& fixed, const Pose2& fixed_pose,
                                   const std::vector<LaserScan>& moving, const Pose2& moving_pose,
                                   double max_distance_m = 1.0);

}  // namespace roadpreview::roadside
