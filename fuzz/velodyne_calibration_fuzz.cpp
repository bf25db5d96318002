// SPDX-License-Identifier: BSD-3-Clause
// libFuzzer target: Velodyne calibration YAML (ROS velodyne_pointcloud format).
#include <cstdint>

#include <roadpreview/io/velodyne.hpp>

#include "scratch_file.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    const std::string path = roadpreview_fuzz::scratch_file(data, size, ".yaml");
    roadpreview_fuzz::expect_clean_errors([&] { roadpreview::read_velodyne_calibration(path); });
    return 0;
}
