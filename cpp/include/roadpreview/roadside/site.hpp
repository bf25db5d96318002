// SPDX-License-Identifier: BSD-3-Clause
// The site file (YAML): where the scanners and the camera are, the site origin in WGS84, and the processing
// settings. Site frame: x, y on the ground (right-handed, z up), metres; angles in degrees in the file.
#pragma once

#include <array>
#include <optional>
#include <string>
#include <vector>

#include "roadpreview/roadside/scan.hpp"
#include "roadpreview/roadside/world_background.hpp"

namespace roadpreview::roadside {

struct ScannerSite {
    std::string name;
    Pose2 pose;                  ///< in the site frame
    double time_offset_s = 0.0;  ///< added to the scanner's scan times to put them on the site clock
    double max_range_m = 80.0;   ///< returns at or beyond are no return
    // Expected angular layout (checked against every scan when given): first beam, step, beam count.
    std::optional<double> start_angle_deg, step_deg;
    std::optional<int> beams;
};

struct CameraSite {
    int width_px = 0, height_px = 0;
    std::optional<std::array<double, 4>> intrinsics;  ///< fx, fy, cx, cy (px), informative
    std::vector<std::array<double, 2>> image_points;  ///< px, ≥ 4 surveyed ground points …
    std::vector<std::array<double, 2>> site_points;   ///< … and where they are in the site frame, m
    std::array<double, 9> homography{};               ///< image px → site m, row-major (cv::findHomography)
    double time_offset_s = 0.0;
};

struct SiteOrigin {
    double lat_deg = 0.0, lon_deg = 0.0, height_m = 0.0;
    double heading_deg = 90.0;  ///< compass heading of the site x axis (clockwise from north; 90 = east)
};

/// Processing settings (the `processing:` block of the site file), with their defaults.
struct RoadsideSettings {
    double cell_m = 0.1;               ///< occupancy grid cell
    int dilation_cells = 2;            ///< dilation radius (square kernel 2r+1)
    int min_points = 2;                ///< smaller components are noise (a cyclist head-on at 25 m gives 2 returns)
    double background_s = 2.0;         ///< background learned over the first seconds
    double background_margin_m = 0.3;  ///< a return this much in front of the background is foreground
    double cycle_s = 1.0 / 37.5;       ///< output period; scans are grouped into cycles of this length
    double accel_sigma_mps2 = 3.0;     ///< Kalman process noise (white acceleration)
    double position_sigma_m = 0.08;    ///< measurement noise of an object centre
    double gate_chi2 = 13.8;           ///< association gate (χ², 2 dof, 99.9 %)
    int confirm_hits = 6;              ///< a track is output after this many updates (0.16 s at 37.5 Hz)
    double max_coast_s = 1.2;          ///< a track not updated for longer is dropped (occlusion by a pole)
    double max_speed_mps = 0.0;        ///< no assignment implying a faster object (0: no limit; for slow logs)
    double camera_gate_m = 2.5;        ///< camera–track association gate (position distance)
    double camera_weight_position = 1.0, camera_weight_heading = 1.0;  ///< cost: w_p·d/gate + w_h·|Δθ|/π
    double scanner_timeout_s = 0.2;    ///< a scanner silent for longer is reported as dropped out
    WorldBackgroundSettings world;     ///< the background of scans with poses (a moving scanner)
};

struct Site {
    SiteOrigin origin;
    std::vector<ScannerSite> scanners;
    std::optional<CameraSite> camera;
    RoadsideSettings settings;
    std::string path;  ///< for messages
};

/// Reads and checks a site file. Throws std::runtime_error naming the file and the offending key; a camera
/// whose surveyed points are fewer than 4, collinear or give a degenerate homography is refused.
Site read_site(const std::string& path);

/// Parses a site from YAML text (`where` names it in messages).
Site parse_site(const std::string& yaml_text, const std::string& where);

/// Image px → site m through a homography; false when the point maps to infinity (above the horizon).
bool image_to_site(const std::array<double, 9>& h, double u, double v, double& x_m, double& y_m);

/// The homography image → site from ≥ 4 point pairs (cv::findHomography, least squares over all points).
/// Throws std::invalid_argument for fewer than 4 pairs, collinear points or a degenerate result.
std::array<double, 9> fit_homography(const std::vector<std::array<double, 2>>& image_points,
                                     const std::vector<std::array<double, 2>>& site_points);

}  // namespace roadpreview::roadside
