// SPDX-License-Identifier: BSD-3-Clause
// Built-in camera detection from video (roadpreview/roadside/video.hpp): HOG people on drawn silhouettes, frame
// times, strides and the processing scale, and bad input.
#include <gtest/gtest.h>

#include <opencv2/imgproc.hpp>
#include <opencv2/videoio.hpp>

#include <cmath>
#include <cstdio>
#include <fstream>
#include <string>

#include "roadpreview/roadside/video.hpp"

namespace rs = roadpreview::roadside;

namespace {

// A dark walking figure `height` px tall standing on (x, foot_y).
void draw_person(cv::Mat& image, double x, double foot_y, double height) {
    const double s = height / 180.0;
    const auto at = [&](double dx, double dy) { return cv::Point(int(std::lround(x + dx * s)), int(std::lround(foot_y - dy * s))); };
    const cv::Scalar colour(60, 40, 40);
    cv::ellipse(image, at(0, 165), cv::Size(int(11 * s), int(14 * s)), 0, 0, 360, colour, -1);
    cv::ellipse(image, at(0, 115), cv::Size(int(20 * s), int(36 * s)), 0, 0, 360, colour, -1);
    cv::line(image, at(-8, 85), at(-14, 2), colour, std::max(1, int(11 * s)));
    cv::line(image, at(8, 85), at(15, 2), colour, std::max(1, int(11 * s)));
    cv::line(image, at(-18, 140), at(-26, 80), colour, std::max(1, int(8 * s)));
    cv::line(image, at(18, 140), at(26, 80), colour, std::max(1, int(8 * s)));
}

// `frames` frames at 10 fps, 1440 × 960, of one figure 300 px tall walking right by 20 px a frame; a file per test,
// as ctest runs the tests in parallel processes.
std::string walking_video(int frames) {
    const std::string path = testing::TempDir() + "roadside_walk_" +
                             testing::UnitTest::GetInstance()->current_test_info()->name() + ".avi";
    cv::VideoWriter writer(path, cv::VideoWriter::fourcc('M', 'J', 'P', 'G'), 10.0, cv::Size(1440, 960));
    EXPECT_TRUE(writer.isOpened());
    cv::Mat noise(960, 1440, CV_8UC3);
    for (int k = 0; k < frames; ++k) {
        cv::Mat image(960, 1440, CV_8UC3, cv::Scalar(170, 170, 170));
        cv::randn(noise, 0, 6);
        image += noise;
        draw_person(image, 400 + 20 * k, 800, 300);
        writer.write(image);
    }
    return path;
}

}  // namespace

TEST(RoadsideVideo, PeopleAreFoundStandingWhereTheyAreAtEachFramesTime) {
    const std::string video = walking_video(12);
    rs::VideoDetectionOptions o;  // processed at 720 px: half size, boxes back in the video's pixels
    o.start_time_s = 100.0;
    o.frame_stride = 3;
    const rs::VideoDetections found = rs::detect_video(video, o);
    EXPECT_EQ(found.width_px, 1440);
    EXPECT_EQ(found.height_px, 960);
    EXPECT_NEAR(found.fps, 10.0, 1e-6);
    EXPECT_EQ(found.frames, 12);
    EXPECT_EQ(found.frames_processed, 4);  // frames 0, 3, 6, 9
    ASSERT_EQ(found.detections.size(), 4u);
    for (std::size_t i = 0; i < found.detections.size(); ++i) {
        const rs::CameraDetection& d = found.detections[i];
        const int frame = 3 * static_cast<int>(i);
        EXPECT_NEAR(d.t_s, 100.0 + 0.1 * frame, 1e-9);
        EXPECT_EQ(d.cls, "pedestrian");
        EXPECT_GT(d.score, 0.0);
        EXPECT_LT(d.score, 1.0);
        EXPECT_NEAR(d.x_px + d.w_px / 2, 400 + 20 * frame, 8.0);  // the box's bottom centre: the feet
        EXPECT_NEAR(d.y_px + d.h_px, 800.0, 0.1 * 300);
        EXPECT_NEAR(d.h_px, 300.0, 0.15 * 300);  // trimmed to the person, not HOG's window
    }
}

// OpenCV's full-body Haar cascade (Debian's opencv-data, installed by scripts/setup.sh) on the same figure.
TEST(RoadsideVideo, ViolaJonesCascadeDetectionsGetTheirClassAndScore) {
    const std::string cascade = "/usr/share/opencv4/haarcascades/haarcascade_fullbody.xml";
    ASSERT_TRUE(std::ifstream(cascade).good()) << cascade << " missing: apt-get install opencv-data";
    const std::string video = walking_video(3);
    rs::VideoDetectionOptions o;
    o.people = false;
    o.cascades.push_back({"walker", cascade, 3});
    const rs::VideoDetections found = rs::detect_video(video, o);
    ASSERT_FALSE(found.detections.empty());
    for (const rs::CameraDetection& d : found.detections) {
        EXPECT_EQ(d.cls, "walker");
        const int frame = static_cast<int>(std::lround(d.t_s * 10.0));
        EXPECT_NEAR(d.x_px + d.w_px / 2, 400 + 20 * frame, 20.0);  // centred on the figure,
        EXPECT_LT(d.y_px, 800.0 - 300.0 * 0.6);                    // over most of its height
        EXPECT_GT(d.y_px + d.h_px, 800.0 - 300.0 * 0.2);
        // n hits of min_neighbours 3: n / (n + 3), n ≥ 3
        EXPECT_GE(d.score, 0.5);
        EXPECT_LT(d.score, 1.0);
    }
}

TEST(RoadsideVideo, BadInputNamesTheFile) {
    const std::string video = walking_video(2);
    const auto message = [](const auto& call) {
        try {
            call();
        } catch (const std::runtime_error& e) {
            return std::string(e.what());
        }
        return std::string("no error");
    };
    EXPECT_NE(message([] { rs::detect_video("missing_video.mp4"); }).find("missing_video.mp4"), std::string::npos);
    const std::string text = testing::TempDir() + "roadside_not_a_video.avi";
    std::ofstream(text) << "hello";
    EXPECT_NE(message([&] { rs::detect_video(text); }).find("cannot read the video"), std::string::npos);
    rs::VideoDetectionOptions o;
    o.cascades.push_back({"car", testing::TempDir() + "no_such_cascade.xml"});
    EXPECT_NE(message([&] { rs::detect_video(video, o); }).find("no_such_cascade.xml"), std::string::npos);
    o.cascades = {{"car", text}};
    EXPECT_NE(message([&] { rs::detect_video(video, o); }).find("roadside_not_a_video.avi"), std::string::npos);
    o.cascades = {{"a,b", text}};
    EXPECT_NE(message([&] { rs::detect_video(video, o); }).find("without commas"), std::string::npos);
    o = {};
    o.people = false;
    EXPECT_NE(message([&] { rs::detect_video(video, o); }).find("nothing to detect"), std::string::npos);
    o = {};
    o.frame_stride = 0;
    EXPECT_NE(message([&] { rs::detect_video(video, o); }).find("stride"), std::string::npos);
}
