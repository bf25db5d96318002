// SPDX-License-Identifier: BSD-3-Clause
// libFuzzer target: stereo calibration files, KITTI calib.txt (first byte even) or YAML (odd), and the road rows
// and camera pose they give.
#include <cstdint>
#include <cstdlib>

#include <roadpreview/io/stereo.hpp>

#include "scratch_file.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    if (size < 1) return 0;
    const std::string path = roadpreview_fuzz::scratch_file(data + 1, size - 1, data[0] & 1 ? ".yaml" : ".txt");
    roadpreview_fuzz::expect_clean_errors([&] {
        const roadpreview::StereoCalibration calib = roadpreview::read_stereo_calibration(path);
        roadpreview::Config config;
        if (!calib.extrinsics) config.sensor_height = 1.65;  // else the file's pose is used
        const roadpreview::Extrinsics camera = roadpreview::stereo_camera_pose(config, calib);
        const int row = roadpreview::first_road_row(calib, camera, 375, config.stereo);
        if (row < 0 || row > 375) std::abort();
    });
    return 0;
}
