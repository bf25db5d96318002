// SPDX-License-Identifier: BSD-3-Clause
// Umbrella header: #include <roadpreview/roadpreview.hpp>
#pragma once

#include "roadpreview/core/config.hpp"
#include "roadpreview/core/frames.hpp"
#include "roadpreview/fusion/fusion.hpp"
#include "roadpreview/ground/ground.hpp"
#include "roadpreview/io/readers.hpp"
#include "roadpreview/io/ouster.hpp"
#include "roadpreview/io/pcap.hpp"
#include "roadpreview/io/velodyne.hpp"
#include "roadpreview/io/stereo.hpp"
#include "roadpreview/paths/motion.hpp"
#include "roadpreview/obstacles/obstacles.hpp"
#include "roadpreview/roughness/iri.hpp"
#include "roadpreview/paths/path.hpp"
#include "roadpreview/pipeline/pipeline.hpp"
#include "roadpreview/profile/profile.hpp"
#include "roadpreview/roughness/roughness.hpp"
#include "roadpreview/roughness/support.hpp"
#include "roadpreview/version.hpp"
