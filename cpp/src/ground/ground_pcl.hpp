// SPDX-License-Identifier: BSD-3-Clause
// Internal: ground extraction on the pipeline's PCL-backed ROI cloud (no copy for RANSAC).
#pragma once

#include <memory>

#include "roadpreview/ground/ground.hpp"
#include "core/roi_cloud.hpp"

namespace roadpreview {

GroundFit fit_ground(const RoiCloud& roi, const GroundConfig& cfg);

struct ZoneScratch;

/// The pipeline's buffers of the ground stage (the zones'; PCA needs none; RANSAC allocates inside PCL).
struct GroundScratch {
    GroundScratch();
    ~GroundScratch();
    std::unique_ptr<ZoneScratch> zones;  // made on first use
};

/// fit_ground into `out`, reusing its mask and the scratch; the zones on up to `threads` threads.
void fit_ground(const RoiCloud& roi, const GroundConfig& cfg, GroundScratch& scratch, GroundFit& out, int threads = 1);

}  // namespace roadpreview
