// SPDX-License-Identifier: BSD-3-Clause
// Site frame ↔ WGS84 through GeographicLib's LocalCartesian (east-north-up tangent plane at the site origin),
// turned by the site's heading.
#pragma once

#include <memory>

#include "roadpreview/roadside/site.hpp"

namespace roadpreview::roadside {

struct LatLon {
    double lat_deg = 0.0, lon_deg = 0.0;
};

class SiteGeodesy {
public:
    explicit SiteGeodesy(const SiteOrigin& origin);
    ~SiteGeodesy();
    SiteGeodesy(SiteGeodesy&&) noexcept;
    SiteGeodesy& operator=(SiteGeodesy&&) noexcept;

    LatLon to_wgs84(double x_m, double y_m) const;     ///< a point on the ground (site z = 0)
    void to_site(double lat_deg, double lon_deg, double& x_m, double& y_m) const;

private:
    struct Impl;
    std::unique_ptr<Impl> impl_;
};

}  // namespace roadpreview::roadside
