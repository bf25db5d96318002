// SPDX-License-Identifier: BSD-3-Clause
#include "roadpreview/roughness.hpp"

#include <cmath>
#include <complex>
#include <stdexcept>

#include <unsupported/Eigen/FFT>

namespace roadpreview {
namespace {

constexpr double kEulerGamma = 0.57721566490153286;  // bias of the log of an exponential variable
constexpr double kClassLimits[] = {32e-6, 128e-6, 512e-6, 2048e-6, 8192e-6, 32768e-6, 131072e-6};  // m³
constexpr double kBandEdgeTolerance = 1e-9;  // relative; keeps ordinates that sit on a band edge

// Removes the least-squares line over the sample index (equivalent to a line in s).
std::vector<double> detrended(const double* z, std::size_t n) {
    const double mid = 0.5 * static_cast<double>(n - 1);
    double mean = 0.0, sxx = 0.0, sxz = 0.0;
    for (std::size_t j = 0; j < n; ++j) mean += z[j];
    mean /= static_cast<double>(n);
    for (std::size_t j = 0; j < n; ++j) {
        const double dj = static_cast<double>(j) - mid;
        sxx += dj * dj;
        sxz += dj * (z[j] - mean);
    }
    const double slope = sxz / sxx;
    std::vector<double> x(n);
    for (std::size_t j = 0; j < n; ++j) x[j] = z[j] - mean - slope * (static_cast<double>(j) - mid);
    return x;
}

bool is_finite(double v) { return std::isfinite(v); }

// Longest run where pred(k) holds, first on ties.
template <typename Pred>
std::pair<std::size_t, std::size_t> longest_run(std::size_t size, Pred pred) {
    std::size_t best_first = 0, best_last = 0, first = 0;
    for (std::size_t k = 0; k <= size; ++k) {
        if (k < size && pred(k)) continue;
        if (k - first > best_last - best_first) best_first = first, best_last = k;
        first = k + 1;
    }
    return {best_first, best_last};
}

Roughness declined(std::string reason) {
    Roughness r;
    r.reason = std::move(reason);
    return r;
}

// ISO 8608 octave bands, centres 2^m cycles/m, m = −6 … 2, limits centre/√2 ≤ n < centre·√2.
void octave_bands(Roughness& r) {
    for (int m = -6; m <= 2; ++m) {
        const double centre = std::ldexp(1.0, m), lo = centre / std::sqrt(2.0), hi = centre * std::sqrt(2.0);
        double sum = 0.0;
        int count = 0;
        for (std::size_t k = 1; k < r.spectrum.n.size(); ++k) {
            if (r.spectrum.n[k] >= lo && r.spectrum.n[k] < hi) sum += r.spectrum.psd[k], ++count;
        }
        if (count == 0) continue;
        r.octave_centers.push_back(centre);
        r.octave_gd.push_back(sum / count);
    }
}

// ln G = A − w·ln(n/n0) by least squares; returns {w = 2 intercept, free intercept, free w}.
struct LogFit {
    double ln_g0_w2, ln_g0_free, waviness;
};
LogFit fit_log_line(const std::vector<double>& x, const std::vector<double>& y) {
    const double m = static_cast<double>(x.size());
    double mx = 0.0, my = 0.0, w2 = 0.0;
    for (std::size_t i = 0; i < x.size(); ++i) mx += x[i], my += y[i], w2 += y[i] + 2.0 * x[i];
    mx /= m, my /= m, w2 /= m;
    double sxx = 0.0, sxy = 0.0;
    for (std::size_t i = 0; i < x.size(); ++i) sxx += (x[i] - mx) * (x[i] - mx), sxy += (x[i] - mx) * (y[i] - my);
    const double slope = sxy / sxx;
    return {w2, my - slope * mx, -slope};
}

}  // namespace

Spectrum displacement_psd(const double* z, std::size_t count, double ds) {
    if (count < 2) throw std::invalid_argument("displacement_psd needs at least 2 samples");
    std::vector<double> x = detrended(z, count);
    const double N = static_cast<double>(count);
    double power = 0.0;  // N·U, U = mean of the squared window
    for (std::size_t j = 0; j < count; ++j) {
        const double w = 0.5 * (1.0 - std::cos(2.0 * M_PI * static_cast<double>(j) / N));  // periodic Hann
        x[j] *= w;
        power += w * w;
    }
    std::vector<std::complex<double>> X;
    Eigen::FFT<double> fft;
    fft.fwd(X, x);

    Spectrum sp;
    const std::size_t half = count / 2;
    sp.n.resize(half + 1);
    sp.psd.resize(half + 1);
    for (std::size_t k = 0; k <= half; ++k) {
        const bool unpaired = k == 0 || 2 * k == count;  // DC and Nyquist have no mirror ordinate
        sp.n[k] = static_cast<double>(k) / (N * ds);
        sp.psd[k] = (unpaired ? 1.0 : 2.0) * std::norm(X[k]) * ds / power;
    }
    return sp;
}

char iso_class(double gd_n0_m3) {
    int k = 0;
    for (double limit : kClassLimits) k += gd_n0_m3 >= limit ? 1 : 0;
    return kIsoClasses[k];
}

Roughness classify_spectrum(Spectrum spectrum, double length_m, double ds, const RoughnessConfig& cfg) {
    Roughness r;
    r.spectrum = std::move(spectrum);
    octave_bands(r);
    const double lo = std::max(cfg.band_min_cpm, cfg.min_cycles / length_m);
    const double hi = std::min(cfg.band_max_cpm, 0.5 / ds);
    std::vector<double> x, y;
    for (std::size_t k = 1; k < r.spectrum.n.size(); ++k) {
        const double n = r.spectrum.n[k];
        if (n < lo * (1.0 - kBandEdgeTolerance) || n > hi * (1.0 + kBandEdgeTolerance)) continue;
        x.push_back(std::log(n / kIsoN0));
        y.push_back(std::log(r.spectrum.psd[k]));
    }
    if (lo >= hi || static_cast<int>(x.size()) < cfg.min_band_points) {
        r.reason = "too few PSD ordinates in band";
        return r;
    }
    r.band_lo = lo, r.band_hi = hi;
    const LogFit fit = fit_log_line(x, y);
    r.gd_n0 = std::exp(fit.ln_g0_w2 + kEulerGamma);
    r.gd_n0_free = std::exp(fit.ln_g0_free + kEulerGamma);
    r.waviness = fit.waviness;
    r.iso_class = iso_class(r.gd_n0);
    return r;
}

std::pair<std::size_t, std::size_t> longest_valid_stretch(const std::vector<double>& z) {
    return longest_run(z.size(), [&](std::size_t k) { return is_finite(z[k]); });
}

namespace {
std::string stretch_problem(std::size_t samples, double ds, const RoughnessConfig& cfg) {
    if (samples == 0) return "no valid profile";
    if (static_cast<double>(samples) * ds < cfg.min_length_m - 1e-9) return "valid stretch too short";
    return {};
}
}  // namespace

Roughness analyze_roughness(const std::vector<double>& z, double ds, const RoughnessConfig& cfg) {
    const auto [first, last] = longest_valid_stretch(z);
    if (auto problem = stretch_problem(last - first, ds, cfg); !problem.empty()) return declined(problem);
    const double length = static_cast<double>(last - first) * ds;
    return classify_spectrum(displacement_psd(z.data() + first, last - first, ds), length, ds, cfg);
}

Roughness vehicle_roughness(const std::vector<double>& z_left, const std::vector<double>& z_right, double ds,
                            const RoughnessConfig& cfg) {
    if (z_left.empty() || z_right.empty()) return declined("no valid profile");
    if (z_left.size() != z_right.size()) throw std::invalid_argument("left and right profiles differ in length");
    const auto [first, last] = longest_run(
        z_left.size(), [&](std::size_t k) { return is_finite(z_left[k]) && is_finite(z_right[k]); });
    if (auto problem = stretch_problem(last - first, ds, cfg); !problem.empty()) return declined(problem);
    Spectrum mean = displacement_psd(z_left.data() + first, last - first, ds);
    const Spectrum right = displacement_psd(z_right.data() + first, last - first, ds);
    for (std::size_t k = 0; k < mean.psd.size(); ++k) mean.psd[k] = 0.5 * (mean.psd[k] + right.psd[k]);
    return classify_spectrum(std::move(mean), static_cast<double>(last - first) * ds, ds, cfg);
}

}  // namespace roadpreview
