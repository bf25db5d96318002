// SPDX-License-Identifier: BSD-3-Clause
// libFuzzer target: PLY files (ascii, binary little and big endian) through read_frame.
#include <cstdint>

#include "scratch_file.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    roadpreview_fuzz::read_cloud_file(data, size, ".ply");
    return 0;
}
