// SPDX-License-Identifier: BSD-3-Clause
// The moments the PCA fits are made from (internal: cpp/src/ground/plane_fit.hpp): a kept set that changes is
// updated by the points it drops and takes back rather than summed again.
#include <gtest/gtest.h>

#include <random>
#include <vector>

#include "ground/plane_fit.hpp"

namespace rp = roadpreview;

namespace {

// Points of a tilted, rough plane far from the origin (where a one-pass covariance loses precision without a shift).
std::vector<Eigen::Vector3d> rough_plane(int n, unsigned seed) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<double> along(-20.0, 20.0);
    std::normal_distribution<double> rough(0.0, 0.02);
    std::vector<Eigen::Vector3d> pts;
    for (int i = 0; i < n; ++i) {
        const double x = 1000.0 + along(rng), y = -500.0 + along(rng);
        pts.emplace_back(x, y, 30.0 + 0.03 * x - 0.01 * y + rough(rng));
    }
    return pts;
}

void expect_same_fit(const rp::Moments& a, const rp::Moments& b) {
    const auto fa = rp::plane_fit(a), fb = rp::plane_fit(b);
    ASSERT_TRUE(fa && fb);
    EXPECT_EQ(a.count, b.count);
    for (int k = 0; k < 4; ++k) EXPECT_NEAR(fa->plane[k], fb->plane[k], 1e-9 * (k == 3 ? 100.0 : 1.0));
    EXPECT_NEAR((fa->centre - fb->centre).norm(), 0.0, 1e-9);
    EXPECT_NEAR(fa->flatness_m2, fb->flatness_m2, 1e-12);
    EXPECT_NEAR(fa->breadth_m2, fb->breadth_m2, 1e-9);
}

}  // namespace

TEST(Moments, RemovingPointsGivesTheFitOfThoseLeft) {
    const auto pts = rough_plane(5000, 3);
    rp::Moments all, left;
    for (const auto& p : pts) all.add(p);
    for (std::size_t i = 0; i < pts.size(); ++i) {
        if (i % 3 == 0) all.remove(pts[i]);
        else left.add(pts[i]);
    }
    expect_same_fit(all, left);
}

TEST(Moments, RemovingEveryPointEmptiesThemAndTheNextPointSetsAFreshShift) {
    const auto first = rough_plane(200, 4), second = rough_plane(300, 5);
    rp::Moments m, fresh;
    for (const auto& p : first) m.add(p);
    for (const auto& p : first) m.remove(p);
    EXPECT_EQ(m.count, 0);
    EXPECT_FALSE(rp::plane_fit(m));
    for (const auto& p : second) m.add(p), fresh.add(p);
    EXPECT_EQ(m.shift, fresh.shift);
    EXPECT_EQ(m.sum, fresh.sum);
    EXPECT_EQ(m.outer, fresh.outer);  // bit for bit: nothing of the first set is left
}
