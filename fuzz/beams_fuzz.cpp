// SPDX-License-Identifier: BSD-3-Clause
// libFuzzer target: beams files (beams.yaml, `roadpreview calibrate`), read, checked against a sensor and, when
// they index beams by elevation, applied to a fixed cloud as the .bin/.pcd readers apply them.
#include <cmath>
#include <cstdint>
#include <cstdlib>

#include <roadpreview/calibration/calibration.hpp>

#include "scratch_file.hpp"

namespace {

// Points at several ranges and elevations around the sensor, some degenerate (origin, NaN).
using Cloud = Eigen::Matrix<float, Eigen::Dynamic, 3, Eigen::RowMajor>;

Cloud fixed_cloud() {
    Cloud p(40, 3);
    for (Eigen::Index k = 0; k < p.rows(); ++k) {
        const double az = 0.3 * static_cast<double>(k), el = -0.4 + 0.02 * static_cast<double>(k), r = 2.0 + k;
        p.row(k) << static_cast<float>(r * std::cos(el) * std::cos(az)),
            static_cast<float>(r * std::cos(el) * std::sin(az)), static_cast<float>(r * std::sin(el));
    }
    p.row(0).setZero();
    p(1, 2) = NAN;
    return p;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    const std::string path = roadpreview_fuzz::scratch_file(data, size, ".yaml");
    roadpreview_fuzz::expect_clean_errors([&] {
        const roadpreview::BeamCalibration c = roadpreview::read_beam_calibration(path);
        if (static_cast<int>(c.beams.size()) != c.beam_count) std::abort();  // the file's count was checked
        roadpreview::check_beam_calibration(c, c.beam_count, c.sensor_model, c.serial);
        if (c.index != roadpreview::BeamIndexMethod::Elevation) return;
        Cloud cloud = fixed_cloud();
        const auto beams = roadpreview::beams_by_elevation(roadpreview::points_view(cloud.data(), cloud.rows(), 3), c);
        for (const std::int32_t b : beams)
            if (b < -1 || b >= c.beam_count) std::abort();
        roadpreview::apply_beam_calibration(cloud.data(), cloud.rows(), cloud.cols(), beams, c);
    });
    return 0;
}
