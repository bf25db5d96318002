// SPDX-License-Identifier: BSD-3-Clause
// ProfileReadout: each wheel's profile read a fixed distance ahead into an array along the drive
// (docs/method.md §10, "Readout").
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

#include <roadpreview/route/readout.hpp>

namespace rp = roadpreview;

namespace {

constexpr double kDs = 0.1;

// Frame `index` of a drive at 10 m/s and 10 Hz (1 m a frame): 30 m of profile per wheel whose every height says
// which frame read it — 1000·index + the bin's drive distance in decimetres.
rp::Result frame(int index, rp::PathStatus status = rp::PathStatus::Straight) {
    rp::Result r;
    r.frame = index;
    r.timestamp = 0.1 * index;
    r.speed_mps = 10.0;
    r.path.status = status;
    r.path.direction = 1.0;
    for (rp::Profile* p : {&r.left, &r.right}) {
        p->ds = kDs;
        for (int k = 0; k < 300; ++k) {
            p->s.push_back((k + 0.5) * kDs);
            p->z.push_back(1000.0 * index + (index * 10 + k));
            p->count.push_back(3);
            p->spread.push_back(0.0);
        }
    }
    return r;
}

}  // namespace

TEST(Readout, EachBinHoldsWhatTheFrameThatHadItAtTheDistanceAheadRead) {
    rp::ProfileReadout readout(rp::Config{}, 6.0);
    for (int f = 0; f < 10; ++f) readout.add(frame(f));
    EXPECT_NEAR(readout.distance_m(), 9.0, 1e-12);
    const rp::ReadoutProfile& p = readout.left();
    // Drive bin X (decimetres) lay 6–7 m ahead of frame ⌊X/10⌋ − 6: the last frame that had it 6 m or more ahead.
    ASSERT_EQ(p.s.size(), 60u);  // from the wheel (drive 9 m) to 6 m ahead
    for (std::size_t i = 0; i < p.s.size(); ++i) {
        const int x = 90 + static_cast<int>(i);
        EXPECT_NEAR(p.s[i], (x + 0.5) * kDs - 9.0, 1e-9) << i;
        const int reader = x / 10 - 6;
        EXPECT_DOUBLE_EQ(p.z[i], 1000.0 * reader + x) << i;
        EXPECT_EQ(p.count[i], 3);
    }
    EXPECT_EQ(readout.right().z, p.z);
}

TEST(Readout, TheFirstFrameLeavesTheArrayEmptyAndTheNextShiftsItsReadingIn) {
    rp::ProfileReadout readout(rp::Config{}, 6.0);
    readout.add(frame(0));
    ASSERT_EQ(readout.left().z.size(), 60u);  // 0–6 m: nothing lay 6 m ahead of an earlier frame
    for (const double z : readout.left().z) EXPECT_TRUE(std::isnan(z));
    readout.add(frame(1));  // a metre on: 6–7 m of the drive keep frame 0's reading
    ASSERT_EQ(readout.left().z.size(), 60u);
    for (std::size_t i = 0; i < 50; ++i) EXPECT_TRUE(std::isnan(readout.left().z[i])) << i;
    for (std::size_t i = 50; i < 60; ++i) EXPECT_DOUBLE_EQ(readout.left().z[i], 10.0 + static_cast<double>(i)) << i;
}

TEST(Readout, AFrameWithoutProfilesLeavesItsStretchToTheFrameBefore) {
    rp::ProfileReadout readout(rp::Config{}, 6.0);
    for (int f = 0; f < 5; ++f) {
        rp::Result r = frame(f);
        if (f == 3) r.status = rp::FrameStatus::NoGround;
        readout.add(r);
    }
    const rp::ReadoutProfile& p = readout.left();  // the wheel at 4 m: drive 9–10 m was frame 3's to read last
    ASSERT_EQ(p.s.size(), 60u);
    for (std::size_t i = 0; i < p.s.size(); ++i) {
        const int x = 40 + static_cast<int>(i);
        if (x < 60)
            EXPECT_TRUE(std::isnan(p.z[i])) << x;
        else
            EXPECT_DOUBLE_EQ(p.z[i], 1000.0 * (x >= 90 ? 2 : x / 10 - 6) + x) << x;
    }
}

TEST(Readout, OnAnArcEachWheelsBinsAreReadAtTheirArcLengthWithoutHoles) {
    rp::ProfileReadout readout(rp::Config{}, 6.0);
    for (int f = 0; f < 8; ++f) {
        rp::Result r = frame(f, rp::PathStatus::Arc);
        r.path.icr_y = 20.0;  // turning left: the left wheel at 19.2 m, the right at 20.8 m from the centre
        r.path.left_radius = 19.2;
        r.path.right_radius = 20.8;
        readout.add(r);
    }
    for (const auto& [p, q] : {std::pair{&readout.left(), 20.0 / 19.2}, std::pair{&readout.right(), 20.0 / 20.8}}) {
        ASSERT_EQ(p->s.size(), 60u);  // drive 7–13 m
        for (std::size_t i = 0; i < p->s.size(); ++i) {
            EXPECT_NEAR(p->s[i] * q, (static_cast<double>(i) + 0.5) * kDs, 1e-9);
            if (i < 10) continue;  // drive 7–8 m: nothing lay 6 m ahead before frame 1
            ASSERT_TRUE(std::isfinite(p->z[i])) << i;
            // read by frame f at arc length s: the profile is linear in its bin index k within a frame
            const double x = 70.0 + static_cast<double>(i) + 0.5;  // drive, decimetres
            const int f = static_cast<int>(std::floor(x / 10.0 - 6.0));
            const double s_dm = (x - 10.0 * f) / q;
            EXPECT_NEAR(p->z[i], 1000.0 * f + 10.0 * f + s_dm - 0.5, 1e-9) << i;
        }
    }
}

TEST(Readout, PosesGiveTheDistanceDriven) {
    rp::ProfileReadout readout(rp::Config{}, 6.0);
    readout.add(frame(0), rp::Pose2{5.0, 1.0, 0.0});
    readout.add(frame(1), rp::Pose2{5.0, 3.0, 1.5});
    EXPECT_NEAR(readout.distance_m(), 2.0, 1e-12);
}

TEST(Readout, BadDistancesAndFramesAreErrorsNamingThem) {
    for (const double bad : {0.0, -1.0, std::numeric_limits<double>::quiet_NaN(), 40.0, 55.0}) {
        try {
            rp::ProfileReadout readout(rp::Config{}, bad);
            FAIL() << bad;
        } catch (const std::invalid_argument& e) {
            EXPECT_NE(std::string(e.what()).find("readout: the distance ahead"), std::string::npos) << e.what();
        }
    }
    try {  // numbers as they were given, not as %f: 301 digits, or 6 decimals of noise
        rp::ProfileReadout readout(rp::Config{}, 1e300);
        FAIL();
    } catch (const std::invalid_argument& e) {
        EXPECT_EQ(std::string(e.what()), "readout: the distance ahead (1e+300 m) must lie within the profiles "
                                         "(profile.preview_length_m 40 m)");
    }
    rp::ProfileReadout readout(rp::Config{}, 6.0);
    readout.add(frame(3));
    rp::Result back = frame(2);
    back.source = "b.bin";
    try {
        readout.add(back);
        FAIL();
    } catch (const std::invalid_argument& e) {
        EXPECT_EQ(std::string(e.what()).rfind("readout: frame 1 (b.bin) is 0.1", 0), 0u) << e.what();
    }
    EXPECT_THROW(readout.add(frame(4), rp::Pose2{0.0, 0.0, 0.0}), std::invalid_argument);  // poses for some only
}

TEST(Readout, ProfilesItCannotPlaceAreErrorsNamingTheFrameThatLeaveTheReadoutAsItWas) {  // lines from files
    rp::ProfileReadout readout(rp::Config{}, 6.0);
    readout.add(frame(0));
    const auto expect_error = [&](const rp::Result& r, const std::string& start) {
        try {
            readout.add(r);
            FAIL() << start;
        } catch (const std::invalid_argument& e) {
            EXPECT_EQ(std::string(e.what()).rfind(start, 0), 0u) << e.what();
        }
        EXPECT_EQ(readout.frames(), 1u);
        EXPECT_NEAR(readout.distance_m(), 0.0, 1e-12);
    };
    rp::Result far = frame(1);
    far.source = "run.jsonl:2";
    for (double& s : far.left.s) s += 1e300;
    expect_error(far, "readout: frame 1 (run.jsonl:2): a profile bin lies at 1e+300 m, beyond the profiles' reach");
    rp::Result no_scale = frame(1, rp::PathStatus::Arc);
    no_scale.path.icr_y = std::numeric_limits<double>::quiet_NaN();
    no_scale.path.left_radius = no_scale.path.right_radius = 10.0;
    expect_error(no_scale, "readout: frame 1: the path's centre of rotation and wheel radii give no distance");
    // A speed or a time stamp no drive has: the drive distance would lose its decimetres (and bins be allocated).
    rp::Result fast = frame(1);
    fast.speed_mps = 1e300;
    expect_error(fast, "readout: frame 1 moves the drive on by 1e+299 m (|speed| × its time since the previous frame)");
    rp::Result late = frame(1);
    late.timestamp = 1e300;
    expect_error(late, "readout: frame 1 moves the drive on by 1e+301 m");
    rp::Result not_a_number = frame(1);
    not_a_number.speed_mps = std::numeric_limits<double>::quiet_NaN();
    expect_error(not_a_number, "readout: frame 1 moves the drive on by nan m");
    readout.add(frame(1));  // the readout goes on
    EXPECT_EQ(readout.frames(), 2u);
}

TEST(Readout, AWheelTurningAboutAPointBesideItReadsNothing) {
    // The inner wheel 1 mm from the centre of rotation: 800 m of drive per metre of its path, its 30 m of profile
    // would span 24 km of drive. It reads nothing (the outer wheel reads as ever), in a bounded time.
    rp::ProfileReadout readout(rp::Config{}, 6.0);
    for (int f = 0; f < 10; ++f) {
        rp::Result r = frame(f, rp::PathStatus::Arc);
        r.path.icr_y = 0.801;
        r.path.left_radius = 0.001;
        r.path.right_radius = 1.601;
        readout.add(r);
    }
    const auto finite = [](const std::vector<double>& z) {
        return std::count_if(z.begin(), z.end(), [](double v) { return std::isfinite(v); });
    };
    EXPECT_EQ(finite(readout.left().z), 0);
    EXPECT_GT(finite(readout.right().z), 50);
}
