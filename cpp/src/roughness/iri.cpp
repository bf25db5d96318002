// SPDX-License-Identifier: BSD-3-Clause
#include "roadpreview/roughness/iri.hpp"

#include <algorithm>
#include <cmath>
#include <complex>
#include <optional>
#include <stdexcept>

#include <Eigen/Dense>
#include <unsupported/Eigen/MatrixFunctions>

#include "roadpreview/profile/profile.hpp"
#include "roadpreview/roughness/roughness.hpp"
#include "roughness/roughness_scratch.hpp"

namespace roadpreview {
namespace {

// Golden car per unit sprung mass (ASTM E1926): tyre and suspension stiffness (1/s²), damping (1/s), mass ratio.
constexpr double kK1 = 653.0, kK2 = 63.3, kC = 6.0, kMu = 0.15;
constexpr double kSpeedMps = 80.0 / 3.6;
constexpr double kBaseLengthM = 0.25;  // the moving average that stands in for the tyre's envelope
constexpr double kInitLengthM = 11.0;  // the initial state takes the profile's mean slope over this length

using Matrix4 = Eigen::Matrix4d;
using Vector4 = Eigen::Vector4d;

// Exact discrete step over ds for a slope held constant over it: ST = exp(A·dt), PR = A⁻¹(ST − I)·B.
void transition(double ds, Matrix4& st, Vector4& pr) {
    Matrix4 a;
    a << 0.0, 1.0, 0.0, 0.0,
         -kK2, -kC, kK2, kC,
         0.0, 0.0, 0.0, 1.0,
         kK2 / kMu, kC / kMu, -(kK1 + kK2) / kMu, -kC / kMu;
    const Vector4 b(0.0, 0.0, 0.0, kK1 / kMu);
    st = (a * (ds / kSpeedMps)).exp();
    pr = a.partialPivLu().solve((st - Matrix4::Identity()) * b);
}

std::size_t moving_average_samples(double ds) {
    return std::max<std::size_t>(1, static_cast<std::size_t>(std::floor(kBaseLengthM / ds + 0.5 + 1e-9)));
}

// |H(n)|²: the power gain of the IRI filter from the profile to the sprung − unsprung slope at n cycles/m — the
// k-sample average's slope, (z^k − 1)/(kΔ), then the car's steps, C·(zI − ST)⁻¹·PR, with z = e^(2πinΔ).
double iri_gain(double n, double ds, std::size_t k, const Matrix4& st, const Vector4& pr) {
    using Complex = std::complex<double>;
    const Complex z = std::polar(1.0, 2.0 * M_PI * n * ds);
    const Eigen::Matrix4cd system = z * Eigen::Matrix4cd::Identity() - st.cast<Complex>();
    const Eigen::Vector4cd state = system.partialPivLu().solve(pr.cast<Complex>());
    const double slope = 2.0 * std::sin(M_PI * n * static_cast<double>(k) * ds) / (static_cast<double>(k) * ds);
    return std::norm(state[0] - state[2]) * slope * slope;
}

// iri_noise with the scratch's buffers: √(2/π) × the errors' filtered RMS, from their unwindowed noise PSD
// weighted by the filter's gain.
std::optional<double> iri_noise(const std::int32_t* count, const double* spread, std::size_t bins, double ds,
                                RoughnessScratch& s) {
    if (!noise_psd(count, spread, bins, ds, false, s, s.iri_noise)) return std::nullopt;
    Matrix4 st;
    Vector4 pr;
    transition(ds, st, pr);
    const std::size_t k = moving_average_samples(ds);
    const double dn = 1.0 / (static_cast<double>(bins) * ds);
    double variance = 0.0;
    for (std::size_t j = 1; j < s.iri_noise.size(); ++j)
        variance += s.iri_noise[j] * iri_gain(static_cast<double>(j) * dn, ds, k, st, pr) * dn;
    return 1000.0 * std::sqrt(2.0 / M_PI * variance);
}

}  // namespace

namespace {

// Calls visit(|sprung − unsprung slope|) after each step of the moving average (see iri_rectified_slope); false
// when the profile is no longer than the average.
template <class Visit>
bool rectified_slopes(const double* z, std::size_t count, double ds, Visit&& visit) {
    check_spacing(ds, "iri");
    const std::size_t k = moving_average_samples(ds);
    if (count <= k) return false;
    const auto a = std::min(static_cast<std::size_t>(std::lround(kInitLengthM / ds)), count - 1);
    const double initial = (z[a] - z[0]) / (static_cast<double>(a) * ds);
    Vector4 state(initial, 0.0, initial, 0.0);
    Matrix4 st;
    Vector4 pr;
    transition(ds, st, pr);
    for (std::size_t i = 0; i + k < count; ++i) {
        const double slope = (z[i + k] - z[i]) / (static_cast<double>(k) * ds);  // of the k-sample average
        state = st * state + pr * slope;
        visit(std::abs(state[0] - state[2]));
    }
    return true;
}

// profile_iri into `out`.
void profile_iri(const std::vector<double>& z, double ds, const IriConfig& cfg, Iri& out) {
    clear(out);
    const auto [first, last] = longest_valid_stretch(z);
    if (last == first) {  // an empty profile may have no spacing
        out.reason = IriReason::NoValidProfile;
        return;
    }
    check_spacing(ds, "profile_iri");
    out.length_m = static_cast<double>(last - first - 1) * ds;
    if (out.length_m < cfg.min_length_m - 1e-9 || last - first <= moving_average_samples(ds)) {
        out.reason = IriReason::StretchTooShort;
        return;
    }
    out.value = iri(z.data() + first, last - first, ds);
}

}  // namespace

const char* to_string(IriReason reason) noexcept {
    switch (reason) {
        case IriReason::None: return "";
        case IriReason::NoValidProfile: return "no valid profile";
        case IriReason::StretchTooShort: return "valid stretch too short for IRI";
        case IriReason::TooSparse: return "too few bins with points for IRI";
        case IriReason::ClassDeclined: return "roughness class declined";
        case IriReason::SegmentNotCovered: return "segment not covered by one valid stretch";
        // The frame's status: one text, the roughness reason's.
        case IriReason::NoFinitePoints: return to_string(RoughnessReason::NoFinitePoints);
        case IriReason::NoRoiPoints: return to_string(RoughnessReason::NoRoiPoints);
        case IriReason::NoGround: return to_string(RoughnessReason::NoGround);
        case IriReason::TiltedGround: return to_string(RoughnessReason::TiltedGround);
        case IriReason::VehicleStopped: return to_string(RoughnessReason::VehicleStopped);
    }
    return "?";
}

std::vector<double> iri_rectified_slope(const double* z, std::size_t count, double ds) {
    std::vector<double> out;
    rectified_slopes(z, count, ds, [&](double v) { out.push_back(v); });
    return out;
}

double iri(const double* z, std::size_t count, double ds) {
    double sum = 0.0;
    std::size_t steps = 0;
    if (!rectified_slopes(z, count, ds, [&](double v) { sum += v, ++steps; }))
        throw std::invalid_argument("iri: the profile is shorter than the moving average");
    return 1000.0 * sum / static_cast<double>(steps);
}

std::optional<double> iri_noise(const std::int32_t* count, const double* spread, std::size_t bins, double ds) {
    check_spacing(ds, "iri_noise");
    RoughnessScratch s;
    return iri_noise(count, spread, bins, ds, s);
}

Iri profile_iri(const std::vector<double>& z, double ds, const IriConfig& cfg) {
    Iri out;
    profile_iri(z, ds, cfg, out);
    return out;
}

void wheel_iri(const Profile& p, const Roughness& wheel, const IriConfig& cfg, RoughnessScratch& s, Iri& out) {
    profile_iri(p.z, p.ds, cfg, out);
    const auto [first, last] = longest_valid_stretch(p.z);
    if (last > first && p.count.size() == p.z.size()) {
        const auto begin = p.count.begin();
        const auto backed = std::count_if(begin + static_cast<std::ptrdiff_t>(first),
                                          begin + static_cast<std::ptrdiff_t>(last), [](auto c) { return c > 0; });
        out.backed_fraction = static_cast<double>(backed) / static_cast<double>(last - first);
    }
    if (out.reason == IriReason::None && p.count.size() == p.z.size() && p.spread.size() == p.z.size())
        out.noise = iri_noise(p.count.data() + first, p.spread.data() + first, last - first, p.ds, s);
    if (!out.value) return;
    if (out.backed_fraction && *out.backed_fraction < cfg.min_backed_fraction - 1e-12) out.reason = IriReason::TooSparse;
    else if (!wheel.iso_class) out.reason = IriReason::ClassDeclined;
    if (out.reason != IriReason::None) out.value.reset();
}

Iri wheel_iri(const Profile& p, const Roughness& wheel, const IriConfig& cfg) {
    Iri out;
    RoughnessScratch s;
    wheel_iri(p, wheel, cfg, s, out);
    return out;
}

void vehicle_iri(const Iri& left, const Iri& right, Iri& out) {
    clear(out);
    if (left.backed_fraction && right.backed_fraction)
        out.backed_fraction = 0.5 * (*left.backed_fraction + *right.backed_fraction);
    if (left.noise && right.noise) out.noise = 0.5 * (*left.noise + *right.noise);
    if (!left.value || !right.value) {
        out.reason = left.reason != IriReason::None ? left.reason : right.reason;
        return;
    }
    out.value = 0.5 * (*left.value + *right.value);
    out.length_m = std::min(left.length_m, right.length_m);
}

Iri vehicle_iri(const Iri& left, const Iri& right) {
    Iri out;
    vehicle_iri(left, right, out);
    return out;
}

}  // namespace roadpreview
