// SPDX-License-Identifier: BSD-3-Clause
// libFuzzer target for the roadside inputs. First byte: 0 one SICK telegram (CoLa-A or CoLa-B), 1 a byte stream
// cut into telegrams by the framer and each decoded, 2 a site file (YAML), 3 a scan CSV, 4 a detections CSV,
// 5 a CARMEN log, 6 a detections JSONL.
#include <cstdint>

#include <roadpreview/roadside/processor.hpp>
#include <roadpreview/roadside/scan.hpp>
#include <roadpreview/roadside/sick.hpp>

#include "scratch_file.hpp"

namespace rs = roadpreview::roadside;

namespace {

void decode(const std::uint8_t* data, std::size_t size) {
    if (const auto t = rs::decode_sick_telegram(data, size, "fuzz")) rs::to_laser_scan(*t, "fuzz");
}

void decode_stream(const std::uint8_t* data, std::size_t size) {
    rs::SickStreamFramer framer(1 << 16);
    std::vector<std::uint8_t> frame;
    for (std::size_t i = 0; i < size; i += 997) {  // fed in pieces, as TCP segments arrive
        framer.feed(data + i, std::min<std::size_t>(997, size - i));
        while (framer.next(frame)) {
            try {
                decode(frame.data(), frame.size());
            } catch (const std::runtime_error&) {
            }
        }
    }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    if (size < 1) return 0;
    const std::uint8_t kind = data[0] % 7;
    ++data, --size;
    roadpreview_fuzz::expect_clean_errors([&] {
        switch (kind) {
            case 0: decode(data, size); break;
            case 1: decode_stream(data, size); break;
            case 2: rs::parse_site(std::string(reinterpret_cast<const char*>(data), size), "fuzz"); break;
            case 3: rs::read_scan_csv(roadpreview_fuzz::scratch_file(data, size, ".csv")); break;
            case 4: rs::read_detections(roadpreview_fuzz::scratch_file(data, size, ".csv")); break;
            case 5: rs::read_carmen_log(roadpreview_fuzz::scratch_file(data, size, ".log"), 37.5); break;
            default: rs::read_detections(roadpreview_fuzz::scratch_file(data, size, ".jsonl")); break;
        }
    });
    return 0;
}
