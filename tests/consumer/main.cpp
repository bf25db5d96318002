// Uses the installed library: a flat road scanned in rings, driven straight at 5 m/s. Built twice: against the
// umbrella target (and then it uses the recording I/O too) and against roadpreview::core alone.
#include <cmath>
#include <cstdio>

#ifdef ROADPREVIEW_CONSUMER_CORE_ONLY
#include <roadpreview/pipeline/pipeline.hpp>
#include <roadpreview/version.hpp>
#else
#include <roadpreview/roadpreview.hpp>
#endif

int main() {
    Eigen::Matrix<float, Eigen::Dynamic, 4, Eigen::RowMajor> points(20000, 4);
    for (int i = 0; i < points.rows(); ++i) {
        const double x = 2.0 + 0.002 * i, y = -3.0 + 6.0 * std::fmod(0.618034 * i, 1.0);
        points.row(i) << float(x), float(y), float(-1.8 + 0.01 * std::sin(3.0 * x)), 1.0f;  // sensor 1.8 m up
    }
    roadpreview::Config cfg;
    cfg.sensor_height = 1.8;
    roadpreview::Estimator est{cfg};
    const roadpreview::Result r = est.process(points, 5.0, 0.0);
    const auto& rough = r.left.roughness;
    std::printf("roadpreview %s: %lld ground points, left class %c, %.3f ms\n", roadpreview::kVersion,
                static_cast<long long>(r.points.ground), rough.iso_class ? *rough.iso_class : '-', r.timing_ms.total);
#ifndef ROADPREVIEW_CONSUMER_CORE_ONLY
    if (!roadpreview::is_pcap_path("drive.pcap")) return 1;  // roadpreview::io is linked
#endif
    return r.points.ground > 0 && rough.iso_class ? 0 : 1;
}
