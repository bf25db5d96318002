// SPDX-License-Identifier: BSD-3-Clause
// A program built with -fno-exceptions (ctest: realtime_noexceptions) uses the pipeline through try_process:
// a bad config is refused by check_config, a good frame gives Ok and profiles, a bad speed a Status with the message,
// and nothing is thrown at it.
#include <cmath>
#include <cstdio>
#include <cstring>
#include <vector>

#include <roadpreview/pipeline/pipeline.hpp>

namespace rp = roadpreview;

int main() {
    std::vector<float> xyz;  // a flat road 1.8 m below the sensor, 0.25 m grid over x ∈ [1, 40), |y| < 5
    for (float x = 1.0f; x < 40.0f; x += 0.25f)
        for (float y = -5.0f; y < 5.0f; y += 0.25f) xyz.insert(xyz.end(), {x, y, -1.8f});
    const rp::PointsView points = rp::points_view(xyz.data(), static_cast<Eigen::Index>(xyz.size() / 3), 3);
    rp::Config cfg;
    int failures = 0;
    cfg.sensor_height = -1.8;  // checked before an Estimator is made of it, which would throw
    const rp::Status refused = rp::check_config(cfg);
    if (refused.code() != rp::StatusCode::InvalidArgument || !std::strstr(refused.message(), "sensor_height must be")) {
        std::printf("FAIL: a negative sensor height gave %s: '%s'\n", rp::to_string(refused.code()), refused.message());
        ++failures;
    }
    cfg.sensor_height = 1.8;
    if (!rp::check_config(cfg)) {
        std::printf("FAIL: the config was refused: '%s'\n", rp::check_config(cfg).message());
        ++failures;
    }
    rp::Estimator est(cfg);
    rp::Result out;
    const rp::Status good = est.try_process(points, 5.0, 0.0, out);
    if (!good || out.status != rp::FrameStatus::Ok || out.left.z.empty()) {
        std::printf("FAIL: a flat road gave status %s, frame status '%s', %zu bins\n", rp::to_string(good.code()),
                    rp::to_string(out.status), out.left.z.size());
        ++failures;
    }
    const rp::Status bad = est.try_process(points, std::nan(""), 0.0, out);
    if (bad.code() != rp::StatusCode::InvalidArgument || std::strcmp(bad.message(), "speed must be finite, got nan")) {
        std::printf("FAIL: a NaN speed gave %s: '%s'\n", rp::to_string(bad.code()), bad.message());
        ++failures;
    }
    std::printf("%s\n", failures ? "FAILED" : "passed");
    return failures ? 1 : 0;
}
