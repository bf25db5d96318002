// SPDX-License-Identifier: BSD-3-Clause
// libFuzzer target: the stereo input's PNGs (libpng with roadpreview's size checks) as an image pair and as a
// disparity image.
#include <cstdint>
#include <cstdlib>

#include <roadpreview/io/stereo.hpp>

#include "scratch_file.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    const std::string path = roadpreview_fuzz::scratch_file(data, size, ".png");
    roadpreview_fuzz::expect_clean_errors([&] {
        const roadpreview::StereoImages pair = roadpreview::read_stereo_pair(path, path);
        if (pair.left != pair.right) std::abort();
    });
    roadpreview_fuzz::expect_clean_errors([&] { roadpreview::read_disparity_png(path); });
    return 0;
}
