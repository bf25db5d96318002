// SPDX-License-Identifier: BSD-3-Clause
// Internal: ground extraction on the pipeline's PCL-backed ROI cloud (no copy for RANSAC).
#pragma once

#include "roadpreview/ground/ground.hpp"
#include "core/roi_cloud.hpp"

namespace roadpreview {

GroundFit fit_ground(const RoiCloud& roi, const GroundConfig& cfg);

}  // namespace roadpreview
