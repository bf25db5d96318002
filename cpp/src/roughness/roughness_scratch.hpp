// SPDX-License-Identifier: BSD-3-Clause
// Internal: the roughness stage (§4, the noise-aware support, §6 IRI) into results the caller keeps, with buffers
// kept between frames — FFT plans cached per length included — so that rating a stream of profiles allocates
// nothing once they have grown.
#pragma once

#include <complex>
#include <cstdint>
#include <utility>
#include <vector>

#include <unsupported/Eigen/FFT>

#include "roadpreview/profile/profile.hpp"
#include "roadpreview/roughness/iri.hpp"
#include "roadpreview/roughness/roughness.hpp"
#include "roadpreview/roughness/support.hpp"

namespace roadpreview {

/// Bin j's height error as weights on (at most) two backed bins: itself, or its gap's two ends.
struct Anchors {
    std::size_t bin[2];
    double weight[2];
};

/// A StretchSupport whose noise PSD keeps its buffer when it is unknown (noise_known false).
struct SupportBuffers {
    std::vector<double> noise;
    bool noise_known = false;
    std::vector<double> resolved;
    double backed_fraction = 0.0;
};

struct RoughnessScratch {
    Eigen::FFT<double> fft;  // keeps a plan per length it has seen
    std::vector<double> detrended;
    std::vector<std::complex<double>> transform;
    Spectrum right;                 // the right wheel's PSD over the vehicle's stretch
    SupportBuffers support, other;  // the wheel's (the left's), and the right wheel's for the vehicle
    // stretch_support
    std::vector<double> variance, lag_sum, window, pooled;
    PoolBuffers pool;
    std::vector<Anchors> anchors;
    std::vector<std::size_t> interval;
    std::vector<std::pair<std::size_t, double>> power_by_interval;
    // the fits
    std::vector<std::size_t> used, strong;
    std::vector<double> x, y, shape, floor, share, corrected;

    /// Plans the FFT of every stretch length up to `bins`, so that no frame pays (or allocates) for a plan, and
    /// reserves the fits' buffers for that many bins.
    void plan_ffts(std::size_t bins);
};

/// analyze_roughness(profile, cfg) into `out`.
void analyze_roughness(const Profile& profile, const RoughnessConfig& cfg, RoughnessScratch& s, Roughness& out);
/// vehicle_roughness(left, right, cfg) into `out`.
void vehicle_roughness(const Profile& left, const Profile& right, const RoughnessConfig& cfg, RoughnessScratch& s,
                       Roughness& out);
/// Support of bins [first, last) of count and spread on the frequency grid n, into `out`.
void stretch_support(const std::vector<std::int32_t>& count, const std::vector<double>& spread, std::size_t first,
                     std::size_t last, double ds, const std::vector<double>& n, RoughnessScratch& s,
                     SupportBuffers& out);
/// backed_variances into `v`; false when no bin holds points, or a single point has neither spread nor pool.
bool backed_variances(const std::int32_t* count, const double* spread, std::size_t bins, RoughnessScratch& s,
                      std::vector<double>& v);
/// wheel_iri and vehicle_iri into `out`.
void wheel_iri(const Profile& profile, const Roughness& wheel, const IriConfig& cfg, Iri& out);
void vehicle_iri(const Iri& left, const Iri& right, Iri& out);

/// Every field back to its default, keeping the vectors' and strings' capacity.
void clear(Iri& iri);
void clear(Roughness& r);

}  // namespace roadpreview
