// Uses the installed roadside libraries: a site file's origin to WGS84 and back, and a video detector's error for
// a missing file (the video library is linked and runs).
#include <cmath>
#include <cstdio>
#include <stdexcept>

#include <roadpreview/roadside/geo.hpp>
#include <roadpreview/roadside/site.hpp>
#include <roadpreview/roadside/video.hpp>

int main() {
    namespace rs = roadpreview::roadside;
    const rs::Site site = rs::parse_site(
        "origin: {lat_deg: 49.01, lon_deg: 8.40, height_m: 115, heading_deg: 90}\n"
        "scanners:\n  - {name: s1, x_m: 0, y_m: 0, yaw_deg: 0}\n", "consumer site");
    const rs::SiteGeodesy geo(site.origin);
    const rs::LatLon p = geo.to_wgs84(100.0, 0.0);  // 100 m east
    double x = 0.0, y = 0.0;
    geo.to_site(p.lat_deg, p.lon_deg, x, y);
    std::printf("roadside: (100, 0) m -> %.6f, %.6f deg -> (%.3f, %.3f) m\n", p.lat_deg, p.lon_deg, x, y);
    try {
        rs::detect_video("no_such_video.mp4");
        return 1;
    } catch (const std::runtime_error& e) {
        std::printf("video: %s\n", e.what());
    }
    return std::abs(x - 100.0) < 1e-6 && std::abs(y) < 1e-6 && p.lon_deg > 8.40 ? 0 : 1;
}
