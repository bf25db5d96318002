// SPDX-License-Identifier: BSD-3-Clause
// The OpenCV side of stereo input: images and disparity PNGs (read with libpng, png_file.hpp), matching with
// calib3d's StereoSGBM. OpenCV stays inside the stereo folder (the library links it privately).
#include <algorithm>
#include <stdexcept>

#include <opencv2/calib3d.hpp>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "io/stereo/png_file.hpp"
#include "roadpreview/io/stereo.hpp"

namespace roadpreview {
namespace {

std::string describe(const cv::Mat& m) {
    const int depth = m.depth();
    const std::string bits = depth == CV_8U ? "8-bit" : depth == CV_16U ? "16-bit" : depth == CV_32F ? "float" : "other-depth";
    return bits + " " + std::to_string(m.channels()) + "-channel " + std::to_string(m.cols) + "x" + std::to_string(m.rows);
}

// One channel, same depth.
cv::Mat to_grey(const cv::Mat& m, const std::string& path) {
    if (m.depth() != CV_8U && m.depth() != CV_16U)
        throw std::runtime_error(path + ": images must be 8 or 16 bit, got " + describe(m));
    cv::Mat grey;
    if (m.channels() == 1) return m;
    if (m.channels() == 3) cv::cvtColor(m, grey, cv::COLOR_RGB2GRAY);
    else if (m.channels() == 4) cv::cvtColor(m, grey, cv::COLOR_RGBA2GRAY);
    else throw std::runtime_error(path + ": images must be grey, RGB or RGBA, got " + describe(m));
    return grey;
}

using Grey8 = Eigen::Matrix<std::uint8_t, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;

Grey8 to_eigen(const cv::Mat& m8) {
    Grey8 out(m8.rows, m8.cols);
    cv::Mat view(m8.rows, m8.cols, CV_8UC1, out.data());
    m8.copyTo(view);
    return out;
}

int sgbm_mode(const std::string& mode) {
    if (mode == "sgbm") return cv::StereoSGBM::MODE_SGBM;
    if (mode == "hh") return cv::StereoSGBM::MODE_HH;
    if (mode == "hh4") return cv::StereoSGBM::MODE_HH4;
    return cv::StereoSGBM::MODE_SGBM_3WAY;
}

}  // namespace

StereoImages read_stereo_pair(const std::string& left, const std::string& right) {
    cv::Mat l = to_grey(read_png(left), left), r = to_grey(read_png(right), right);
    if (l.size() != r.size())
        throw std::runtime_error(left + " and " + right + ": left and right differ in size (" + describe(l) + " vs " +
                                 describe(r) + ")");
    if (l.depth() != r.depth())
        throw std::runtime_error(left + " and " + right + ": left and right differ in bit depth (" + describe(l) +
                                 " vs " + describe(r) + ")");
    if (l.depth() == CV_16U) {  // one scale for both, so equal grey levels stay equal
        double max_l = 0.0, max_r = 0.0;
        cv::minMaxLoc(l, nullptr, &max_l);
        cv::minMaxLoc(r, nullptr, &max_r);
        const double scale = 255.0 / std::max({max_l, max_r, 1.0});
        l.convertTo(l, CV_8U, scale);
        r.convertTo(r, CV_8U, scale);
    }
    return {to_eigen(l), to_eigen(r)};
}

DisparityImage match_stereo(const StereoImages& pair, int first_row, const StereoConfig& cfg) {
    const auto rows = static_cast<int>(pair.left.rows()), cols = static_cast<int>(pair.left.cols());
    if (pair.right.rows() != rows || pair.right.cols() != cols)
        throw std::invalid_argument("left and right images differ in size");
    if (cols <= cfg.min_disparity + cfg.num_disparities)
        throw std::invalid_argument("images " + std::to_string(cols) + " px wide are too narrow for " +
                                    std::to_string(cfg.num_disparities) + " disparities");
    DisparityImage out = DisparityImage::Zero(rows, cols);
    // Matching starts half a window above the first road row, so that row has its full window.
    const int top = std::clamp(first_row - cfg.block_size / 2, 0, rows);
    if (top >= rows) return out;
    // Full-width row ranges of a row-major buffer are continuous, so OpenCV reads them in place.
    const cv::Mat left(rows - top, cols, CV_8UC1, const_cast<std::uint8_t*>(pair.left.data()) + std::size_t(top) * cols);
    const cv::Mat right(rows - top, cols, CV_8UC1, const_cast<std::uint8_t*>(pair.right.data()) + std::size_t(top) * cols);
    cv::setNumThreads(cfg.threads > 0 ? cfg.threads : -1);  // −1: OpenCV's default
    const auto sgbm = cv::StereoSGBM::create(cfg.min_disparity, cfg.num_disparities, cfg.block_size, cfg.p1, cfg.p2,
                                             cfg.disp12_max_diff, cfg.pre_filter_cap, cfg.uniqueness_ratio,
                                             cfg.speckle_window_size, cfg.speckle_range, sgbm_mode(cfg.mode));
    cv::Mat fixed;  // CV_16S, disparity × 16; (min_disparity − 1) × 16 where there is none
    sgbm->compute(left, right, fixed);
    const int invalid = (cfg.min_disparity - 1) * 16;
    const int first = std::max(first_row, top) - top;
    for (int v = first; v < fixed.rows; ++v) {
        const auto* row = fixed.ptr<std::int16_t>(v);
        for (int u = 0; u < cols; ++u)
            if (row[u] > invalid && row[u] > 0) out(v + top, u) = static_cast<float>(row[u]) / 16.0f;
    }
    return out;
}

DisparityImage read_disparity_png(const std::string& path) {
    const cv::Mat m = read_png(path);
    if (m.type() != CV_16UC1)
        throw std::runtime_error(path + ": a disparity image must be a single-channel 16-bit PNG (disparity x 256, "
                                 "0 = invalid, as KITTI stores it), got " + describe(m));
    DisparityImage out(m.rows, m.cols);
    for (int v = 0; v < m.rows; ++v) {
        const auto* row = m.ptr<std::uint16_t>(v);
        for (int u = 0; u < m.cols; ++u) out(v, u) = static_cast<float>(row[u]) / 256.0f;  // 0 stays invalid
    }
    return out;
}

}  // namespace roadpreview
