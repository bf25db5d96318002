#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <numeric>

#include <roadpreview/roughness/roughness.hpp>

#include "scenes.hpp"

namespace rp = roadpreview;

namespace {

constexpr double kDs = 0.1;
const double kIsoMeans[] = {16e-6, 64e-6, 256e-6, 1024e-6, 4096e-6, 16384e-6, 65536e-6, 262144e-6};

std::vector<double> sine(double amplitude, double cycles_per_m, std::size_t n, double phase = 0.3) {
    std::vector<double> z(n);
    for (std::size_t j = 0; j < n; ++j) z[j] = amplitude * std::sin(2 * M_PI * cycles_per_m * j * kDs + phase);
    return z;
}

}  // namespace

TEST(Roughness, SinePeaksAtItsFrequencyWithItsPower) {
    const double amplitude = 0.02, freq = 1.25;  // 50 whole cycles in 40 m
    const rp::Spectrum sp = rp::displacement_psd(sine(amplitude, freq, 400).data(), 400, kDs);
    const auto peak = std::max_element(sp.psd.begin(), sp.psd.end()) - sp.psd.begin();
    EXPECT_NEAR(sp.n[peak], freq, 1e-12);
    const double dn = sp.n[1];
    const double power = (sp.psd[peak - 1] + sp.psd[peak] + sp.psd[peak + 1]) * dn;  // Hann main lobe
    EXPECT_NEAR(power, amplitude * amplitude / 2, 1e-3 * amplitude * amplitude / 2);
}

TEST(Roughness, ParsevalHoldsForTheWindowedCorrectedProfile) {
    std::mt19937 rng(3);
    std::normal_distribution<double> g(0.0, 0.01);
    for (std::size_t n : {64u, 101u, 400u}) {
        std::vector<double> z(n);
        for (double& v : z) v = g(rng) + 0.3;
        const rp::Spectrum sp = rp::displacement_psd(z.data(), n, kDs);
        const double lhs = std::accumulate(sp.psd.begin(), sp.psd.end(), 0.0) * sp.n[1];
        // Right side from the definition: detrend, periodic Hann, mean square / mean window power.
        std::vector<double> idx(n);
        std::iota(idx.begin(), idx.end(), 0.0);
        const double mi = (n - 1) / 2.0, mz = std::accumulate(z.begin(), z.end(), 0.0) / n;
        double sxx = 0, sxz = 0;
        for (std::size_t j = 0; j < n; ++j) sxx += (j - mi) * (j - mi), sxz += (j - mi) * (z[j] - mz);
        double xw2 = 0, w2 = 0;
        for (std::size_t j = 0; j < n; ++j) {
            const double x = z[j] - mz - sxz / sxx * (j - mi), w = 0.5 * (1 - std::cos(2 * M_PI * j / n));
            xw2 += x * x * w * w, w2 += w * w;
        }
        EXPECT_NEAR(lhs, xw2 / w2, 1e-12 * lhs) << n;
    }
}

TEST(Roughness, ClassLimitsSitAtTheGeometricMidpoints) {
    const double limits[] = {32e-6, 128e-6, 512e-6, 2048e-6, 8192e-6, 32768e-6, 131072e-6};
    for (int k = 0; k < 7; ++k) {
        EXPECT_EQ(rp::iso_class(limits[k] * (1 - 1e-9)), rp::kIsoClasses[k]);
        EXPECT_EQ(rp::iso_class(limits[k]), rp::kIsoClasses[k + 1]);  // a limit belongs to the rougher class
        EXPECT_EQ(rp::iso_class(limits[k] * (1 + 1e-9)), rp::kIsoClasses[k + 1]);
    }
    for (int k = 0; k < 8; ++k) EXPECT_EQ(rp::iso_class(kIsoMeans[k]), rp::kIsoClasses[k]);
    EXPECT_EQ(rp::iso_class(0.0), 'A');
    EXPECT_EQ(rp::iso_class(1.0), 'H');
}

// Each class's geometric mean lies a factor 2 from both limits; the estimator's spread over ~155 band
// ordinates is ~10 % (π/√6/√155 in ln), so a correct estimator is never a whole class off.
class IsoClassProfiles : public ::testing::TestWithParam<int> {};

TEST_P(IsoClassProfiles, SyntheticProfileOfEachClassIsThatClass) {
    const int k = GetParam();
    for (unsigned seed = 1; seed <= 5; ++seed) {
        const std::vector<double> z = scenes::iso_profile(kIsoMeans[k], 1000, kDs, 100 * k + seed);
        const rp::Roughness r = rp::analyze_roughness(z, kDs, rp::RoughnessConfig{});
        ASSERT_TRUE(r.iso_class) << rp::to_string(r.reason);
        EXPECT_EQ(*r.iso_class, rp::kIsoClasses[k]) << "seed " << seed << " gd_n0 " << r.gd_n0;
        EXPECT_NEAR(std::log(r.gd_n0 / kIsoMeans[k]), 0.0, std::log(1.5)) << seed;
        EXPECT_NEAR(r.waviness, 2.0, 0.3) << seed;
        EXPECT_NEAR(r.band_lo, 0.1, 1e-12);
        EXPECT_NEAR(r.band_hi, 4.0, 1e-12);
    }
}

INSTANTIATE_TEST_SUITE_P(AtoH, IsoClassProfiles, ::testing::Range(0, 8));

TEST(Roughness, ShortStretchesAreDeclinedWithAReason) {
    std::vector<double> z(400, std::numeric_limits<double>::quiet_NaN());
    EXPECT_STREQ(rp::to_string(rp::analyze_roughness(z, kDs, {}).reason), "no valid profile");
    for (int k = 100; k < 140; ++k) z[k] = 0.01 * std::sin(k);  // 4 m < 5 m
    const rp::Roughness r = rp::analyze_roughness(z, kDs, {});
    EXPECT_FALSE(r.iso_class);
    EXPECT_STREQ(rp::to_string(r.reason), "valid stretch too short");
}

TEST(Roughness, BandIsClippedToWhatTheStretchResolves) {
    std::vector<double> z = scenes::iso_profile(256e-6, 100, kDs, 9);  // 10 m: lowest usable n = 0.2
    const rp::Roughness r = rp::analyze_roughness(z, kDs, {});
    ASSERT_TRUE(r.iso_class) << rp::to_string(r.reason);
    EXPECT_NEAR(r.band_lo, 0.2, 1e-12);
    EXPECT_NEAR(r.band_hi, 4.0, 1e-12);
}

TEST(Roughness, LongestStretchIsAnalysedAndTheFirstWinsTies) {
    const double nan = std::numeric_limits<double>::quiet_NaN();
    using Run = std::pair<std::size_t, std::size_t>;
    EXPECT_EQ(rp::longest_valid_stretch({nan, 1, 2, nan, 3, 4, 5, nan, 6, 7, 8}), Run(4, 7));
    EXPECT_EQ(rp::longest_valid_stretch({}), Run(0, 0));
}

TEST(Roughness, VehicleIsTheMeanOfBothWheels) {
    const std::vector<double> left = scenes::iso_profile(256e-6, 400, kDs, 1);
    const std::vector<double> right = scenes::iso_profile(1024e-6, 400, kDs, 2);
    const rp::Roughness v = rp::vehicle_roughness(left, right, kDs, {});
    const rp::Spectrum l = rp::displacement_psd(left.data(), 400, kDs), r = rp::displacement_psd(right.data(), 400, kDs);
    for (std::size_t k = 0; k < l.psd.size(); ++k) EXPECT_DOUBLE_EQ(v.spectrum.psd[k], 0.5 * (l.psd[k] + r.psd[k]));
    ASSERT_TRUE(v.iso_class);
}

TEST(Roughness, OctaveBandsAverageTheOrdinatesInsideThem) {
    const rp::Roughness r = rp::analyze_roughness(scenes::iso_profile(256e-6, 400, kDs, 4), kDs, {});
    ASSERT_FALSE(r.octave_centers.empty());
    for (std::size_t b = 0; b < r.octave_centers.size(); ++b) {
        const double c = r.octave_centers[b];
        double sum = 0;
        int count = 0;
        for (std::size_t k = 1; k < r.spectrum.n.size(); ++k)
            if (r.spectrum.n[k] >= c / std::sqrt(2.0) && r.spectrum.n[k] < c * std::sqrt(2.0)) sum += r.spectrum.psd[k], ++count;
        EXPECT_GT(count, 0);
        EXPECT_DOUBLE_EQ(r.octave_gd[b], sum / count);
    }
    EXPECT_DOUBLE_EQ(r.octave_centers.back(), 4.0);  // 4 cycles/m band: 2.83 … 5 (Nyquist)
}

TEST(Roughness, IsoClassRejectsValuesThatAreNoPsd) {
    EXPECT_THROW(rp::iso_class(std::numeric_limits<double>::quiet_NaN()), std::invalid_argument);
    EXPECT_THROW(rp::iso_class(-1.0), std::invalid_argument);
    EXPECT_THROW(rp::iso_class(std::numeric_limits<double>::infinity()), std::invalid_argument);
    EXPECT_EQ(rp::iso_class(0.0), 'A');
}

namespace {
rp::Roughness classified(double gd_n0, double confidence, double lo, double hi) {
    rp::Roughness r;
    r.gd_n0 = gd_n0;
    r.iso_class = rp::iso_class(gd_n0);
    r.confidence = confidence;
    r.band_lo = lo, r.band_hi = hi;
    return r;
}
}  // namespace

TEST(Roughness, VehicleClassNeverContradictsBothWheels) {
    rp::Roughness declined;
    declined.reason = rp::RoughnessReason::NoiseDominates;
    rp::Roughness vehicle = classified(300e-6, 0.7, 0.1, 2.0);  // the common stretch fitted: C
    rp::reconcile_vehicle(vehicle, declined, declined);
    EXPECT_FALSE(vehicle.iso_class);
    EXPECT_STREQ(rp::to_string(vehicle.reason), "both wheels declined");
    vehicle = classified(300e-6, 0.7, 0.1, 2.0);  // one wheel classified: the vehicle's own fit stands
    rp::reconcile_vehicle(vehicle, classified(200e-6, 0.8, 0.1, 2.0), declined);
    EXPECT_EQ(*vehicle.iso_class, 'C');
    rp::Roughness noisy = declined;  // ... and so does its decline
    rp::reconcile_vehicle(noisy, classified(200e-6, 0.8, 0.1, 2.0), declined);
    EXPECT_FALSE(noisy.iso_class);
    EXPECT_STREQ(rp::to_string(noisy.reason), "noise dominates the band");

    rp::Roughness short_common;  // both wheels classified, their common stretch too short
    short_common.reason = rp::RoughnessReason::StretchTooShort;
    rp::reconcile_vehicle(short_common, classified(200e-6, 0.8, 0.2, 2.0), classified(1000e-6, 0.6, 0.1, 4.0));
    ASSERT_TRUE(short_common.iso_class);
    EXPECT_DOUBLE_EQ(short_common.gd_n0, 600e-6);
    EXPECT_EQ(*short_common.iso_class, 'D');
    EXPECT_DOUBLE_EQ(short_common.confidence, 0.6);
    EXPECT_STREQ(rp::to_string(short_common.band_limit), "wheels");
    EXPECT_EQ(short_common.reason, rp::RoughnessReason::None);
    EXPECT_DOUBLE_EQ(short_common.band_lo, 0.1);
    EXPECT_DOUBLE_EQ(short_common.band_hi, 4.0);

    rp::Roughness fitted = classified(300e-6, 0.7, 0.1, 2.0);  // everything classified: the fit stands
    rp::reconcile_vehicle(fitted, classified(200e-6, 0.8, 0.1, 2.0), classified(500e-6, 0.8, 0.1, 2.0));
    EXPECT_DOUBLE_EQ(fitted.gd_n0, 300e-6);
}
