// SPDX-License-Identifier: BSD-3-Clause
// Built-in camera detection: a video's frames through OpenCV's HOG people detector and Viola–Jones cascades
// (roadpreview/roadside/video.hpp).
#include "roadpreview/roadside/video.hpp"

#include <cmath>
#include <filesystem>
#include <memory>
#include <stdexcept>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/objdetect.hpp>
#include <opencv2/videoio.hpp>

namespace roadpreview::roadside {
namespace {

// Dalal & Triggs' 64 × 128 px windows hold a person about 96 px tall and 32 wide with 16 px of margin around.
constexpr double kHogMarginX = 16.0 / 64.0, kHogMarginY = 16.0 / 128.0;

void check(const VideoDetectionOptions& o, const std::string& path) {
    const auto fail = [&](const std::string& what) { throw std::runtime_error(path + ": " + what); };
    if (o.process_width_px < 64 || o.process_width_px > 8192) fail("process width must be 64–8192 px");
    if (o.frame_stride < 1) fail("frame stride must be ≥ 1");
    if (!std::isfinite(o.start_time_s)) fail("start time must be finite");
    // A detection's score is its margin m as m/(1 + m), in (0, 1): a negative margin has none.
    if (!(o.people_threshold >= 0.0 && std::isfinite(o.people_threshold)))
        fail("the people threshold (a HOG SVM margin) must be a finite number ≥ 0");
    if (!o.people && o.cascades.empty()) fail("nothing to detect: people detection off and no cascade given");
    for (const auto& c : o.cascades) {
        if (c.cls.empty() || c.cls.find_first_of(",\"\n") != std::string::npos)
            fail("cascade class '" + c.cls + "' must be a non-empty name without commas or quotes");
        if (c.min_neighbours < 1) fail(c.path + ": a cascade's min neighbours must be ≥ 1");
    }
}

struct Detectors {
    cv::HOGDescriptor hog;
    std::vector<std::pair<const Cascade*, std::unique_ptr<cv::CascadeClassifier>>> cascades;
};

Detectors load(const VideoDetectionOptions& o) {
    Detectors d;
    if (o.people) d.hog.setSVMDetector(cv::HOGDescriptor::getDefaultPeopleDetector());
    for (const auto& c : o.cascades) {
        auto classifier = std::make_unique<cv::CascadeClassifier>();
        bool loaded = false;
        try {
            loaded = classifier->load(c.path);
        } catch (const cv::Exception& e) {
            throw std::runtime_error(c.path + ": not a cascade OpenCV can read (" + e.what() + ")");
        }
        if (!loaded) throw std::runtime_error(c.path + ": cannot read the cascade (missing or not OpenCV's XML)");
        d.cascades.emplace_back(&c, std::move(classifier));
    }
    return d;
}

// Detections in one frame, boxes in the video's pixels (`scale` = video px per processed px).
void detect_frame(const cv::Mat& grey, double scale, double t_s, const VideoDetectionOptions& o, Detectors& d,
                  std::vector<CameraDetection>& out) {
    if (o.people) {
        std::vector<cv::Rect> boxes;
        std::vector<double> margins;
        d.hog.detectMultiScale(grey, boxes, margins, o.people_threshold, cv::Size(8, 8), cv::Size(8, 8), 1.05, 2.0);
        for (std::size_t i = 0; i < boxes.size(); ++i) {
            const cv::Rect& b = boxes[i];
            const double m = margins[i];
            if (!(m > 0.0)) continue;  // no margin: no vote (a detection's score lies in (0, 1])
            out.push_back({t_s, scale * (b.x + kHogMarginX * b.width), scale * (b.y + kHogMarginY * b.height),
                           scale * b.width * (1.0 - 2.0 * kHogMarginX), scale * b.height * (1.0 - 2.0 * kHogMarginY),
                           "pedestrian", m / (1.0 + m)});
        }
    }
    for (auto& [cascade, classifier] : d.cascades) {
        std::vector<cv::Rect> boxes;
        std::vector<int> hits;
        classifier->detectMultiScale(grey, boxes, hits, 1.1, cascade->min_neighbours);
        for (std::size_t i = 0; i < boxes.size(); ++i) {
            const cv::Rect& b = boxes[i];
            const double n = hits[i];
            out.push_back({t_s, scale * b.x, scale * b.y, scale * b.width, scale * b.height, cascade->cls,
                           n / (n + cascade->min_neighbours)});
        }
    }
}

}  // namespace

VideoDetections detect_video(const std::string& path, const VideoDetectionOptions& options,
                             const std::function<void(long long, long long)>& progress) {
    check(options, path);
    Detectors detectors = load(options);
    std::error_code ec;
    if (!std::filesystem::is_regular_file(path, ec)) throw std::runtime_error(path + ": no such video file");
    cv::VideoCapture video;
    try {
        video.open(path, cv::CAP_FFMPEG);  // one back end, so a file is read the same way everywhere
    } catch (const cv::Exception& e) {
        throw std::runtime_error(path + ": cannot read the video (" + e.what() + ")");
    }
    if (!video.isOpened()) throw std::runtime_error(path + ": cannot read the video (not a container and codec FFmpeg reads)");
    VideoDetections result;
    result.fps = video.get(cv::CAP_PROP_FPS);
    const auto frames = static_cast<long long>(video.get(cv::CAP_PROP_FRAME_COUNT));
    cv::Mat frame, grey, small;
    for (long long index = 0; video.read(frame); ++index) {
        if (frame.empty()) break;
        if (result.frames == 0) result.width_px = frame.cols, result.height_px = frame.rows;
        if (frame.cols != result.width_px || frame.rows != result.height_px)
            throw std::runtime_error(path + ": frame " + std::to_string(index) + " is " + std::to_string(frame.cols) +
                                     "×" + std::to_string(frame.rows) + " px, the first was " +
                                     std::to_string(result.width_px) + "×" + std::to_string(result.height_px));
        ++result.frames;
        // The frame's time in the video: the container's, else its index over the frame rate.
        const double position_ms = video.get(cv::CAP_PROP_POS_MSEC);
        const double t_s = options.start_time_s +
                           (position_ms > 0.0 || index == 0 || !(result.fps > 0.0) ? position_ms / 1000.0
                                                                                   : index / result.fps);
        if (index % options.frame_stride != 0) continue;
        if (frame.channels() == 1) grey = frame;
        else cv::cvtColor(frame, grey, frame.channels() == 4 ? cv::COLOR_BGRA2GRAY : cv::COLOR_BGR2GRAY);
        const double scale = static_cast<double>(frame.cols) / options.process_width_px;
        const cv::Size size(options.process_width_px, std::max(1, static_cast<int>(std::lround(frame.rows / scale))));
        if (size == grey.size()) small = grey;
        else cv::resize(grey, small, size, 0, 0, scale > 1.0 ? cv::INTER_AREA : cv::INTER_LINEAR);
        detect_frame(small, scale, t_s, options, detectors, result.detections);
        ++result.frames_processed;
        if (progress && result.frames_processed % 25 == 0) progress(result.frames, frames);
    }
    if (result.frames == 0) throw std::runtime_error(path + ": the video holds no frame OpenCV can decode");
    return result;
}

}  // namespace roadpreview::roadside
