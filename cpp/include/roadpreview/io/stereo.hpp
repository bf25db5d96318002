// SPDX-License-Identifier: BSD-3-Clause
// Stereo cameras as a preview sensor (docs/method.md §12): rectified image pairs (or precomputed disparity
// images) and their calibration → points in the camera's frame, each with the variance of its range.
// OpenCV does the PNG reading and the matching (StereoSGBM) inside the library; nothing here needs its headers.
#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "roadpreview/core/config.hpp"
#include "roadpreview/io/frame_source.hpp"

namespace roadpreview {

/// A rectified stereo pair's geometry. The camera frame roadpreview uses is the left camera's, axes like the
/// base frame's: origin at the optical centre, x along the optical axis, y left, z up (image right is −y, image
/// down is −z). Its pose in the base frame is the config's sensor_height / extrinsics.
struct StereoCalibration {
    double fx_px = 0.0, fy_px = 0.0;  ///< focal lengths of the rectified left camera
    double cx_px = 0.0, cy_px = 0.0;  ///< principal point
    double baseline_m = 0.0;          ///< distance between the two optical centres (> 0)
    std::optional<Extrinsics> extrinsics;  ///< camera frame in the base frame, when the calibration file gives it
    std::string source;                    ///< the file it was read from
};

/// From the 3×4 row-major projection matrices of the rectified left and right cameras (KITTI P2, P3): the
/// baseline is (P_left[0,3] − P_right[0,3]) / fx, which is right whether or not the left camera is the reference
/// one. Throws std::invalid_argument (naming `source`) for a zero or negative baseline or focal length.
StereoCalibration calibration_from_projections(const double (&left)[12], const double (&right)[12],
                                               const std::string& source);

/// KITTI calib.txt (lines "P2: 12 numbers" and "P3: ..."; the colour pair) or a .yaml/.yml with fx, fy, cx, cy
/// (px), baseline (m) and optional extrinsics {x_m, y_m, z_m, roll_rad, pitch_rad, yaw_rad}. Throws
/// std::runtime_error naming the file (and line) for a missing file, missing P2/P3 or keys, or a bad value.
StereoCalibration read_stereo_calibration(const std::string& path);

/// Disparity in px, row-major, one entry per pixel; 0, negative and NaN entries are invalid.
using DisparityImage = Eigen::Matrix<float, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
/// Grey levels 0..1 of the left image, one per pixel (the points' fourth column).
using GreyImage = Eigen::Matrix<float, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;

/// The first image row that can see the road within stereo.max_depth_m: the row of a point max_depth_m ahead,
/// stereo.road_rise_m above the base plane, seen by a camera posed by `camera` (rows above it see only farther
/// road or sky). Clamped to [0, rows].
int first_road_row(const StereoCalibration& calib, const Extrinsics& camera, int rows, const StereoConfig& cfg);

/// Points of a disparity image and what each carries.
struct StereoPoints {
    PointMatrix points;                  ///< camera frame x, y, z (m) and the left image's grey level (0..1; 0 without)
    std::vector<float> range_variances;  ///< m², variance of each point's distance along its line of sight
    std::vector<std::int32_t> pixels;    ///< row · width + column of each point's pixel
    /// each point's error group: its tile of 2·stereo.error_correlation_along_px columns by
    /// 2·stereo.error_correlation_across_px rows (row-major tile index), whose points share a matching error
    std::vector<std::int32_t> error_groups;
};

/// Depth z = fx·B/d of every valid pixel in rows [first_row, rows) nearer than stereo.max_depth_m, its point
/// ((u − cx)·z/fx right, (v − cy)·z/fy down) and its range variance: σ_z = z²·σ_d/(fx·B) along the optical axis,
/// σ_r = σ_z·r/z along the ray. `grey` (optional, same size) fills the fourth column.
StereoPoints disparity_to_points(const DisparityImage& disparity, int first_row, const StereoCalibration& calib,
                                 const StereoConfig& cfg, const GreyImage* grey = nullptr);

/// A rectified pair read from image files (PNG or anything OpenCV reads; grey or colour, 8 or 16 bit).
struct StereoImages {
    Eigen::Matrix<std::uint8_t, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> left, right;  ///< grey, 8 bit
};
/// Reads and converts both images to 8-bit grey (16-bit images are scaled by the pair's common maximum). Throws
/// std::runtime_error naming the file for an unreadable image or a pair of different sizes.
StereoImages read_stereo_pair(const std::string& left, const std::string& right);

/// StereoSGBM (settings in `cfg`) on rows [first_row, rows) of the pair; rows above are invalid (0). Throws
/// std::invalid_argument for images of different sizes or narrower than the disparity range.
DisparityImage match_stereo(const StereoImages& pair, int first_row, const StereoConfig& cfg);

/// A 16-bit PNG disparity image as KITTI stores it (disparity × 256, 0 = invalid). Throws std::runtime_error
/// naming the file for an unreadable file or one that is not single-channel 16 bit (e.g. an 8-bit image).
DisparityImage read_disparity_png(const std::string& path);

/// Where the pairs of a stereo run come from: image files or directories (PNGs processed in name order).
struct StereoInputs {
    std::vector<std::string> left, right;  ///< rectified images; empty when only disparities are given
    std::vector<std::string> disparity;    ///< precomputed disparity PNGs; empty: matched with StereoSGBM
    std::string calibration;               ///< KITTI calib.txt or YAML
};

/// Expands each of left, right and disparity (a file, or a directory of PNGs sorted by name) and checks that
/// they pair up. Throws std::runtime_error naming the input when a path is missing, or counts differ.
StereoInputs expand_stereo_inputs(const StereoInputs& inputs);

/// Frames from stereo pairs: one per pair (or disparity image), points in the camera frame (see
/// StereoCalibration) with their range variances in Frame::range_variances and error groups in
/// Frame::error_groups; frame_id = index of the pair.
/// Matching uses config.stereo; the camera's pose (for the road rows) is config's extrinsics, else the
/// calibration's. Throws std::invalid_argument when neither gives a pose.
class StereoSource : public FrameSource {
public:
    StereoSource(const StereoInputs& inputs, const Config& config);
    std::optional<Frame> next() override;
    SourceInfo info() const override;

    const StereoCalibration& calibration() const { return calib_; }
    /// Milliseconds spent on the last frame: reading the images, matching, and making the points.
    struct Timing {
        double read = 0.0, match = 0.0, points = 0.0;
    };
    const Timing& last_timing() const { return timing_; }

private:
    StereoInputs inputs_;
    StereoConfig cfg_;
    StereoCalibration calib_;
    Extrinsics camera_;
    std::size_t index_ = 0;
    Timing timing_;
    std::vector<std::string> notes_;  // SourceInfo::notes
};

/// The camera's pose in the base frame for a stereo run: the config's when it sets one, else the calibration's.
/// Throws std::invalid_argument when neither does (a camera's height is needed to find the road rows).
Extrinsics stereo_camera_pose(const Config& config, const StereoCalibration& calib);

}  // namespace roadpreview
