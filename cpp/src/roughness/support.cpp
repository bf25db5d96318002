// SPDX-License-Identifier: BSD-3-Clause
#include "roadpreview/roughness/support.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <utility>

#include "core/median.hpp"
#include "roughness/roughness_scratch.hpp"

namespace roadpreview {
namespace {

constexpr double kMedianVarianceFactor = M_PI / 2;  // Var(median of n Gaussians) ≈ (π/2)σ²/n
constexpr double kNyquistTolerance = 1e-9;  // relative: a frequency on an interval's Nyquist frequency is resolved

double hann(std::size_t j, std::size_t n) {
    return 0.5 * (1.0 - std::cos(2.0 * M_PI * static_cast<double>(j) / static_cast<double>(n)));
}

void interpolation_anchors(const std::int32_t* count, std::size_t bins, std::vector<Anchors>& out) {
    out.assign(bins, Anchors{{0, 0}, {0.0, 0.0}});
    std::size_t previous = bins;  // none yet
    for (std::size_t j = 0; j < bins; ++j) {
        if (count[j] <= 0) continue;
        out[j] = Anchors{{j, j}, {1.0, 0.0}};
        if (previous != bins) {
            for (std::size_t i = previous + 1; i < j; ++i) {
                const double f = static_cast<double>(i - previous) / static_cast<double>(j - previous);
                out[i] = Anchors{{previous, j}, {1.0 - f, f}};
            }
        }
        previous = j;
    }
}

double shared_covariance(const Anchors& a, const Anchors& b, const std::vector<double>& variance) {
    double c = 0.0;
    for (int i = 0; i < 2; ++i)
        for (int k = 0; k < 2; ++k)
            if (a.weight[i] != 0.0 && b.weight[k] != 0.0 && a.bin[i] == b.bin[k])
                c += a.weight[i] * b.weight[k] * variance[a.bin[i]];
    return c;
}

double sinc(double x) { return x == 0.0 ? 1.0 : std::sin(M_PI * x) / (M_PI * x); }

// cos(2π m / n) for m = 0 … n − 1, kept in the scratch for the next call of the same length (both wheels, and the
// windowed and the unwindowed noise of each, share it).
const std::vector<double>& unit_circle(std::size_t n, RoughnessScratch& s) {
    if (s.cosine.size() == n) return s.cosine;
    s.cosine.resize(n);
    for (std::size_t m = 0; m < n; ++m) {
        const double turns = static_cast<double>(m) / static_cast<double>(n);
        s.cosine[m] = std::cos(2.0 * M_PI * turns);
    }
    return s.cosine;
}

}  // namespace

// noise_psd into `psd` (with the Hann window, or none); false when the bins' noise is unknown.
bool noise_psd(const std::int32_t* count, const double* spread, std::size_t bins, double ds, bool windowed,
               RoughnessScratch& s, std::vector<double>& psd) {
    if (!backed_variances(count, spread, bins, s, s.variance)) return false;
    interpolation_anchors(count, bins, s.anchors);
    const auto& anchors = s.anchors;
    // Windowed error covariance summed by lag, R(L) = Σ_j w_j w_{j+L} C(j, j+L). Bins share an error only when
    // they share a backed bin, so R vanishes beyond a few gaps and E|X_k|² = R(0) + 2 Σ_L R(L) cos(2πLk/N).
    s.lag_sum.assign(bins, 0.0);
    s.window.resize(bins);
    double window_power = 0.0;
    for (std::size_t j = 0; j < bins; ++j) {
        s.window[j] = windowed ? hann(j, bins) : 1.0;
        window_power += s.window[j] * s.window[j];
    }
    std::size_t max_lag = 0;
    for (std::size_t j = 0; j < bins; ++j) {
        const std::size_t reach = anchors[j].weight[1] != 0.0 ? anchors[j].bin[1] : anchors[j].bin[0];
        for (std::size_t i = j; i < bins && anchors[i].bin[0] <= reach; ++i) {
            const double c = shared_covariance(anchors[j], anchors[i], s.variance);
            if (c == 0.0) continue;
            s.lag_sum[i - j] += s.window[j] * s.window[i] * c;
            max_lag = std::max(max_lag, i - j);
        }
    }
    const std::size_t half = bins / 2;
    psd.resize(half + 1);
    const std::vector<double>& cosine = unit_circle(bins, s);
    for (std::size_t k = 0; k <= half; ++k) {
        double power = s.lag_sum[0];
        for (std::size_t lag = 1; lag <= max_lag; ++lag) power += 2.0 * s.lag_sum[lag] * cosine[lag * k % bins];
        const bool unpaired = k == 0 || 2 * k == bins;
        psd[k] = (unpaired ? 1.0 : 2.0) * power * ds / window_power;
    }
    return true;
}

namespace {

void resolved_fraction(const std::int32_t* count, std::size_t bins, double ds, const std::vector<double>& n,
                       RoughnessScratch& s, std::vector<double>& phi) {
    // Each bin lies in the interval from a backed bin to the next (ds where there is none); the window's power
    // is summed per interval length, in bins (ascending lengths, as a map would hold them).
    s.interval.assign(bins, 1);
    std::size_t previous = bins;  // none yet
    for (std::size_t j = 0; j < bins; ++j) {
        if (count[j] <= 0) continue;
        if (previous != bins) std::fill(s.interval.begin() + static_cast<std::ptrdiff_t>(previous),
                                        s.interval.begin() + static_cast<std::ptrdiff_t>(j), j - previous);
        previous = j;
    }
    auto& by_length = s.power_by_interval;
    by_length.clear();
    double total = 0.0;
    for (std::size_t j = 0; j < bins; ++j) {
        const double w2 = hann(j, bins) * hann(j, bins);
        const auto at = std::lower_bound(by_length.begin(), by_length.end(), std::pair{s.interval[j], -1.0});
        if (at == by_length.end() || at->first != s.interval[j])
            by_length.insert(at, {s.interval[j], w2});
        else
            at->second += w2;
        total += w2;
    }
    phi.assign(n.size(), 0.0);
    for (std::size_t k = 0; k < n.size(); ++k) {
        for (const auto& [length, power] : by_length) {
            const double x = n[k] * (static_cast<double>(length) * ds);
            if (x <= 0.5 * (1.0 + kNyquistTolerance)) phi[k] += std::pow(sinc(x), 4) * power;
        }
        phi[k] /= total;
    }
}

// b.limit: each band's limit on the spreads it pools, max_spread_factor × its typical (median) spread — at most
// the least typical spread of the nearer bands of min_bins bins at least: honest noise does not grow with range,
// and a wall's foot that fills a far band's bins of several points must not set its own limit.
template <class Band, class Measured>
void band_spread_limits(const double* spread, std::size_t bins, std::size_t bands, Band band, Measured measured,
                        double max_spread_factor, std::size_t min_bins, PoolBuffers& b) {
    b.start.assign(bands + 1, 0);  // each band's spreads, contiguous (a counting sort), for its median
    for (std::size_t j = 0; j < bins; ++j)
        if (measured(j)) ++b.start[band(j) + 1];
    for (std::size_t k = 0; k < bands; ++k) b.start[k + 1] += b.start[k];
    b.next.assign(b.start.begin(), b.start.end() - 1);
    b.spreads.resize(b.start[bands]);
    for (std::size_t j = 0; j < bins; ++j)
        if (measured(j)) b.spreads[b.next[band(j)]++] = spread[j];
    double nearer = std::numeric_limits<double>::infinity();
    for (std::size_t k = 0; k < bands; ++k) {
        const auto first = b.spreads.begin() + static_cast<std::ptrdiff_t>(b.start[k]);
        const auto last = b.spreads.begin() + static_cast<std::ptrdiff_t>(b.start[k + 1]);
        if (first == last) continue;
        const double typical = median(first, last);
        if (static_cast<std::size_t>(last - first) >= min_bins) nearer = std::min(nearer, typical);
        b.limit[k] = max_spread_factor * std::min(typical, nearer);
    }
}

}  // namespace

void PoolBuffers::reserve(std::size_t bands, std::size_t bins) {
    for (auto* v : {&limit, &squares, &dof, &pool}) v->reserve(bands);
    for (auto* v : {&start, &next, &cells}) v->reserve(bands + 1);
    spreads.reserve(bins);
}

bool pooled_variances(const std::int32_t* count, const double* spread, const std::int32_t* bands_of, std::size_t bins,
                      double max_spread_factor, std::size_t min_bins, PoolBuffers& b, std::vector<double>& out) {
    auto band = [&](std::size_t j) { return bands_of ? static_cast<std::size_t>(bands_of[j]) : std::size_t{0}; };
    std::size_t bands = 1;
    for (std::size_t j = 0; j < bins; ++j) bands = std::max(bands, band(j) + 1);
    auto measured = [&](std::size_t j) { return count[j] >= 2 && std::isfinite(spread[j]); };
    b.limit.assign(bands, std::numeric_limits<double>::infinity());
    if (std::isfinite(max_spread_factor))
        band_spread_limits(spread, bins, bands, band, measured, max_spread_factor, min_bins, b);
    b.squares.assign(bands, 0.0);
    b.dof.assign(bands, 0.0);
    b.cells.assign(bands, 0);
    for (std::size_t j = 0; j < bins; ++j) {
        const std::size_t k = band(j);
        if (measured(j) && spread[j] <= b.limit[k])
            b.squares[k] += (count[j] - 1) * spread[j] * spread[j], b.dof[k] += count[j] - 1, ++b.cells[k];
    }
    b.pool.assign(bands, std::numeric_limits<double>::quiet_NaN());
    bool any = false;
    for (std::size_t k = 0; k < bands; ++k)
        if (b.cells[k] >= min_bins) b.pool[k] = b.squares[k] / b.dof[k], any = true;
    if (!any) {  // too few anywhere: one pool over every band
        double squares = 0.0, dof = 0.0;
        for (std::size_t k = 0; k < bands; ++k) squares += b.squares[k], dof += b.dof[k];
        if (dof == 0.0) return false;
        b.pool.assign(bands, squares / dof);
    }
    for (std::size_t k = 1; k < bands; ++k)  // a band without a pool borrows the nearest below …
        if (b.cells[k] < min_bins) b.pool[k] = b.pool[k - 1];
    for (std::size_t k = bands - 1; k-- > 0;)  // … or, below every pool, the nearest above
        if (std::isnan(b.pool[k])) b.pool[k] = b.pool[k + 1];
    out.resize(bins);
    for (std::size_t j = 0; j < bins; ++j) out[j] = b.pool[band(j)];
    return true;
}

bool backed_variances(const std::int32_t* count, const double* spread, std::size_t bins, RoughnessScratch& s,
                      std::vector<double>& v) {
    // One pool over the stretch, not per band of range as the map's cells (method.md §7): a bin beside a ring's
    // crossing holds the points whose range error carried them there, noisier than their ring's spread says, and
    // the stretch's pool, ruled by the nearer bins, covers them (README, "Temporal fusion").
    const bool pooled = pooled_variances(count, spread, nullptr, bins, std::numeric_limits<double>::infinity(), 1,
                                         s.pool, s.pooled);
    v.assign(bins, std::numeric_limits<double>::quiet_NaN());
    bool any = false;
    for (std::size_t j = 0; j < bins; ++j) {
        if (count[j] <= 0) continue;
        const double n = count[j], s2 = spread[j] * spread[j];
        if (count[j] >= 3) {
            v[j] = kMedianVarianceFactor * s2 / n;
        } else if (count[j] == 2) {
            v[j] = s2 / 2.0;
        } else if (!std::isnan(spread[j])) {
            v[j] = s2;
        } else if (pooled) {
            v[j] = s.pooled[j];
        } else {
            return false;  // a single point, and no spread anywhere to pool
        }
        any = true;
    }
    return any;
}

std::optional<std::vector<double>> backed_variances(const std::int32_t* count, const double* spread,
                                                    std::size_t bins) {
    RoughnessScratch scratch;
    std::vector<double> v;
    if (!backed_variances(count, spread, bins, scratch, v)) return std::nullopt;
    return v;
}

std::optional<std::vector<double>> noise_psd(const std::int32_t* count, const double* spread, std::size_t bins,
                                             double ds) {
    check_spacing(ds, "noise_psd");
    RoughnessScratch scratch;
    std::vector<double> psd;
    if (!noise_psd(count, spread, bins, ds, true, scratch, psd)) return std::nullopt;
    return psd;
}

std::vector<double> resolved_fraction(const std::int32_t* count, std::size_t bins, double ds,
                                      const std::vector<double>& n) {
    check_spacing(ds, "resolved_fraction");
    RoughnessScratch scratch;
    std::vector<double> phi;
    resolved_fraction(count, bins, ds, n, scratch, phi);
    return phi;
}

void stretch_support(const std::vector<std::int32_t>& count, const std::vector<double>& spread, std::size_t first,
                     std::size_t last, double ds, const std::vector<double>& n, RoughnessScratch& s,
                     SupportBuffers& out) {
    const std::size_t bins = last - first;
    out.noise_known = noise_psd(count.data() + first, spread.data() + first, bins, ds, true, s, out.noise);
    resolved_fraction(count.data() + first, bins, ds, n, s, out.resolved);
    std::size_t backed = 0;
    for (std::size_t j = first; j < last; ++j) backed += count[j] > 0 ? 1 : 0;
    out.backed_fraction = static_cast<double>(backed) / static_cast<double>(bins);
}

StretchSupport stretch_support(const std::vector<std::int32_t>& count, const std::vector<double>& spread,
                               std::size_t first, std::size_t last, double ds, const std::vector<double>& n) {
    RoughnessScratch scratch;
    SupportBuffers buffers;
    stretch_support(count, spread, first, last, ds, n, scratch, buffers);
    StretchSupport s;
    if (buffers.noise_known) s.noise = std::move(buffers.noise);
    s.resolved = std::move(buffers.resolved);
    s.backed_fraction = buffers.backed_fraction;
    return s;
}

}  // namespace roadpreview
