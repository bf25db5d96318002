// SPDX-License-Identifier: BSD-3-Clause
// StereoSource: pairs (or disparity images) in name order → frames of camera-frame points.
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <stdexcept>

#include "roadpreview/io/stereo.hpp"
#include "core/stopwatch.hpp"

namespace roadpreview {
namespace {

namespace fs = std::filesystem;

// A file stays as it is; a directory gives its .png files sorted by name.
std::vector<std::string> expand_images(const std::string& path, const char* role) {
    std::error_code ec;
    if (!fs::exists(path, ec)) throw std::runtime_error(path + ": no such file or directory (" + role + ")");
    if (!fs::is_directory(path, ec)) return {path};
    std::vector<std::string> files;
    for (const auto& entry : fs::directory_iterator(path)) {
        std::string ext = entry.path().extension().string();
        std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
        if (entry.is_regular_file() && ext == ".png") files.push_back(entry.path().string());
    }
    if (files.empty()) throw std::runtime_error(path + ": directory holds no .png images (" + role + ")");
    std::sort(files.begin(), files.end());
    return files;
}

std::vector<std::string> expand_all(const std::vector<std::string>& paths, const char* role) {
    std::vector<std::string> out;
    for (const auto& p : paths) {
        const auto files = expand_images(p, role);
        out.insert(out.end(), files.begin(), files.end());
    }
    return out;
}

// Folders of pairs go by position in name order: a first pair whose names differ (an image missing on one side)
// pairs other instants from there on. Files named one by one pair as given.
std::vector<std::string> pairing_notes(const StereoInputs& given, const StereoInputs& expanded) {
    std::error_code ec;
    const auto folder = [&](const std::string& p) { return fs::is_directory(p, ec); };
    if (given.left.empty() || !std::all_of(given.left.begin(), given.left.end(), folder) ||
        !std::all_of(given.right.begin(), given.right.end(), folder))
        return {};
    for (std::size_t i = 0; i < expanded.left.size(); ++i)
        if (fs::path(expanded.left[i]).filename() != fs::path(expanded.right[i]).filename())
            return {expanded.left[i] + " is paired with " + expanded.right[i] +
                    ": folders pair by position in name order, and from here the names differ (an image missing on "
                    "one side?)"};
    return {};
}

GreyImage grey_levels(const StereoImages& pair) {
    return pair.left.cast<float>() / 255.0f;
}

}  // namespace

StereoInputs expand_stereo_inputs(const StereoInputs& in) {
    StereoInputs out;
    out.calibration = in.calibration;
    out.left = expand_all(in.left, "left images");
    out.right = expand_all(in.right, "right images");
    out.disparity = expand_all(in.disparity, "disparity images");
    if (out.left.size() != out.right.size())
        throw std::runtime_error((in.left.empty() ? std::string("left") : in.left[0]) + ": " + std::to_string(out.left.size()) +
                                 " left images but " + std::to_string(out.right.size()) + " right images");
    if (out.left.empty() && out.disparity.empty())
        throw std::runtime_error("stereo input needs left and right images, or disparity images");
    if (!out.disparity.empty() && !out.left.empty() && out.disparity.size() != out.left.size())
        throw std::runtime_error(in.disparity[0] + ": " + std::to_string(out.disparity.size()) + " disparity images but " +
                                 std::to_string(out.left.size()) + " image pairs");
    return out;
}

StereoSource::StereoSource(const StereoInputs& inputs, const Config& config)
    : inputs_(expand_stereo_inputs(inputs)), cfg_(config.stereo), calib_(read_stereo_calibration(inputs.calibration)),
      camera_(stereo_camera_pose(config, calib_)), notes_(pairing_notes(inputs, inputs_)) {}

std::optional<Frame> StereoSource::next() {
    const std::size_t count = inputs_.disparity.empty() ? inputs_.left.size() : inputs_.disparity.size();
    if (index_ >= count) return std::nullopt;
    const std::size_t i = index_++;
    timing_ = {};
    auto mark = Clock::now();
    std::optional<StereoImages> pair;
    if (!inputs_.left.empty()) pair = read_stereo_pair(inputs_.left[i], inputs_.right[i]);
    DisparityImage disparity;
    const std::string& name = inputs_.disparity.empty() ? inputs_.left[i] : inputs_.disparity[i];
    if (!inputs_.disparity.empty()) {
        disparity = read_disparity_png(inputs_.disparity[i]);
        if (pair && (pair->left.rows() != disparity.rows() || pair->left.cols() != disparity.cols()))
            throw std::runtime_error(name + ": the disparity image and the pair " + inputs_.left[i] + " differ in size");
    }
    timing_.read = ms_since(mark);
    const auto rows = static_cast<int>(pair ? pair->left.rows() : disparity.rows());
    const int first_row = first_road_row(calib_, camera_, rows, cfg_);
    try {
        if (inputs_.disparity.empty()) disparity = match_stereo(*pair, first_row, cfg_);
    } catch (const std::invalid_argument& e) {
        throw std::runtime_error(name + ": " + e.what());
    }
    timing_.match = ms_since(mark);
    const std::optional<GreyImage> grey = pair ? std::optional<GreyImage>(grey_levels(*pair)) : std::nullopt;
    StereoPoints points = disparity_to_points(disparity, first_row, calib_, cfg_, grey ? &*grey : nullptr);
    timing_.points = ms_since(mark);

    Frame f;
    f.points = std::move(points.points);
    f.range_variances = std::move(points.range_variances);
    f.error_groups = std::move(points.error_groups);
    f.source = name;
    f.frame_id = static_cast<std::int64_t>(i);
    return f;
}

SourceInfo StereoSource::info() const {
    SourceInfo s;
    s.format = inputs_.disparity.empty() ? "stereo pairs" : "stereo disparity";
    char model[160];
    std::snprintf(model, sizeof model, "stereo camera, fx %.2f px, baseline %.4f m", calib_.fx_px, calib_.baseline_m);
    s.sensor_model = model;
    s.profile = inputs_.disparity.empty() ? "StereoSGBM " + cfg_.mode : "precomputed disparity";
    s.metadata = calib_.source;
    s.notes = notes_;
    return s;
}

}  // namespace roadpreview
