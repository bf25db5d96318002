// SPDX-License-Identifier: BSD-3-Clause
// Built-in camera detection for users without a detector of their own: a video's frames through OpenCV's HOG
// people detector (Dalal & Triggs) and any Viola–Jones cascades, as the paper's pole camera did (docs/method.md
// "Roadside", "Camera"). Its own library, roadpreview::roadside_video (OpenCV's video I/O and object detection
// would add ~200 shared libraries to the CLI, FFmpeg's and GDAL's among them: programs that do not read video
// should not pay for them); the CLI runs it as the helper program `roadpreview-video`.
#pragma once

#include <functional>
#include <string>
#include <vector>

#include "roadpreview/roadside/processor.hpp"

namespace roadpreview::roadside {

/// A Viola–Jones cascade (OpenCV's XML) and the class its detections get.
struct Cascade {
    std::string cls;   ///< e.g. car, pedestrian, cyclist
    std::string path;  ///< cascade XML (OpenCV's `haarcascade_*.xml` / `lbpcascade_*.xml` or one trained for the site)
    int min_neighbours = 3;  ///< overlapping hits a detection needs (`detectMultiScale`'s minNeighbors)
};

struct VideoDetectionOptions {
    int process_width_px = 720;   ///< frames are scaled to this width for detection (the paper: 720×480); boxes
                                  ///< come back in the video's pixels
    int frame_stride = 1;         ///< detect in every n-th frame
    double start_time_s = 0.0;    ///< camera time of the video's first frame (the site adds its camera offset)
    bool people = true;           ///< HOG people detector → class "pedestrian"
    double people_threshold = 0.0;  ///< HOG's SVM margin a detection needs (OpenCV's hitThreshold)
    std::vector<Cascade> cascades;
};

struct VideoDetections {
    int width_px = 0, height_px = 0;  ///< the video's frame size
    double fps = 0.0;
    long long frames = 0, frames_processed = 0;
    std::vector<CameraDetection> detections;  ///< in time order; t_s = start + the frame's position in the video
};

/// Detects in every `frame_stride`-th frame of the video. Frame times come from the container (OpenCV's
/// CAP_PROP_POS_MSEC), else from the frame rate. A person box is trimmed to the person: the HOG window holds a
/// margin around them (16 of its 64 × 128 px above and below, 16 each side; Dalal & Triggs 2005), so the box's
/// bottom edge is where the feet touch the ground. Scores lie in (0, 1): m / (1 + m) of HOG's margin m, and
/// n / (n + min_neighbours) of a cascade detection's n hits. `progress(frame, frames)` is called now and then.
/// Throws std::runtime_error naming the file: unreadable video, missing or broken cascade, bad options.
VideoDetections detect_video(const std::string& path, const VideoDetectionOptions& options = {},
                             const std::function<void(long long, long long)>& progress = {});

}  // namespace roadpreview::roadside
