// SPDX-License-Identifier: BSD-3-Clause
// Umbrella header: #include <roadpreview/roadpreview.hpp>
#pragma once

#include "roadpreview/config.hpp"
#include "roadpreview/frames.hpp"
#include "roadpreview/fusion.hpp"
#include "roadpreview/ground.hpp"
#include "roadpreview/io.hpp"
#include "roadpreview/io/ouster.hpp"
#include "roadpreview/io/pcap.hpp"
#include "roadpreview/io/velodyne.hpp"
#include "roadpreview/motion.hpp"
#include "roadpreview/obstacles.hpp"
#include "roadpreview/iri.hpp"
#include "roadpreview/path.hpp"
#include "roadpreview/pipeline.hpp"
#include "roadpreview/profile.hpp"
#include "roadpreview/roughness.hpp"
#include "roadpreview/support.hpp"
#include "roadpreview/version.hpp"
