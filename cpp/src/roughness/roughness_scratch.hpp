// SPDX-License-Identifier: BSD-3-Clause
// Internal: the roughness stage (§4, the noise-aware support, §6 IRI) into results the caller keeps, with buffers
// kept between frames — FFT plans cached per length included — so that rating a stream of profiles allocates
// nothing once they have grown.
#pragma once

#include <complex>
#include <cstdint>
#include <limits>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include <unsupported/Eigen/FFT>

#include "core/text.hpp"
#include "roadpreview/profile/profile.hpp"
#include "roadpreview/roughness/iri.hpp"
#include "roadpreview/roughness/roughness.hpp"
#include "roadpreview/roughness/support.hpp"

namespace roadpreview {

/// Throws, naming `where`, unless the bins' spacing ds is a finite length > 0 (0 divides by zero, a negative one
/// gave negative spectra, and the stage functions take ds from their caller, not from a checked config).
inline void check_spacing(double ds, const char* where) {
    if (!(ds > 0.0 && ds < std::numeric_limits<double>::infinity()))
        throw std::invalid_argument(std::string(where) + ": the bin spacing ds must be a finite length > 0 m, got " +
                                    number_text(ds));
}

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

/// Eigen's KISS FFT with its plans made ahead: a length's plan (twiddles, factors and the generic butterfly's
/// buffer) is what its first transform makes before transforming. Planning by transforming every length up to a
/// profile's bins took 32 ms per Estimator — a prime length transforms in O(n²). Uses the protected members of
/// Eigen 3.4's kissfft_impl (unsupported/Eigen/src/FFT/ei_kissfft_impl.h).
struct PlannedKissFft : Eigen::internal::kissfft_impl<double> {
    /// The plans and buffer that fwd(Complex*, const double*, nfft), a real forward transform, uses.
    void plan_real_forward(int nfft) {
        if (nfft & 3) {  // a complex transform of the real input, through m_tmpBuf1
            get_plan(nfft, false);
            m_tmpBuf1.reserve(static_cast<std::size_t>(nfft));
        } else {  // half as long a complex transform, and the twiddles that recombine it
            real_twiddles(nfft >> 2);
            get_plan(nfft >> 1, false);
        }
    }
};

struct RoughnessScratch {
    /// Stretches of up to this many bins have their FFT planned ahead. A length's plan holds O(length) twiddles,
    /// so planning every length up to N costs O(N²): a process planning up to 8,000 bins peaked at 633 MB, up to
    /// 40,000 (a legal ds_m of 1 mm) at 12.9 GB. Constructing an Estimator now adds 2 MB to the peak for the
    /// default 400 bins, 11 MB for 1,024 and beyond (measured with ru_maxrss).
    static constexpr std::size_t kPlannedLength = 1024;
    Eigen::FFT<double, PlannedKissFft> fft;  // a plan per length up to kPlannedLength, made by plan_ffts
    Eigen::FFT<double> unplanned;  // longer stretches: planned as they come, the plan dropped after the transform
    std::vector<double> detrended;
    std::vector<std::complex<double>> transform;
    Spectrum right;                 // the right wheel's PSD over the vehicle's stretch
    SupportBuffers support, other;  // the wheel's (the left's), and the right wheel's for the vehicle
    // stretch_support
    std::vector<double> variance, lag_sum, window, pooled;
    std::vector<double> cosine;  // cos(2π m / N), m = 0 … N − 1, for the last stretch of N bins
    PoolBuffers pool;
    std::vector<Anchors> anchors;
    std::vector<std::size_t> interval;
    std::vector<std::pair<std::size_t, double>> power_by_interval;
    // the fits
    std::vector<std::size_t> used, strong;
    std::vector<double> x, y, shape, floor, share, corrected;
    std::vector<double> iri_noise;  // the IRI's: the unwindowed noise PSD

    /// Plans the FFT of every stretch length up to `bins` (at most kPlannedLength), so that no frame pays (or
    /// allocates) for a plan, and reserves the transform's and the fits' buffers for that many bins.
    void plan_ffts(std::size_t bins);
};

/// The displacement PSD of `count` heights `ds` apart (docs/method.md §4) into `sp`, with the scratch's FFT plans.
void displacement_psd(const double* z, std::size_t count, double ds, RoughnessScratch& s, Spectrum& sp);

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
/// noise_psd of `bins` bins (support.hpp) into `psd`, windowed as the profile's PSD or not at all (w = 1, U = 1:
/// the errors' power averaged over the stretch); false when the bins' noise is unknown.
bool noise_psd(const std::int32_t* count, const double* spread, std::size_t bins, double ds, bool windowed,
               RoughnessScratch& s, std::vector<double>& psd);
/// wheel_iri and vehicle_iri into `out` (its noise from the scratch's buffers).
void wheel_iri(const Profile& profile, const Roughness& wheel, const IriConfig& cfg, RoughnessScratch& s, Iri& out);
void vehicle_iri(const Iri& left, const Iri& right, Iri& out);

/// Every field back to its default, keeping the vectors' and strings' capacity.
void clear(Iri& iri);
void clear(Roughness& r);

}  // namespace roadpreview
