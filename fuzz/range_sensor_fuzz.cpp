// SPDX-License-Identifier: BSD-3-Clause
// libFuzzer target: the range-sensor files. First byte mod 3: 0 a layout YAML, 1 a calibration YAML, 2 a readings
// CSV streamed through RangeProfiler with a fixed two-sensor layout (counts calibrated, distances as they are).
#include <cstdint>

#include <roadpreview/range_sensor/range_sensor.hpp>

#include "scratch_file.hpp"

namespace {

std::vector<roadpreview::RangeSensor> fixed_layout() {
    roadpreview::RangeSensor left, right;
    left.id = "l";
    left.kind = roadpreview::RangeKind::Ultrasonic;
    left.x_m = 0.5;
    left.y_m = 0.8;
    left.height_m = 0.3;
    left.max_count = 10000.0;
    right = left;
    right.id = "r";
    right.kind = roadpreview::RangeKind::Laser;
    right.wheel = roadpreview::Wheel::Right;
    right.y_m = -0.8;
    return {left, right};
}

void profile_readings(const std::string& path) {
    roadpreview::RangeCalibration cal;
    cal.distance = roadpreview::DistanceCalibration{};
    cal.distance->a1 = 1e-3;
    roadpreview::RangeProfilerConfig cfg;
    cfg.frame_length_m = 4.0;  // several windows from a small input
    roadpreview::RangeProfiler profiler(fixed_layout(), cal, cfg);
    profiler.run(path, roadpreview::RangeMotion(5.0, 0.1), [](const roadpreview::RangeWindow&) {});
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    if (size < 1) return 0;
    const int kind = data[0] % 3;
    const std::string path = roadpreview_fuzz::scratch_file(data + 1, size - 1, kind == 2 ? ".csv" : ".yaml");
    roadpreview_fuzz::expect_clean_errors([&] {
        if (kind == 0) roadpreview::read_range_layout(path);
        else if (kind == 1) roadpreview::read_range_calibration(path);
        else profile_readings(path);
    });
    return 0;
}
