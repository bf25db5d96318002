// SPDX-License-Identifier: BSD-3-Clause
// libFuzzer target: KITTI .bin files (float32 x, y, z, intensity) through read_frame.
#include <cstdint>
#include <cstdlib>

#include <roadpreview/io/readers.hpp>

#include "scratch_file.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    const std::string path = roadpreview_fuzz::scratch_file(data, size, ".bin");
    roadpreview_fuzz::expect_clean_errors([&] {
        const roadpreview::Frame frame = roadpreview::read_frame(path);
        // A .bin holds whole rows of 4 floats, nothing else: any other size must have been refused.
        if (static_cast<std::size_t>(frame.points.rows()) * 16 != size) std::abort();
    });
    return 0;
}
