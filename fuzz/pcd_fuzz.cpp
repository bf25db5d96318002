// SPDX-License-Identifier: BSD-3-Clause
// libFuzzer target: PCD files in every encoding (ascii, binary, binary_compressed) through read_frame.
#include <cstdint>
#include <cstdlib>

#include <roadpreview/io/readers.hpp>

#include "scratch_file.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    const std::string path = roadpreview_fuzz::scratch_file(data, size, ".pcd");
    roadpreview_fuzz::expect_clean_errors([&] {
        const roadpreview::Frame frame = roadpreview::read_frame(path);
        if (frame.points.rows() > static_cast<Eigen::Index>(size)) std::abort();  // more points than bytes
    });
    return 0;
}
