// SPDX-License-Identifier: BSD-3-Clause
// libFuzzer target: Ouster sensor metadata JSON (legacy flat and firmware 2.x/3.x nested layouts).
#include <cstdint>
#include <string>

#include <roadpreview/io/ouster.hpp>

#include "scratch_file.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    const std::string text(reinterpret_cast<const char*>(data), size);
    roadpreview_fuzz::expect_clean_errors([&] { roadpreview::parse_ouster_metadata(text, "fuzz.json"); });
    return 0;
}
