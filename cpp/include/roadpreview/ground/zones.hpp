// SPDX-License-Identifier: BSD-3-Clause
// Zone ground (docs/method.md §1, method "zones"): a concentric zone model of the front ROI — rings of
// horizontal distance × sectors of azimuth, after Patchwork (Lim et al., RA-L 2021) — with the paper's
// iterative PCA plane fit in each patch and uprightness, elevation and flatness tests, so that the ground
// follows grades, crests, banking and kerbs.
#pragma once

#include <cstdint>
#include <vector>

#include "roadpreview/core/config.hpp"
#include "roadpreview/core/points.hpp"
#include "roadpreview/ground/ground.hpp"

namespace roadpreview {

/// Patch index of each point (ring-major: the sectors of ring 0 first), −1 outside every ring.
std::vector<std::int32_t> zone_patches(PointsView points, const GroundConfig& cfg);

/// Zone ground of base-frame `points` (all of them candidates: crop to the ROI first). The plane is the PCA
/// plane of all ground points.
GroundFit zone_ground(PointsView points, const GroundConfig& cfg);

}  // namespace roadpreview
