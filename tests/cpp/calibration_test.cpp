// SPDX-License-Identifier: BSD-3-Clause
// Beam self-calibration: known offsets recovered on a synthetic drive, the drive checks, the beams file round
// trip and sensor check, the beam index by elevation and the correction of points.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <limits>
#include <random>

#include <Eigen/Dense>

#include "roadpreview/calibration/calibration.hpp"

namespace rp = roadpreview;

namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kHeightM = 1.8;
constexpr int kBeams = 24;

double beam_elevation_deg(int b) { return -2.0 - 0.5 * b; }  // 24 beams, −2° … −13.5°
double beam_error_deg(int b) { return 0.05 * std::sin(1.7 * b); }  // up to 0.05°, no smooth trend

// One frame of a flat road seen from kHeightM: rays fly at the table angle + error, the points lie along the table
// angle at the measured range (as a miscalibrated sensor reports them), 2 mm of height noise.
void scan(std::mt19937& rng, std::vector<float>& xyz, std::vector<std::int32_t>& beams) {
    std::normal_distribution<double> noise(0.0, 0.002);
    for (int b = 0; b < kBeams; ++b)
        for (double az_deg = -40.0; az_deg <= 40.0; az_deg += 0.1) {
            const double actual = (beam_elevation_deg(b) + beam_error_deg(b)) * kPi / 180.0;
            const double range = kHeightM / std::sin(-actual) + noise(rng) / std::sin(-actual);
            const double el = beam_elevation_deg(b) * kPi / 180.0, az = az_deg * kPi / 180.0;
            xyz.insert(xyz.end(), {static_cast<float>(range * std::cos(el) * std::cos(az)),
                                   static_cast<float>(range * std::cos(el) * std::sin(az)),
                                   static_cast<float>(range * std::sin(el))});
            beams.push_back(b);
        }
}

rp::Config level_sensor() {
    rp::Config cfg;
    cfg.sensor_height = kHeightM;
    return cfg;
}

// `frames` scans of the flat road drawn from `seed`, each handed to add_frame(frame index, points, beams).
template <class AddFrame>
void drive(unsigned seed, int frames, AddFrame add_frame) {
    std::mt19937 rng(seed);
    for (int f = 0; f < frames; ++f) {
        std::vector<float> xyz;
        std::vector<std::int32_t> beams;
        scan(rng, xyz, beams);
        add_frame(f, rp::points_view(xyz.data(), static_cast<Eigen::Index>(beams.size()), 3), beams);
    }
}

rp::BeamCalibration calibrate_drive(int frames, double step_m) {
    rp::BeamCalibrator calibrator(level_sensor(), kBeams);
    drive(5, frames, [&](int f, rp::PointsView view, const std::vector<std::int32_t>& beams) {
        calibrator.add_frame(view, beams, rp::Pose2{f * step_m, 0.0, 0.0});
    });
    return calibrator.solve();
}

// values less their least-squares fit by 1, 1/reach and reach over the determined beams (the gauge).
std::vector<double> gauge_free(const std::vector<double>& v, const rp::BeamCalibration& c) {
    Eigen::MatrixXd A(0, 3);
    Eigen::VectorXd y(0);
    std::vector<int> idx;
    for (int b = 0; b < kBeams; ++b) {
        if (!c.beams[static_cast<std::size_t>(b)].determined) continue;
        const double reach = kHeightM / std::tan(-beam_elevation_deg(b) * kPi / 180.0);
        A.conservativeResize(A.rows() + 1, 3);
        A.row(A.rows() - 1) << 1.0, 1.0 / reach, reach;
        y.conservativeResize(y.size() + 1);
        y[y.size() - 1] = v[static_cast<std::size_t>(b)];
        idx.push_back(b);
    }
    const Eigen::VectorXd fit = A * A.colPivHouseholderQr().solve(y);
    std::vector<double> out(v.size(), 0.0);
    for (std::size_t k = 0; k < idx.size(); ++k) out[static_cast<std::size_t>(idx[k])] = y[static_cast<Eigen::Index>(k)] - fit[static_cast<Eigen::Index>(k)];
    return out;
}

// Every determined beam of c within 0.005° of the true offset in the same gauge, and at least half determined.
void expect_known_offsets(const rp::BeamCalibration& c) {
    std::vector<double> truth;
    for (int b = 0; b < kBeams; ++b) truth.push_back(beam_error_deg(b));
    const std::vector<double> expected = gauge_free(truth, c);
    int determined = 0;
    for (int b = 0; b < kBeams; ++b) {
        const rp::BeamOffsets& o = c.beams[static_cast<std::size_t>(b)];
        if (!o.determined) continue;
        ++determined;
        EXPECT_NEAR(o.elevation_offset_deg, expected[static_cast<std::size_t>(b)], 0.005) << "beam " << b;
        EXPECT_GE(o.elevation_sigma_deg, 0.0) << "beam " << b;
    }
    EXPECT_GE(determined, kBeams / 2);
}

}  // namespace

TEST(BeamCalibrator, RecoversKnownElevationOffsets) {
    const rp::BeamCalibration c = calibrate_drive(8, 1.0);
    expect_known_offsets(c);
    for (const rp::BeamOffsets& o : c.beams) {
        EXPECT_EQ(o.range_offset_m, 0.0) << "a flat road cannot tell a range offset from an elevation offset";
        if (o.determined) {
            EXPECT_GT(o.elevation_sigma_deg, 0.0);
        }
    }
    EXPECT_EQ(c.frames, 8);
    EXPECT_NEAR(c.travel_m, 7.0, 1e-9);
}

TEST(BeamCalibrator, RejectsAShortOrStaticDrive) {
    EXPECT_THROW(calibrate_drive(1, 1.0), rp::CalibrationError);
    try {
        calibrate_drive(4, 0.0);
        FAIL() << "a static drive was calibrated";
    } catch (const rp::CalibrationError& e) {
        EXPECT_NE(std::string(e.what()).find("no motion"), std::string::npos) << e.what();
    }
}

TEST(BeamCalibrator, RejectsBeamIndicesBeyondTheSensor) {
    rp::BeamCalibrator calibrator(level_sensor(), 4);
    std::vector<float> xyz{10.0f, 0.0f, -1.8f};
    EXPECT_THROW(calibrator.add_frame(rp::points_view(xyz.data(), 1, 3), {7}, {1}, rp::Pose2{}), std::invalid_argument);
}

TEST(BeamCalibrator, RejectsCellsNoIntegerIndexHolds) {  // 1e-300 m cells: 4e301 cells in 40 m of road
    for (const double cell : {1e-300, 0.001, 50.0, std::numeric_limits<double>::quiet_NaN()}) {
        rp::CalibrationOptions options;
        options.cell_m = cell;
        EXPECT_THROW(rp::BeamCalibrator(level_sensor(), 4, options), std::invalid_argument) << cell;
    }
}

TEST(BeamsFile, RoundTripsAndChecksTheSensor) {
    rp::BeamCalibration c;
    c.sensor_model = "OS-1-128";
    c.serial = "122201000998";
    c.beam_count = 2;
    c.beams.resize(2);
    c.beams[1].determined = true;
    c.beams[1].elevation_offset_deg = 0.0125;
    c.beams[1].elevation_sigma_deg = 0.001;
    const std::string path = ::testing::TempDir() + "/beams.yaml";
    rp::write_beam_calibration(c, path);
    const rp::BeamCalibration back = rp::read_beam_calibration(path);
    EXPECT_EQ(back.serial, "122201000998");
    EXPECT_FALSE(back.beams[0].determined);
    EXPECT_TRUE(std::isnan(back.beams[0].elevation_sigma_deg));
    EXPECT_DOUBLE_EQ(back.beams[1].elevation_offset_deg, 0.0125);
    EXPECT_NO_THROW(rp::check_beam_calibration(back, 2, "OS-1-128", "122201000998"));
    for (const auto& [beams, serial] : {std::pair<int, std::string>{3, ""}, {2, "999"}}) {
        try {
            rp::check_beam_calibration(back, beams, "", serial);
            FAIL() << "another sensor's beams file was accepted";
        } catch (const std::runtime_error& e) {
            EXPECT_NE(std::string(e.what()).find(path), std::string::npos) << "the message names the file: " << e.what();
        }
    }
    std::FILE* f = std::fopen(path.c_str(), "w");
    std::fputs("format: something else\n", f);
    std::fclose(f);
    EXPECT_THROW(rp::read_beam_calibration(path), std::runtime_error);
}

TEST(BeamsFile, CorrectsPointsAlongTheirBeam) {
    rp::BeamCalibration c;
    c.beam_count = 1;
    c.beams.resize(1);
    c.beams[0].elevation_offset_deg = 0.1;
    c.beams[0].range_offset_m = 0.05;
    const double el = -10.0 * kPi / 180.0;
    float p[3] = {static_cast<float>(20.0 * std::cos(el)), 0.0f, static_cast<float>(20.0 * std::sin(el))};
    rp::apply_beam_calibration(p, 1, 3, {0}, c);
    EXPECT_NEAR(std::hypot(p[0], p[2]), 19.95, 1e-5);
    EXPECT_NEAR(std::atan2(p[2], p[0]) * 180.0 / kPi, -9.9, 1e-5);
}

TEST(BeamsFile, FindsBeamsByElevationUnderATilt) {
    std::mt19937 rng(1);
    std::vector<float> xyz;
    std::vector<std::int32_t> truth;
    for (int b = 0; b < kBeams; ++b)
        for (double az = -170.0; az <= 170.0; az += 0.5) {
            const double a = az * kPi / 180.0;
            const double el = (beam_elevation_deg(b) + 0.2 * (std::cos(a) - 1.0) - 0.3 * std::sin(a)) * kPi / 180.0;
            const double r = 10.0 + 0.01 * b;
            xyz.insert(xyz.end(), {static_cast<float>(r * std::cos(el) * std::cos(a)),
                                   static_cast<float>(r * std::cos(el) * std::sin(a)), static_cast<float>(r * std::sin(el))});
            truth.push_back(b);
        }
    const auto view = rp::points_view(xyz.data(), static_cast<Eigen::Index>(truth.size()), 3);
    rp::BeamCalibration c;
    rp::find_beam_centres({view}, kBeams, c);
    EXPECT_NEAR(c.tilt_deg[0], 0.2, 0.021);
    EXPECT_NEAR(c.tilt_deg[1], -0.3, 0.021);
    EXPECT_EQ(rp::beams_by_elevation(view, c), truth);

    // Offsets estimated from such frames are saved with the way they were indexed, so applying them finds the
    // same beams; frames the decoder numbered (no indexing) leave the estimate as it is.
    rp::BeamCalibration estimated;
    estimated.beam_count = kBeams;
    estimated.beams.resize(kBeams);
    rp::adopt_beam_indexing(estimated, rp::BeamCalibration{});
    EXPECT_EQ(estimated.index, rp::BeamIndexMethod::Decoder);
    EXPECT_TRUE(std::isnan(estimated.beams[0].elevation_deg));
    rp::adopt_beam_indexing(estimated, c);
    EXPECT_EQ(estimated.index, rp::BeamIndexMethod::Elevation);
    EXPECT_EQ(estimated.index_tolerance_deg, c.index_tolerance_deg);
    EXPECT_EQ(rp::beams_by_elevation(view, estimated), truth);
}

namespace {

// A drive of `frames` frames of the flat road, from anywhere (the surface calibration needs no poses).
rp::BeamCalibration calibrate_on_surface(int frames) {
    rp::SurfaceCalibrator calibrator(level_sensor(), kBeams);
    drive(11, frames, [&](int, rp::PointsView view, const std::vector<std::int32_t>& beams) {
        calibrator.add_frame(view, beams);
    });
    return calibrator.solve();
}

// One turn per beam from azimuth 0, the top beam first, as KITTI's .bin files list their points.
std::vector<float> rings_in_order(int beams) {
    std::vector<float> xyz;
    for (int b = 0; b < beams; ++b)
        for (double az_deg = 0.2; az_deg < 360.0; az_deg += 0.4) {
            const double el = beam_elevation_deg(b) * kPi / 180.0, az = az_deg * kPi / 180.0, range = 12.0;
            xyz.insert(xyz.end(), {static_cast<float>(range * std::cos(el) * std::cos(az)),
                                   static_cast<float>(range * std::cos(el) * std::sin(az)),
                                   static_cast<float>(range * std::sin(el))});
        }
    return xyz;
}

}  // namespace

TEST(SurfaceCalibrator, RecoversKnownElevationOffsetsWithoutMotion) {
    const rp::BeamCalibration c = calibrate_on_surface(5);
    expect_known_offsets(c);
    for (const rp::BeamOffsets& o : c.beams)
        if (o.determined) {
            EXPECT_EQ(o.observations, 5) << "one reading per frame";
        }
    EXPECT_EQ(c.frames, 5);
    EXPECT_EQ(c.travel_m, 0.0);
}

TEST(SurfaceCalibrator, RejectsTooFewFrames) {
    try {
        calibrate_on_surface(2);
        FAIL() << "two frames were calibrated";
    } catch (const rp::CalibrationError& e) {
        EXPECT_NE(std::string(e.what()).find("too short"), std::string::npos) << e.what();
    }
}

TEST(BeamIndex, FilesListedRingByRingAreIndexedByScanOrderElseByElevation) {
    std::vector<float> xyz = rings_in_order(kBeams);
    const auto rows = static_cast<Eigen::Index>(xyz.size() / 3);
    const auto view = rp::points_view(xyz.data(), rows, 3);
    rp::BeamCalibration c;
    rp::find_beam_centres({view}, kBeams, c);
    ASSERT_EQ(c.index, rp::BeamIndexMethod::ScanOrder);
    EXPECT_NEAR(c.beams[3].elevation_deg, beam_elevation_deg(3), 1e-4);
    const std::vector<std::int32_t> beams = rp::beams_of_points(view, c, "rings.bin");
    for (Eigen::Index k = 0; k < rows; k += 97) EXPECT_EQ(beams[static_cast<std::size_t>(k)], k / (rows / kBeams));
    EXPECT_TRUE(rp::read_beam_calibration([&] {
                    const std::string path = ::testing::TempDir() + "/scan_order.yaml";
                    rp::write_beam_calibration(c, path);
                    return path;
                }()).index == rp::BeamIndexMethod::ScanOrder);

    // the same points with two rings swapped: not in scan order from the top down, so found by elevation
    std::vector<float> swapped(xyz);
    const std::size_t ring = xyz.size() / kBeams;
    std::rotate(swapped.begin(), swapped.begin() + static_cast<std::ptrdiff_t>(ring),
                swapped.begin() + static_cast<std::ptrdiff_t>(2 * ring));
    const auto other = rp::points_view(swapped.data(), rows, 3);
    rp::BeamCalibration e;
    rp::find_beam_centres({other}, kBeams, e);
    EXPECT_EQ(e.index, rp::BeamIndexMethod::Elevation);
    try {
        rp::beams_of_points(other, c, "swapped.bin");
        FAIL() << "points out of scan order were indexed by it";
    } catch (const std::runtime_error& err) {
        EXPECT_NE(std::string(err.what()).find("swapped.bin"), std::string::npos) << err.what();
    }
}

TEST(SurfaceCalibrator, ANoiseFreeRoadIsNoCrash) {
    // exact heights: the residuals' robust σ is 0, so no point may be dropped as an outlier
    rp::SurfaceCalibrator calibrator(level_sensor(), kBeams);
    for (int f = 0; f < 3; ++f) {
        std::vector<float> xyz;
        std::vector<std::int32_t> beams;
        for (int b = 0; b < kBeams; ++b)
            for (double az_deg = -40.0; az_deg <= 40.0; az_deg += 0.1) {
                const double el = beam_elevation_deg(b) * kPi / 180.0, az = az_deg * kPi / 180.0;
                const double range = kHeightM / std::sin(-el);
                xyz.insert(xyz.end(), {static_cast<float>(range * std::cos(el) * std::cos(az)),
                                       static_cast<float>(range * std::cos(el) * std::sin(az)),
                                       static_cast<float>(-kHeightM)});
                beams.push_back(b);
            }
        calibrator.add_frame(rp::points_view(xyz.data(), static_cast<Eigen::Index>(beams.size()), 3), beams);
    }
    const rp::BeamCalibration c = calibrator.solve();
    int determined = 0;
    for (const rp::BeamOffsets& o : c.beams)
        if (o.determined) {
            ++determined;
            EXPECT_NEAR(o.elevation_offset_deg, 0.0, 1e-9);  // exact heights: no offset but rounding's
        }
    EXPECT_GE(determined, kBeams / 2);  // most beams see the road (19 of 24 measured)
}
