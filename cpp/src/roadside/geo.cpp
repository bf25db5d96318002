// SPDX-License-Identifier: BSD-3-Clause
#include "roadpreview/roadside/geo.hpp"

#include <GeographicLib/LocalCartesian.hpp>
#include <cmath>

namespace roadpreview::roadside {

struct SiteGeodesy::Impl {
    GeographicLib::LocalCartesian enu;
    double sin_h = 0.0, cos_h = 1.0;  // site x axis = (east, north) = (sin h, cos h)
};

SiteGeodesy::SiteGeodesy(const SiteOrigin& origin) : impl_(std::make_unique<Impl>()) {
    impl_->enu.Reset(origin.lat_deg, origin.lon_deg, origin.height_m);
    const double h = origin.heading_deg * 3.14159265358979323846 / 180.0;
    impl_->sin_h = std::sin(h);
    impl_->cos_h = std::cos(h);
}
SiteGeodesy::~SiteGeodesy() = default;
SiteGeodesy::SiteGeodesy(SiteGeodesy&&) noexcept = default;
SiteGeodesy& SiteGeodesy::operator=(SiteGeodesy&&) noexcept = default;

LatLon SiteGeodesy::to_wgs84(double x_m, double y_m) const {
    // y is 90° counter-clockwise of x: (east, north) = (−cos h, sin h).
    const double east = x_m * impl_->sin_h - y_m * impl_->cos_h;
    const double north = x_m * impl_->cos_h + y_m * impl_->sin_h;
    LatLon out;
    double h = 0.0;
    impl_->enu.Reverse(east, north, 0.0, out.lat_deg, out.lon_deg, h);
    return out;
}

void SiteGeodesy::to_site(double lat_deg, double lon_deg, double& x_m, double& y_m) const {
    double east = 0.0, north = 0.0, up = 0.0;
    impl_->enu.Forward(lat_deg, lon_deg, impl_->enu.HeightOrigin(), east, north, up);
    x_m = east * impl_->sin_h + north * impl_->cos_h;
    y_m = -east * impl_->cos_h + north * impl_->sin_h;
}

}  // namespace roadpreview::roadside
