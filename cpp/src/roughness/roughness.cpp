// SPDX-License-Identifier: BSD-3-Clause
#include "roadpreview/roughness/roughness.hpp"

#include <algorithm>
#include <cfloat>
#include <cmath>
#include <complex>
#include <limits>
#include <stdexcept>

#include <unsupported/Eigen/FFT>

#include "roadpreview/profile/profile.hpp"
#include "roughness/roughness_scratch.hpp"

namespace roadpreview {
namespace {

constexpr double kEulerGamma = 0.57721566490153286;  // bias of the log of an exponential variable
constexpr double kClassLimits[] = {32e-6, 128e-6, 512e-6, 2048e-6, 8192e-6, 32768e-6, 131072e-6};  // m³
constexpr double kBandEdgeTolerance = 1e-9;  // relative; keeps ordinates that sit on a band edge
constexpr int kWhittleIterations = 60;       // Fisher-scoring steps of the noise-aware fit
constexpr double kMaxWhittleStep = 1.0;      // in ln G(n0): scoring overshoots when it starts far from the optimum
// Variance of ln G_d(n0) from M ordinates of a Hann-windowed stretch is factor/M. Neighbouring ordinates are
// correlated (DFT coefficients −2/3 at lag 1, 1/6 at lag 2, so periodogram ordinates 4/9 and 1/36):
// log regression: (π²/6)·(1 + 2·[Li₂(4/9) + Li₂(1/36)]/ζ(2)); likelihood fit: 1 + 2·(4/9 + 1/36).
constexpr double kLogFitVariance = M_PI * M_PI / 6.0 * 1.6504918528873;
constexpr double kWhittleVariance = 1.0 + 2.0 * (4.0 / 9.0 + 1.0 / 36.0);
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// Removes the least-squares line over the sample index (equivalent to a line in s).
void detrend(const double* z, std::size_t n, std::vector<double>& x) {
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
    x.resize(n);
    for (std::size_t j = 0; j < n; ++j) x[j] = z[j] - mean - slope * (static_cast<double>(j) - mid);
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

// ISO 8608 octave bands, centres 2^m cycles/m, m = −6 … 2, limits centre/√2 ≤ n < centre·√2.
void octave_bands(Roughness& r) {
    r.octave_centers.clear();
    r.octave_gd.clear();
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

void displacement_psd(const double* z, std::size_t count, double ds, RoughnessScratch& s, Spectrum& sp) {
    if (count < 2) throw std::invalid_argument("displacement_psd needs at least 2 samples");
    check_spacing(ds, "displacement_psd");
    std::vector<double>& x = s.detrended;
    detrend(z, count, x);
    const double N = static_cast<double>(count);
    double power = 0.0;  // N·U, U = mean of the squared window
    for (std::size_t j = 0; j < count; ++j) {
        const double w = 0.5 * (1.0 - std::cos(2.0 * M_PI * static_cast<double>(j) / N));  // periodic Hann
        x[j] *= w;
        power += w * w;
    }
    std::vector<std::complex<double>>& X = s.transform;
    if (count <= RoughnessScratch::kPlannedLength) {
        s.fft.fwd(X, x);
    } else {  // a plan this long is made for this transform only: kept, every length would cost O(length²) in all
        s.unplanned.fwd(X, x);
        s.unplanned.impl().clear();
    }

    const std::size_t half = count / 2;
    sp.n.resize(half + 1);
    sp.psd.resize(half + 1);
    for (std::size_t k = 0; k <= half; ++k) {
        const bool unpaired = k == 0 || 2 * k == count;  // DC and Nyquist have no mirror ordinate
        sp.n[k] = static_cast<double>(k) / (N * ds);
        sp.psd[k] = (unpaired ? 1.0 : 2.0) * std::norm(X[k]) * ds / power;
    }
}

void RoughnessScratch::plan_ffts(std::size_t bins) {
    const std::size_t ordinates = bins / 2 + 1;
    for (auto* v : {&x, &y, &shape, &floor, &share, &corrected, &iri_noise}) v->reserve(ordinates);
    used.reserve(ordinates);
    strong.reserve(ordinates);
    for (auto* v : {&variance, &lag_sum, &window, &pooled, &cosine, &support.noise, &support.resolved, &other.noise,
                    &other.resolved})
        v->reserve(bins);
    pool.reserve(1, bins);
    anchors.reserve(bins);
    interval.reserve(bins);
    power_by_interval.reserve(bins);
    detrended.reserve(bins);
    transform.reserve(bins);
    for (std::size_t n = 2; n <= std::min(bins, kPlannedLength); ++n) fft.impl().plan_real_forward(static_cast<int>(n));
}

Spectrum displacement_psd(const double* z, std::size_t count, double ds) {
    RoughnessScratch scratch;
    Spectrum sp;
    displacement_psd(z, count, ds, scratch, sp);
    return sp;
}

char iso_class(double gd_n0_m3) {
    if (!std::isfinite(gd_n0_m3) || gd_n0_m3 < 0.0)
        throw std::invalid_argument("iso_class: G_d(n0) must be finite and >= 0 m³, got " + std::to_string(gd_n0_m3));
    int k = 0;
    for (double limit : kClassLimits) k += gd_n0_m3 >= limit ? 1 : 0;
    return kIsoClasses[k];
}

const char* to_string(RoughnessReason reason) noexcept {
    switch (reason) {
        case RoughnessReason::None: return "";
        case RoughnessReason::NoValidProfile: return "no valid profile";
        case RoughnessReason::StretchTooShort: return "valid stretch too short";
        case RoughnessReason::TooFewOrdinates: return "too few PSD ordinates in band";
        case RoughnessReason::NoiseUnknown: return "noise floor unknown";
        case RoughnessReason::NoiseDominates: return "noise dominates the band";
        case RoughnessReason::FitFailed: return "fit failed (G_d(n0) not finite)";
        case RoughnessReason::BothWheelsDeclined: return "both wheels declined";
        case RoughnessReason::NoFinitePoints: return "no finite points";
        case RoughnessReason::NoRoiPoints: return "no points in the region of interest";
        case RoughnessReason::NoGround: return "no ground";
        case RoughnessReason::TiltedGround: return kTiltedGround;
        case RoughnessReason::VehicleStopped: return "vehicle stopped";
    }
    return "?";
}

const char* to_string(BandLimit limit) noexcept {
    switch (limit) {
        case BandLimit::None: return "";
        case BandLimit::Requested: return "requested";
        case BandLimit::Nyquist: return "nyquist";
        case BandLimit::Sampling: return "sampling";
        case BandLimit::Noise: return "noise";
        case BandLimit::Wheels: return "wheels";
    }
    return "?";
}

namespace {

using Indices = std::vector<std::size_t>;

struct Fit {
    double gd_n0 = 0.0;
    double log_variance = 0.0;  // of ln gd_n0
    double waviness = kNaN, gd_n0_free = kNaN;
    RoughnessReason reason = RoughnessReason::None;  // why there is no fit
    bool noise_bound = false;  // the noise dominates: gd_n0 is the upper bound of the fit without noise
};

// The w = 2 log fit and the free-w fit of ln y over the ordinates; x = ln(n/n0).
LogFit log_fit_over(const Spectrum& sp, const Indices& used, RoughnessScratch& s,
                    const std::vector<double>* log_y = nullptr) {
    s.x.clear();
    s.y.clear();
    for (std::size_t i = 0; i < used.size(); ++i) {
        s.x.push_back(std::log(sp.n[used[i]] / kIsoN0));
        s.y.push_back(log_y ? (*log_y)[i] : std::log(sp.psd[used[i]]));
    }
    return fit_log_line(s.x, s.y);
}

Fit log_fit(const Spectrum& sp, const Indices& used, RoughnessScratch& s) {
    const LogFit f = log_fit_over(sp, used, s);
    return {std::exp(f.ln_g0_w2 + kEulerGamma), kLogFitVariance / static_cast<double>(used.size()), f.waviness,
            std::exp(f.ln_g0_free + kEulerGamma), RoughnessReason::None, false};
}

// Maximum of the Whittle likelihood of exponential ordinates with E[G_k] = S_k + N_k, S_k = Φ_k·G(n0)(n_k/n0)^−2:
// Fisher scoring in θ = ln G(n0) from the log-regression estimate, θ ← θ + Σw(G/E − 1)/Σw², w_k = S_k/E[G_k],
// each step at most ±1.
// Returns G(n0); s.share gets w_k at the optimum.
double whittle_fit(const Spectrum& sp, const Indices& used, const std::vector<double>& resolved,
                   const std::vector<double>* noise, RoughnessScratch& s) {
    const std::size_t m = used.size();
    s.shape.resize(m);
    s.floor.assign(m, 0.0);
    for (std::size_t i = 0; i < m; ++i) {
        s.shape[i] = resolved[used[i]] * std::pow(sp.n[used[i]] / kIsoN0, -2.0);
        if (noise) s.floor[i] = (*noise)[used[i]];
    }
    double theta = std::log(std::max(std::exp(log_fit_over(sp, used, s).ln_g0_w2 + kEulerGamma), DBL_MIN));
    s.share.assign(m, 0.0);
    for (int it = 0; it < kWhittleIterations; ++it) {
        double information = 0.0, score = 0.0;
        for (std::size_t i = 0; i < m; ++i) {
            const double expected = std::exp(theta) * s.shape[i] + s.floor[i];
            const double w = expected > 0.0 ? std::exp(theta) * s.shape[i] / expected : 0.0;  // flat and noiseless: 0
            information += w * w;
            if (w > 0.0) score += w * (sp.psd[used[i]] / expected - 1.0);
        }
        if (information < 1e-12) break;  // the signal has vanished below the noise
        theta += std::clamp(score / information, -kMaxWhittleStep, kMaxWhittleStep);
    }
    for (std::size_t i = 0; i < m; ++i) {
        const double signal = std::exp(theta) * s.shape[i];
        s.share[i] = signal + s.floor[i] > 0.0 ? signal / (signal + s.floor[i]) : 0.0;
    }
    return std::exp(theta);
}

// docs/noise-aware-roughness.md §4–5: the likelihood fit with the noise PSD while its effective number of
// signal-dominated ordinates Σw² reaches min_band_points, the free fit on the noise-corrected logs of the
// ordinates the signal dominates; else the fit without noise bounds the road from above: class A or nothing.
Fit noise_aware_fit(const Spectrum& sp, const Indices& used, const SupportBuffers& support,
                    const RoughnessConfig& cfg, RoughnessScratch& s) {
    Fit fit;
    if (!support.noise_known) {
        fit.reason = RoughnessReason::NoiseUnknown;
        return fit;
    }
    const double gd = whittle_fit(sp, used, support.resolved, &support.noise, s);
    double effective = 0.0;
    for (double w : s.share) effective += w * w;
    if (effective >= cfg.min_band_points) {
        fit.gd_n0 = gd, fit.log_variance = kWhittleVariance / effective;
        s.strong.clear();
        s.corrected.clear();
        for (std::size_t i = 0; i < used.size(); ++i) {
            if (s.share[i] < 0.5) continue;
            s.strong.push_back(used[i]);
            s.corrected.push_back(std::log(sp.psd[used[i]]) - std::log(support.resolved[used[i]] / s.share[i]));
        }
        if (s.strong.size() >= 2) {
            const LogFit f = log_fit_over(sp, s.strong, s, &s.corrected);
            fit.waviness = f.waviness, fit.gd_n0_free = std::exp(f.ln_g0_free + kEulerGamma);
        }
        return fit;
    }
    fit.noise_bound = true;
    fit.gd_n0 = whittle_fit(sp, used, support.resolved, nullptr, s);
    if (!std::isfinite(fit.gd_n0) || iso_class(fit.gd_n0) != 'A') {
        fit.reason = RoughnessReason::NoiseDominates;
        return fit;
    }
    const LogFit f = log_fit_over(sp, used, s);
    fit.log_variance = kWhittleVariance / static_cast<double>(used.size());
    fit.waviness = f.waviness, fit.gd_n0_free = std::exp(f.ln_g0_free + kEulerGamma);
    return fit;
}

// Steps 6–9 of §4 on r.spectrum (already there), into r.
void classify(Roughness& r, double length_m, double ds, const RoughnessConfig& cfg, const SupportBuffers* support,
              RoughnessScratch& s) {
    const Spectrum& sp = r.spectrum;
    octave_bands(r);
    const double lo = std::max(cfg.band_min_cpm, cfg.min_cycles / length_m);
    const double nyquist = 0.5 / ds;
    double hi = std::min(cfg.band_max_cpm, nyquist);
    r.band_limit = cfg.band_max_cpm <= nyquist ? BandLimit::Requested : BandLimit::Nyquist;
    Indices& used = s.used;
    used.clear();
    for (std::size_t k = 1; k < sp.n.size(); ++k)
        if (sp.n[k] >= lo * (1.0 - kBandEdgeTolerance) && sp.n[k] <= hi * (1.0 + kBandEdgeTolerance)) used.push_back(k);
    if (support) r.backed_fraction = support->backed_fraction;
    const bool noise_aware = support && cfg.noise_aware;
    std::size_t keep = used.size();  // up to the first ordinate the sampling no longer resolves
    if (noise_aware) {
        keep = 0;
        while (keep < used.size() && support->resolved[used[keep]] >= cfg.min_resolved_fraction) ++keep;
    }
    if (support && support->noise_known) {  // over the band the fit uses; the requested one when none is left
        r.noise_psd.assign(support->noise.begin(), support->noise.end());
        const std::size_t over = keep > 0 ? keep : used.size();
        double sum = 0.0;
        for (std::size_t j = 0; j < over; ++j) sum += r.noise_psd[used[j]];
        if (over > 0) r.noise_floor = sum / static_cast<double>(over);
    }
    if (keep < used.size()) {
        hi = keep > 0 ? sp.n[used[keep - 1]] : lo;
        used.resize(keep);
        r.band_limit = BandLimit::Sampling;
    }
    if (lo >= hi || static_cast<int>(used.size()) < cfg.min_band_points) {
        r.reason = RoughnessReason::TooFewOrdinates;
        return;
    }
    const Fit fit = noise_aware ? noise_aware_fit(sp, used, *support, cfg, s) : log_fit(sp, used, s);
    if (fit.noise_bound) r.band_limit = BandLimit::Noise;
    if (fit.reason != RoughnessReason::None || !std::isfinite(fit.gd_n0)) {
        r.reason = fit.reason != RoughnessReason::None ? fit.reason : RoughnessReason::FitFailed;
        return;
    }
    r.band_lo = lo, r.band_hi = hi;
    r.gd_n0 = fit.gd_n0;
    r.gd_n0_free = fit.gd_n0_free;
    r.waviness = fit.waviness;
    r.iso_class = iso_class(r.gd_n0);
    r.confidence = class_confidence(r.gd_n0, fit.log_variance);
}

SupportBuffers buffers_of(const StretchSupport& support) {
    SupportBuffers b;
    b.noise_known = support.noise.has_value();
    if (support.noise) b.noise = *support.noise;
    b.resolved = support.resolved;
    b.backed_fraction = support.backed_fraction;
    return b;
}

}  // namespace

void clear(Iri& iri) {
    iri.value.reset();
    iri.length_m = 0.0;
    iri.reason = IriReason::None;
    iri.backed_fraction.reset();
    iri.noise.reset();
}

void clear(Roughness& r) {
    r.iso_class.reset();
    r.gd_n0 = r.gd_n0_free = r.waviness = 0.0;
    r.band_lo = r.band_hi = 0.0;
    r.spectrum.n.clear();
    r.spectrum.psd.clear();
    r.octave_centers.clear();
    r.octave_gd.clear();
    r.reason = RoughnessReason::None;
    r.confidence = 0.0;
    r.noise_psd.clear();
    r.noise_floor.reset();
    r.backed_fraction.reset();
    r.band_limit = BandLimit::None;
    clear(r.iri);
}

double class_confidence(double gd_n0_m3, double log_variance) {
    if (gd_n0_m3 <= 0.0) return 1.0;
    const int k = static_cast<int>(std::string(kIsoClasses).find(iso_class(gd_n0_m3)));
    const double sigma = std::sqrt(log_variance);
    const auto below = [&](double limit) {  // P(true value < limit)
        return 0.5 * std::erfc((std::log(gd_n0_m3) - std::log(limit)) / (sigma * std::sqrt(2.0)));
    };
    const double upper = k < 7 ? below(kClassLimits[k]) : 1.0;
    const double lower = k > 0 ? below(kClassLimits[k - 1]) : 0.0;
    return upper - lower;
}

Roughness classify_spectrum(Spectrum spectrum, double length_m, double ds, const RoughnessConfig& cfg,
                            const StretchSupport* support) {
    RoughnessScratch scratch;
    Roughness r;
    r.spectrum = std::move(spectrum);
    const SupportBuffers buffers = support ? buffers_of(*support) : SupportBuffers{};
    classify(r, length_m, ds, cfg, support ? &buffers : nullptr, scratch);
    return r;
}

void reconcile_vehicle(Roughness& vehicle, const Roughness& left, const Roughness& right) {
    if (!left.iso_class && !right.iso_class) {
        vehicle.iso_class.reset();
        vehicle.band_lo = vehicle.band_hi = 0.0;
        vehicle.reason = RoughnessReason::BothWheelsDeclined;
        return;
    }
    if (vehicle.iso_class || !left.iso_class || !right.iso_class) return;  // one wheel alone: the fit decides
    vehicle.gd_n0 = 0.5 * (left.gd_n0 + right.gd_n0);
    vehicle.gd_n0_free = vehicle.waviness = kNaN;
    vehicle.iso_class = iso_class(vehicle.gd_n0);
    vehicle.confidence = std::min(left.confidence, right.confidence);
    vehicle.band_lo = std::min(left.band_lo, right.band_lo);
    vehicle.band_hi = std::max(left.band_hi, right.band_hi);
    vehicle.band_limit = BandLimit::Wheels;
    vehicle.reason = RoughnessReason::None;
}

std::pair<std::size_t, std::size_t> longest_valid_stretch(const std::vector<double>& z) {
    return longest_run(z.size(), [&](std::size_t k) { return is_finite(z[k]); });
}

namespace {
RoughnessReason stretch_problem(std::size_t samples, double ds, const RoughnessConfig& cfg) {
    if (samples == 0) return RoughnessReason::NoValidProfile;  // an empty profile may have no spacing
    check_spacing(ds, "roughness");
    // One bin has no spectrum, however long it is (a ds_m as long as min_length_m)
    if (samples < 2 || static_cast<double>(samples) * ds < cfg.min_length_m - 1e-9)
        return RoughnessReason::StretchTooShort;
    return RoughnessReason::None;
}

void require_support(const Profile& p) {
    if (p.count.size() != p.z.size() || p.spread.size() != p.z.size())
        throw std::invalid_argument("profile count and spread must have one entry per bin");
}

// Longest run of bins valid in both profiles, first on ties.
std::pair<std::size_t, std::size_t> common_stretch(const std::vector<double>& z_left, const std::vector<double>& z_right) {
    if (z_left.size() != z_right.size()) throw std::invalid_argument("left and right profiles differ in length");
    return longest_run(z_left.size(), [&](std::size_t k) { return is_finite(z_left[k]) && is_finite(z_right[k]); });
}

// The mean of both wheels' PSDs over bins [first, last), into `mean`.
void mean_spectrum(const std::vector<double>& z_left, const std::vector<double>& z_right, std::size_t first,
                   std::size_t last, double ds, RoughnessScratch& s, Spectrum& mean) {
    displacement_psd(z_left.data() + first, last - first, ds, s, mean);
    displacement_psd(z_right.data() + first, last - first, ds, s, s.right);
    for (std::size_t k = 0; k < mean.psd.size(); ++k) mean.psd[k] = 0.5 * (mean.psd[k] + s.right.psd[k]);
}

// The support of both wheels over bins [first, last): noise and resolved fraction averaged, into s.support.
void mean_support(const Profile& left, const Profile& right, std::size_t first, std::size_t last,
                  const std::vector<double>& n, RoughnessScratch& s) {
    SupportBuffers& support = s.support;
    const SupportBuffers& other = s.other;
    stretch_support(left.count, left.spread, first, last, left.ds, n, s, s.support);
    stretch_support(right.count, right.spread, first, last, right.ds, n, s, s.other);
    support.noise_known = support.noise_known && other.noise_known;
    if (support.noise_known)
        for (std::size_t k = 0; k < support.noise.size(); ++k) support.noise[k] = 0.5 * (support.noise[k] + other.noise[k]);
    for (std::size_t k = 0; k < support.resolved.size(); ++k) support.resolved[k] = 0.5 * (support.resolved[k] + other.resolved[k]);
    support.backed_fraction = 0.5 * (support.backed_fraction + other.backed_fraction);
}
}  // namespace

Roughness analyze_roughness(const std::vector<double>& z, double ds, const RoughnessConfig& cfg) {
    Roughness r;
    const auto [first, last] = longest_valid_stretch(z);
    if (const RoughnessReason problem = stretch_problem(last - first, ds, cfg); problem != RoughnessReason::None) {
        r.reason = problem;
        return r;
    }
    RoughnessScratch s;
    displacement_psd(z.data() + first, last - first, ds, s, r.spectrum);
    classify(r, static_cast<double>(last - first) * ds, ds, cfg, nullptr, s);
    return r;
}

void analyze_roughness(const Profile& p, const RoughnessConfig& cfg, RoughnessScratch& s, Roughness& r) {
    require_support(p);
    clear(r);
    const auto [first, last] = longest_valid_stretch(p.z);
    if (const RoughnessReason problem = stretch_problem(last - first, p.ds, cfg); problem != RoughnessReason::None) {
        r.reason = problem;
        return;
    }
    displacement_psd(p.z.data() + first, last - first, p.ds, s, r.spectrum);
    stretch_support(p.count, p.spread, first, last, p.ds, r.spectrum.n, s, s.support);
    classify(r, static_cast<double>(last - first) * p.ds, p.ds, cfg, &s.support, s);
}

Roughness analyze_roughness(const Profile& p, const RoughnessConfig& cfg) {
    RoughnessScratch s;
    Roughness r;
    analyze_roughness(p, cfg, s, r);
    return r;
}

Roughness vehicle_roughness(const std::vector<double>& z_left, const std::vector<double>& z_right, double ds,
                            const RoughnessConfig& cfg) {
    Roughness r;
    const auto [first, last] = z_left.empty() || z_right.empty() ? std::pair<std::size_t, std::size_t>{0, 0}
                                                                  : common_stretch(z_left, z_right);
    if (const RoughnessReason problem = stretch_problem(last - first, ds, cfg); problem != RoughnessReason::None) {
        r.reason = problem;
        return r;
    }
    RoughnessScratch s;
    mean_spectrum(z_left, z_right, first, last, ds, s, r.spectrum);
    classify(r, static_cast<double>(last - first) * ds, ds, cfg, nullptr, s);
    return r;
}

void vehicle_roughness(const Profile& left, const Profile& right, const RoughnessConfig& cfg, RoughnessScratch& s,
                       Roughness& r) {
    clear(r);
    if (left.z.empty() || right.z.empty()) {
        r.reason = RoughnessReason::NoValidProfile;
        return;
    }
    require_support(left);
    require_support(right);
    const auto [first, last] = common_stretch(left.z, right.z);
    if (const RoughnessReason problem = stretch_problem(last - first, left.ds, cfg); problem != RoughnessReason::None) {
        r.reason = problem;
        return;
    }
    mean_spectrum(left.z, right.z, first, last, left.ds, s, r.spectrum);
    mean_support(left, right, first, last, r.spectrum.n, s);
    classify(r, static_cast<double>(last - first) * left.ds, left.ds, cfg, &s.support, s);
}

Roughness vehicle_roughness(const Profile& left, const Profile& right, const RoughnessConfig& cfg) {
    RoughnessScratch s;
    Roughness r;
    vehicle_roughness(left, right, cfg, s, r);
    return r;
}

}  // namespace roadpreview
