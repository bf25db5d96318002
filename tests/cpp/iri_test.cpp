#include <gtest/gtest.h>

#include <cmath>
#include <complex>
#include <fstream>
#include <limits>
#include <numeric>
#include <random>
#include <string>
#include <vector>

#include <Eigen/Dense>
#include <roadpreview/profile/profile.hpp>
#include <roadpreview/roughness/iri.hpp>

namespace rp = roadpreview;

namespace {

constexpr double kDs = 0.1;

std::vector<double> read_column(const std::string& path, int column, int columns) {
    std::ifstream in(path);
    std::vector<double> out;
    double v;
    for (int i = 0; in >> v; ++i)
        if (i % columns == column) out.push_back(v);
    return out;
}

std::vector<double> reference_iri(const std::string& name) {
    std::ifstream in(std::string(ROADPREVIEW_TEST_DATA) + "/profiles/sroubek_iri/reference_iri_computed/" + name);
    std::string header;
    std::getline(in, header);
    std::vector<double> iri;
    double start, end, value, spread;
    while (in >> start >> end >> value >> spread) iri.push_back(value);
    return iri;
}

// |H(iω)| of the continuous golden car from input slope to (sprung − unsprung) slope.
double golden_car_response(double wavelength_m) {
    const double k1 = 653.0, k2 = 63.3, c = 6.0, mu = 0.15, v = 80.0 / 3.6;
    Eigen::Matrix4cd a;
    a << 0, 1, 0, 0, -k2, -c, k2, c, 0, 0, 0, 1, k2 / mu, c / mu, -(k1 + k2) / mu, -c / mu;
    const Eigen::Vector4cd b(0, 0, 0, k1 / mu);
    const std::complex<double> iw(0.0, 2.0 * M_PI * v / wavelength_m);
    const Eigen::Vector4cd x = (iw * Eigen::Matrix4cd::Identity() - a).partialPivLu().solve(b);
    return std::abs(x[0] - x[2]);
}

}  // namespace

TEST(Iri, FlatAndInclinedProfilesGiveZero) {
    std::vector<double> flat(500, 0.3), grade(500);
    for (std::size_t j = 0; j < grade.size(); ++j) grade[j] = 0.04 * j * kDs;
    EXPECT_NEAR(rp::iri(flat.data(), flat.size(), kDs), 0.0, 1e-12);
    EXPECT_NEAR(rp::iri(grade.data(), grade.size(), kDs), 0.0, 1e-9);
}

TEST(Iri, SineGivesTheQuarterCarResponse) {
    for (double wavelength : {2.47, 15.3}) {  // not multiples of the step: |cos| is sampled at every phase
        const double amplitude = 0.004;
        std::vector<double> z(20000);
        for (std::size_t j = 0; j < z.size(); ++j) z[j] = amplitude * std::sin(2 * M_PI * j * kDs / wavelength);
        const std::vector<double> rs = rp::iri_rectified_slope(z.data(), z.size(), kDs);
        const double steady = 1000.0 * std::accumulate(rs.begin() + 2000, rs.end(), 0.0) / (rs.size() - 2000);
        const double base = 3 * kDs, x = kDs / wavelength;
        const double slope = amplitude * 2 * std::abs(std::sin(M_PI * base / wavelength)) / base *
                             std::sin(M_PI * x) / (M_PI * x);  // 250 mm average, slope held over each step
        EXPECT_NEAR(steady / (1000.0 * 2 / M_PI * golden_car_response(wavelength) * slope), 1.0, 5e-3) << wavelength;
    }
}

TEST(Iri, RealProfileMatchesTheReferenceProgramWithinOnePercent) {
    const std::string dir = std::string(ROADPREVIEW_TEST_DATA) + "/profiles/sroubek_iri/";
    const std::vector<double> elevation = read_column(dir + "profile_1.txt", 1, 2);
    ASSERT_EQ(elevation.size(), 2177u);
    const std::vector<double> rs = rp::iri_rectified_slope(elevation.data() + 2, elevation.size() - 2, 0.25);  // from 478.5 m
    for (int segment : {20, 100}) {
        const std::vector<double> reference = reference_iri("profile_1_seg" + std::to_string(segment) + "_sayers_start478.5.txt");
        ASSERT_FALSE(reference.empty());
        const std::size_t steps = static_cast<std::size_t>(segment / 0.25);
        for (std::size_t i = 0; i < reference.size(); ++i) {
            const double ours = 1000.0 * std::accumulate(rs.begin() + i * steps, rs.begin() + (i + 1) * steps, 0.0) / steps;
            EXPECT_NEAR(ours / reference[i], 1.0, 0.01) << segment << " m segment " << i;
        }
    }
}

TEST(Iri, ProfileIriTakesTheLongestStretchOrDeclines) {
    const double nan = std::numeric_limits<double>::quiet_NaN();
    std::vector<double> z(400, nan);
    for (int k = 100; k < 200; ++k) z[k] = 0.01 * std::sin(0.3 * k);  // 9.9 m
    rp::IriConfig cfg;
    rp::Iri short_one = rp::profile_iri(z, kDs, cfg);
    EXPECT_FALSE(short_one.value);
    EXPECT_STREQ(rp::to_string(short_one.reason), "valid stretch too short for IRI");
    for (int k = 200; k < 260; ++k) z[k] = 0.01 * std::sin(0.3 * k);  // 15.9 m
    const rp::Iri iri = rp::profile_iri(z, kDs, cfg);
    ASSERT_TRUE(iri.value) << rp::to_string(iri.reason);
    EXPECT_DOUBLE_EQ(*iri.value, rp::iri(z.data() + 100, 160, kDs));
    EXPECT_NEAR(iri.length_m, 15.9, 1e-9);
    const rp::Iri mean = rp::vehicle_iri(iri, rp::profile_iri(std::vector<double>(400, 0.0), kDs, cfg));
    EXPECT_DOUBLE_EQ(*mean.value, 0.5 * *iri.value);
    EXPECT_EQ(rp::vehicle_iri(iri, short_one).reason, rp::IriReason::StretchTooShort);
}

namespace {

// A 20 m profile with points in every `backed_every`-th bin, classified or not.
rp::Profile sine_profile(int backed_every, bool classified) {
    rp::Profile p;
    p.ds = kDs;
    for (int k = 0; k < 200; ++k) {
        p.z.push_back(0.01 * std::sin(0.3 * k));
        p.count.push_back(k % backed_every == 0 ? 3 : 0);
    }
    if (classified) p.roughness.iso_class = 'C';
    else p.roughness.reason = rp::RoughnessReason::NoiseDominates;
    return p;
}

}  // namespace

TEST(Iri, WheelIriReportsItsBackingAndDeclinesWhereItCannotBeTrusted) {
    rp::IriConfig cfg;
    const rp::Profile dense = sine_profile(1, true);
    const rp::Iri trusted = rp::wheel_iri(dense, dense.roughness, cfg);
    ASSERT_TRUE(trusted.value) << rp::to_string(trusted.reason);
    EXPECT_DOUBLE_EQ(*trusted.value, rp::iri(dense.z.data(), dense.z.size(), kDs));
    EXPECT_DOUBLE_EQ(*trusted.backed_fraction, 1.0);

    const rp::Profile sparse = sine_profile(5, true);  // four bins in five interpolated
    const rp::Iri thin = rp::wheel_iri(sparse, sparse.roughness, cfg);
    EXPECT_FALSE(thin.value);
    EXPECT_STREQ(rp::to_string(thin.reason), "too few bins with points for IRI");
    EXPECT_NEAR(*thin.backed_fraction, 40.0 / 200.0, 1e-12);
    EXPECT_NEAR(thin.length_m, 19.9, 1e-9);

    const rp::Profile declined = sine_profile(1, false);
    const rp::Iri no_class = rp::wheel_iri(declined, declined.roughness, cfg);
    EXPECT_FALSE(no_class.value);
    EXPECT_STREQ(rp::to_string(no_class.reason), "roughness class declined");

    const rp::Iri mean = rp::vehicle_iri(trusted, thin);
    EXPECT_FALSE(mean.value);
    EXPECT_NEAR(*mean.backed_fraction, 0.5 * (1.0 + 40.0 / 200.0), 1e-12);
    const rp::Profile third = sine_profile(3, true);  // 67 of 200 bins backed: above the default 0.25
    EXPECT_TRUE(rp::wheel_iri(third, third.roughness, cfg).value);
}

namespace {

// 30 m of flat road whose bins hold 3 points each every `backed_every`-th bin (and the last), with that spread.
rp::Profile noisy_flat(int backed_every, double spread) {
    rp::Profile p;
    p.ds = kDs;
    const int bins = 301;
    for (int k = 0; k < bins; ++k) {
        const bool backed = k % backed_every == 0 || k == bins - 1;
        p.z.push_back(0.0);
        p.count.push_back(backed ? 3 : 0);
        p.spread.push_back(backed ? spread : std::numeric_limits<double>::quiet_NaN());
    }
    p.roughness.iso_class = 'A';
    return p;
}

// The mean IRI of `draws` profiles whose backed bins err by independent normal errors of the bins' stated
// variance (π/2·s²/3, the median of 3 points), linear between them.
double monte_carlo_iri(const rp::Profile& p, int draws) {
    std::mt19937 rng(7);
    const double sigma = std::sqrt(M_PI / 2.0 * p.spread[0] * p.spread[0] / 3.0);
    std::normal_distribution<double> error(0.0, sigma);
    double sum = 0.0;
    for (int d = 0; d < draws; ++d) {
        std::vector<double> z(p.z.size());
        std::size_t last = 0;
        for (std::size_t k = 0; k < z.size(); ++k) {
            if (p.count[k] == 0) continue;
            z[k] = error(rng);
            for (std::size_t j = last + 1; j < k; ++j)
                z[j] = z[last] + (z[k] - z[last]) * static_cast<double>(j - last) / static_cast<double>(k - last);
            last = k;
        }
        sum += rp::iri(z.data(), z.size(), kDs);
    }
    return sum / draws;
}

}  // namespace

TEST(Iri, NoiseIsTheIriOfTheBinsErrorsAlone) {
    // Known answer by Monte Carlo: every bin backed (white errors), and one bin in five (errors drawn across the
    // gaps by the interpolation, which the golden car feels more); the noise scales with the spreads.
    rp::IriConfig cfg;
    cfg.min_backed_fraction = 0.0;
    for (const int every : {1, 5}) {
        const rp::Profile p = noisy_flat(every, 0.004);
        const rp::Iri iri = rp::wheel_iri(p, p.roughness, cfg);
        ASSERT_TRUE(iri.noise) << "one bin in " << every;
        EXPECT_NEAR(*iri.noise, monte_carlo_iri(p, 400), 0.04 * *iri.noise) << "one bin in " << every;
        EXPECT_DOUBLE_EQ(*iri.value, 0.0);  // the profile itself is flat
        const rp::Profile doubled = noisy_flat(every, 0.008);
        EXPECT_NEAR(*rp::wheel_iri(doubled, doubled.roughness, cfg).noise, 2.0 * *iri.noise, 1e-9 * *iri.noise);
    }
    const rp::Profile white = noisy_flat(1, 0.004), sparse = noisy_flat(5, 0.004);
    const rp::Iri a = rp::wheel_iri(white, white.roughness, cfg), b = rp::wheel_iri(sparse, sparse.roughness, cfg);
    EXPECT_GT(*b.noise, *a.noise);  // each backed bin's error spans its gaps
    EXPECT_DOUBLE_EQ(*rp::vehicle_iri(a, b).noise, 0.5 * (*a.noise + *b.noise));
    rp::Profile unknown = white;
    unknown.spread.assign(unknown.spread.size(), std::numeric_limits<double>::quiet_NaN());
    unknown.count.assign(unknown.count.size(), 1);  // single points without a spread: no noise to pool
    EXPECT_FALSE(rp::wheel_iri(unknown, unknown.roughness, cfg).noise);
    EXPECT_FALSE(rp::vehicle_iri(a, rp::wheel_iri(unknown, unknown.roughness, cfg)).noise);
}
