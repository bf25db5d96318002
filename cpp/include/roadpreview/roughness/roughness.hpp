// SPDX-License-Identifier: BSD-3-Clause
// Stage 4 — roughness: one-sided displacement PSD of a profile and its ISO 8608 class (docs/method.md §4);
// noise-aware when the points behind the bins are known (docs/noise-aware-roughness.md); the IRI beside it.
#pragma once

#include <optional>
#include <vector>

#include "roadpreview/core/config.hpp"
#include "roadpreview/roughness/iri.hpp"
#include "roadpreview/roughness/support.hpp"

namespace roadpreview {

struct Profile;

inline constexpr double kIsoN0 = 0.1;  ///< ISO 8608 reference spatial frequency, cycles/m
inline constexpr char kIsoClasses[] = "ABCDEFGH";

/// One-sided displacement PSD; n[0] = 0 (the DC ordinate) and n[k] = k/(N·ds).
struct Spectrum {
    std::vector<double> n;    ///< cycles/m
    std::vector<double> psd;  ///< G_d(n), m³
};

/// Detrend (least-squares line), periodic Hann window with power correction, FFT, one-sided PSD.
/// Parseval: Σ psd·Δn = mean((x·w)²) / mean(w²) for the detrended profile x.
Spectrum displacement_psd(const double* z, std::size_t count, double ds);

/// Why a profile (or the vehicle) has no ISO 8608 class (None: it has one). to_string gives the text of the
/// output's `reason`.
enum class RoughnessReason {
    None,
    NoValidProfile,      ///< "no valid profile"
    StretchTooShort,     ///< "valid stretch too short"
    TooFewOrdinates,     ///< "too few PSD ordinates in band"
    NoiseUnknown,        ///< "noise floor unknown": noise-aware, but no bin has the points to measure it
    NoiseDominates,      ///< "noise dominates the band"
    FitFailed,           ///< "fit failed (G_d(n0) not finite)"
    BothWheelsDeclined,  ///< "both wheels declined" (the vehicle)
    // The frame's FrameStatus, with its text: the frame has no profiles.
    NoFinitePoints,  ///< "no finite points"
    NoRoiPoints,     ///< "no points in the region of interest"
    NoGround,        ///< "no ground"
    TiltedGround,    ///< "no ground within the tilt limit"
    VehicleStopped,  ///< "vehicle stopped"
};

/// What set the upper edge of the band the fit used (None: no band). to_string gives the output's `band_limit`.
enum class BandLimit {
    None,
    Requested,  ///< "requested": RoughnessConfig::band_max_cpm
    Nyquist,    ///< "nyquist": of the bins
    Sampling,   ///< "sampling": the points' spacing stops resolving the road (noise-aware)
    Noise,      ///< "noise": the noise dominates (no class, or class A from the noise bound)
    Wheels,     ///< "wheels": the vehicle's class from the mean of the wheels' (reconcile_vehicle)
};

/// The documented texts ("noise dominates the band", "nyquist", ...); "" for None.
const char* to_string(RoughnessReason reason) noexcept;
const char* to_string(BandLimit limit) noexcept;

struct Roughness {
    std::optional<char> iso_class;  ///< 'A'..'H'; nullopt when the data do not support a class
    double gd_n0 = 0.0;             ///< m³, G_d(n0) of the w = 2 fit
    double gd_n0_free = 0.0;        ///< m³, G_d(n0) of the free-waviness fit
    double waviness = 0.0;          ///< w of the free fit
    double band_lo = 0.0, band_hi = 0.0;  ///< cycles/m, band actually used (0, 0 when none)
    Spectrum spectrum;
    std::vector<double> octave_centers;   ///< cycles/m
    std::vector<double> octave_gd;        ///< m³, mean G_d in each ISO 8608 octave band
    RoughnessReason reason = RoughnessReason::None;  ///< None when classified
    double confidence = 0.0;              ///< probability that the class is right, given the fit's spread
    std::vector<double> noise_psd;        ///< m³, expected PSD of the bin errors on the grid n; empty: unknown
    std::optional<double> noise_floor;    ///< m³, mean of noise_psd over the analysis band
    std::optional<double> backed_fraction;  ///< bins of the stretch that hold points; nullopt: unknown
    BandLimit band_limit = BandLimit::None;  ///< what set the band's upper edge
    Iri iri;                              ///< International Roughness Index of the same profile (§6)
};

/// ISO 8608 class of G_d(n0) in m³ (limits at the geometric midpoints; a limit belongs to the rougher class).
char iso_class(double gd_n0_m3);

/// Steps 6–9 of §4 on a spectrum of a stretch `length_m` long; with `support` (and cfg.noise_aware) the band
/// and fit of docs/noise-aware-roughness.md.
Roughness classify_spectrum(Spectrum spectrum, double length_m, double ds, const RoughnessConfig& cfg,
                            const StretchSupport* support = nullptr);

/// The whole of §4 on a profile with NaN for missing bins (no point statistics: not noise-aware).
Roughness analyze_roughness(const std::vector<double>& z, double ds, const RoughnessConfig& cfg);

/// The whole of §4 on a profile, noise-aware from its count and spread.
Roughness analyze_roughness(const Profile& profile, const RoughnessConfig& cfg);

/// Both wheels over the longest stretch valid in both, PSDs averaged (not noise-aware).
Roughness vehicle_roughness(const std::vector<double>& z_left, const std::vector<double>& z_right, double ds,
                            const RoughnessConfig& cfg);

/// Both wheels, noise-aware with the mean of the two profiles' support.
Roughness vehicle_roughness(const Profile& left, const Profile& right, const RoughnessConfig& cfg);

/// The vehicle's class never contradicts both wheels (docs/method.md §4, "Vehicle"): with both wheels declined
/// it is declined (BothWheelsDeclined); with both classified and the common stretch declined, G_d(n0) is
/// the mean of the wheels' (BandLimit::Wheels); with one wheel classified its own fit stands.
void reconcile_vehicle(Roughness& vehicle, const Roughness& left, const Roughness& right);

/// Probability that the true G_d(n0) lies in iso_class(gd_n0) for a normal error of ln G_d(n0) of this variance.
double class_confidence(double gd_n0_m3, double log_variance);

/// Half-open [first, last) of the longest run of finite values (the first on ties).
std::pair<std::size_t, std::size_t> longest_valid_stretch(const std::vector<double>& z);

}  // namespace roadpreview
