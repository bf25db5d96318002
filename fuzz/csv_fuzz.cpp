// SPDX-License-Identifier: BSD-3-Clause
// libFuzzer target: the motion table CSV (first byte even) and KITTI poses files (odd).
#include <cstdint>

#include <roadpreview/fusion/fusion.hpp>
#include <roadpreview/paths/motion.hpp>

#include "scratch_file.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    if (size < 1) return 0;
    const bool poses = data[0] & 1;
    const std::string path = roadpreview_fuzz::scratch_file(data + 1, size - 1, poses ? ".txt" : ".csv");
    roadpreview_fuzz::expect_clean_errors([&] {
        if (poses) {
            roadpreview::read_kitti_poses(path);
            return;
        }
        const auto table = roadpreview::MotionTable::read_csv(path);
        for (double t : {-1e9, 0.0, 0.5, 1.0, 1e9}) {
            try {
                table.at(t);
            } catch (const std::runtime_error&) {  // outside the table's span
            }
        }
    });
    return 0;
}
