#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <vector>

#include <roadpreview/profile/profile.hpp>
#include <roadpreview/roughness/roughness.hpp>
#include <roadpreview/roughness/support.hpp>

#include "scenes.hpp"

namespace rp = roadpreview;

namespace {
constexpr double kDs = 0.1;
const double kNaN = std::numeric_limits<double>::quiet_NaN();

rp::Profile profile_with_support(std::vector<double> z, int points, double sigma) {
    rp::Profile p;
    p.ds = kDs;
    p.z = std::move(z);
    p.count.assign(p.z.size(), points);
    p.spread.assign(p.z.size(), sigma);
    return p;
}
}  // namespace

TEST(Support, FullyBackedBinsGiveWhiteNoiseAtTheMedianVariance) {
    const std::vector<std::int32_t> count(300, 5);
    const std::vector<double> spread(300, 0.004);
    const auto psd = rp::noise_psd(count.data(), spread.data(), 300, kDs);
    ASSERT_TRUE(psd);
    ASSERT_EQ(psd->size(), 151u);
    for (std::size_t k = 1; k < 150; ++k) EXPECT_NEAR((*psd)[k] / (2 * kDs * M_PI / 2 * 0.004 * 0.004 / 5), 1.0, 1e-12);
}

TEST(Support, NoBinOfTwoPointsMeansUnknownNoise) {
    const std::vector<std::int32_t> count(50, 1);
    const std::vector<double> spread(50, kNaN);
    EXPECT_FALSE(rp::noise_psd(count.data(), spread.data(), 50, kDs));
}

TEST(Support, InterpolationMakesTheNoiseRedAndKeepsItsPower) {
    // Points every 4th bin: the interpolated errors' total power is less than the backed bins' (the gaps carry
    // (1 − f)² + f² of it) and concentrated at low frequencies.
    std::vector<std::int32_t> count(401, 0);
    std::vector<double> spread(401, kNaN);
    for (std::size_t j = 0; j < 401; j += 4) count[j] = 3, spread[j] = 0.005;
    const auto psd = rp::noise_psd(count.data(), spread.data(), 401, kDs);
    ASSERT_TRUE(psd);
    const double white = 2 * kDs * M_PI / 2 * 0.005 * 0.005 / 3;
    EXPECT_GT((*psd)[5], 2.0 * white);   // 4× the spacing: up to 4× the density at low n
    EXPECT_LT((*psd)[100], 0.1 * white);  // 2.5 cycles/m, beyond the points' Nyquist frequency
}

TEST(Support, ResolvedFractionOfRegularSamplingIsTheInterpolationLoss) {
    std::vector<std::int32_t> count(181, 0);
    for (std::size_t j = 0; j < 181; j += 3) count[j] = 2;
    std::vector<double> n;
    for (std::size_t k = 0; k <= 90; ++k) n.push_back(k / (181 * kDs));
    const std::vector<double> phi = rp::resolved_fraction(count.data(), 181, kDs, n);
    for (std::size_t k = 0; k < n.size(); ++k) {
        const double x = n[k] * 0.3;
        const double expected = x == 0 ? 1.0 : x <= 0.5 ? std::pow(std::sin(M_PI * x) / (M_PI * x), 4) : 0.0;
        EXPECT_NEAR(phi[k], expected, 2e-3) << k;
    }
}

TEST(NoiseAwareRoughness, PureNoiseIsDeclinedAndTinyNoiseIsClassA) {
    std::mt19937 rng(4);
    std::normal_distribution<double> gauss(0.0, 1.0);
    std::vector<double> z(400);
    const double sigma = 0.005, bin_sd = sigma * std::sqrt(M_PI / 2 / 4);
    for (double& v : z) v = bin_sd * gauss(rng);
    const rp::Roughness noisy = rp::analyze_roughness(profile_with_support(z, 4, sigma), {});
    EXPECT_FALSE(noisy.iso_class);
    EXPECT_STREQ(rp::to_string(noisy.reason), "noise dominates the band");
    EXPECT_STREQ(rp::to_string(noisy.band_limit), "noise");
    EXPECT_TRUE(rp::analyze_roughness(z, kDs, {}).iso_class);  // not noise-aware: the noise passes for a road
    for (double& v : z) v *= 1e-3;
    const rp::Roughness tiny = rp::analyze_roughness(profile_with_support(z, 4, sigma * 1e-3), {});
    ASSERT_TRUE(tiny.iso_class) << rp::to_string(tiny.reason);
    EXPECT_EQ(*tiny.iso_class, 'A');
}

TEST(NoiseAwareRoughness, RoadAboveTheNoiseKeepsItsClass) {
    for (unsigned seed = 1; seed <= 5; ++seed) {
        std::vector<double> z = scenes::iso_profile(1024e-6, 400, kDs, seed);
        std::mt19937 rng(seed);
        std::normal_distribution<double> gauss(0.0, 0.002);
        for (double& v : z) v += gauss(rng) * std::sqrt(M_PI / 2 / 4);
        const rp::Roughness r = rp::analyze_roughness(profile_with_support(z, 4, 0.002), {});
        ASSERT_TRUE(r.iso_class) << rp::to_string(r.reason);
        EXPECT_EQ(*r.iso_class, 'D') << seed;
        EXPECT_GT(r.confidence, 0.5);
        ASSERT_TRUE(r.noise_floor && r.backed_fraction);
        EXPECT_DOUBLE_EQ(*r.backed_fraction, 1.0);
    }
}
