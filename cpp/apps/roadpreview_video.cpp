// SPDX-License-Identifier: BSD-3-Clause
// `roadpreview-video`: camera detections from a video (HOG people detector, Viola–Jones cascades) as the CSV
// `t,x,y,w,h,class,score`. The `roadpreview` CLI runs it for `roadside detect` and `roadside run --video`, so that
// the CLI itself never loads OpenCV's video libraries.
#include <cstdio>
#include <exception>
#include <map>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>
#include <opencv2/core/utils/logger.hpp>

#include "roadpreview/roadside/video.hpp"

namespace rs = roadpreview::roadside;

namespace {

// CLASS=FILE[:MIN_NEIGHBOURS]
rs::Cascade parse_cascade(const std::string& arg) {
    const auto eq = arg.find('=');
    if (eq == std::string::npos || eq == 0 || eq + 1 == arg.size())
        throw std::runtime_error("--cascade " + arg + ": expected CLASS=FILE (e.g. car=cars.xml)");
    rs::Cascade c{arg.substr(0, eq), arg.substr(eq + 1)};
    const auto colon = c.path.rfind(':');
    if (colon != std::string::npos && colon + 1 < c.path.size() &&
        c.path.find_first_not_of("0123456789", colon + 1) == std::string::npos) {
        c.min_neighbours = std::stoi(c.path.substr(colon + 1));
        c.path.resize(colon);
    }
    return c;
}

// WIDTHxHEIGHT
std::pair<int, int> parse_size(const std::string& arg) {
    int w = 0, h = 0;
    char x = 0;
    if (std::sscanf(arg.c_str(), "%d%c%d", &w, &x, &h) != 3 || x != 'x' || w <= 0 || h <= 0)
        throw std::runtime_error("--expect-size " + arg + ": expected WIDTHxHEIGHT in pixels (e.g. 720x480)");
    return {w, h};
}

}  // namespace

int main(int argc, char** argv) {
    CLI::App app{"Camera detections from a video (OpenCV's HOG people detector and Viola–Jones cascades) as CSV "
                 "t,x,y,w,h,class,score (README \"Roadside\")"};
    std::string video, output, expect_size;
    std::vector<std::string> cascades;
    bool no_people = false, quiet = false;
    rs::VideoDetectionOptions o;
    app.add_option("VIDEO", video, "Video file (any container and codec OpenCV's FFmpeg reads)")->required();
    app.add_option("-o,--output", output, "Detections CSV to write")->required();
    app.add_option("--cascade", cascades, "CLASS=FILE[:MIN_NEIGHBOURS]: a Viola–Jones cascade (OpenCV XML) whose "
                                          "detections get CLASS (repeatable)");
    app.add_flag("--no-people", no_people, "Do not run the HOG people detector (class pedestrian)");
    app.add_option("--people-threshold", o.people_threshold, "HOG SVM margin a person needs, ≥ 0 (default 0; its score is margin/(1 + margin))");
    app.add_option("--process-width", o.process_width_px, "Frames are scaled to this width for detection, px "
                                                          "(default 720, as the paper)");
    app.add_option("--stride", o.frame_stride, "Detect in every n-th frame (default 1)");
    app.add_option("--start", o.start_time_s, "Camera time of the first frame, s (default 0)");
    app.add_option("--expect-size", expect_size, "WIDTHxHEIGHT the frames must have (the site camera's image)");
    app.add_flag("-q,--quiet", quiet, "No progress on stderr");
    CLI11_PARSE(app, argc, argv);
    // OpenCV's own log lines (back ends tried, files it could not open) would bury the one error this prints.
    cv::utils::logging::setLogLevel(cv::utils::logging::LOG_LEVEL_SILENT);
    try {
        o.people = !no_people;
        for (const auto& c : cascades) o.cascades.push_back(parse_cascade(c));
        const auto progress = [&](long long frame, long long frames) {
            if (!quiet) std::fprintf(stderr, "\r%s: frame %lld of %lld", video.c_str(), frame, frames);
        };
        const rs::VideoDetections found = rs::detect_video(video, o, progress);
        if (!quiet) std::fprintf(stderr, "\r");
        if (!expect_size.empty()) {
            const auto [w, h] = parse_size(expect_size);
            if (w != found.width_px || h != found.height_px)
                throw std::runtime_error(video + ": frames are " + std::to_string(found.width_px) + "x" +
                                         std::to_string(found.height_px) + " px, the site's camera " + expect_size);
        }
        rs::write_detections_csv(found.detections, output);
        if (!quiet) {
            std::map<std::string, int> per_class;
            for (const auto& d : found.detections) ++per_class[d.cls];
            std::fprintf(stderr, "%s: %dx%d px, %.2f fps, %lld frames (%lld processed), %zu detections", video.c_str(),
                         found.width_px, found.height_px, found.fps, found.frames, found.frames_processed,
                         found.detections.size());
            for (const auto& [cls, n] : per_class) std::fprintf(stderr, ", %s %d", cls.c_str(), n);
            std::fprintf(stderr, "\n");
        }
    } catch (const std::exception& e) {
        std::fprintf(stderr, "roadpreview-video: error: %s\n", e.what());
        return 1;
    }
    return 0;
}
