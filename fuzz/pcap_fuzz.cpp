// SPDX-License-Identifier: BSD-3-Clause
// libFuzzer target: pcap/pcapng recordings through open_frames and the streamed frames, as Ouster (with a
// real metadata file) when the first byte is odd, else as whatever the packets say (Velodyne detection).
#include <cstdint>

#include <roadpreview/io/frame_source.hpp>
#include <roadpreview/io/readers.hpp>

#include "scratch_file.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    if (size < 1) return 0;
    roadpreview::SourceOptions options;
    if (data[0] & 1) options.meta = ROADPREVIEW_TEST_DATA "/ouster/OS-1-32-G_v2.1.1_1024x10.json";
    options.skip_bad_packets = data[0] & 2;
    const std::string path = roadpreview_fuzz::scratch_file(data + 1, size - 1, ".pcap");
    roadpreview_fuzz::expect_clean_errors([&] {
        auto source = roadpreview::open_frames({path}, options);
        for (int frames = 0; frames < 64 && source->next(); ++frames) {
        }
    });
    return 0;
}
