// SPDX-License-Identifier: BSD-3-Clause
// libFuzzer target: output lines read back (JSON, one per line) and fed to the route and the readout, as
// `RouteBuilder.add_line` / `ProfileReadout.add_line` and batch runs do; then the route's profiles and segments.
#include <cstdint>
#include <sstream>
#include <string>

#include <roadpreview/route/readout.hpp>
#include <roadpreview/route/route.hpp>

#include "scratch_file.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    const roadpreview::Config cfg;
    roadpreview::RouteBuilder route(cfg);
    roadpreview::ProfileReadout readout(cfg, 6.0);
    std::istringstream lines(std::string(reinterpret_cast<const char*>(data), size));
    std::string line;
    for (int number = 1; std::getline(lines, line); ++number) {
        roadpreview_fuzz::expect_clean_errors([&] {
            const roadpreview::Result r = roadpreview::route_input_from_json(line, "line " + std::to_string(number));
            try {
                route.add(r);
            } catch (const std::invalid_argument&) {  // the readout may still take it
            }
            readout.add(r);
        });
    }
    roadpreview_fuzz::expect_clean_errors([&] {
        route.left();
        route.right();
        route.segments(10.0);
    });
    return 0;
}
