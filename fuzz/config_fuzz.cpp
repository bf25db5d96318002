// SPDX-License-Identifier: BSD-3-Clause
// libFuzzer target: pipeline configuration files, JSON (first byte even) or YAML (odd), parsed and validated.
#include <cstdint>

#include <roadpreview/core/config.hpp>

#include "scratch_file.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    if (size < 1) return 0;
    const std::string path = roadpreview_fuzz::scratch_file(data + 1, size - 1, data[0] & 1 ? ".yaml" : ".json");
    roadpreview_fuzz::expect_clean_errors([&] { roadpreview::validate(roadpreview::config_from_file(path)); });
    return 0;
}
