// SPDX-License-Identifier: BSD-3-Clause
// International Roughness Index (docs/method.md §6): the ASTM E1926 golden quarter-car at 80 km/h on a wheel's
// profile after the 250 mm moving average; IRI = mean rectified suspension slope, m/km.
#pragma once

#include <optional>
#include <vector>

#include "roadpreview/core/config.hpp"

namespace roadpreview {

struct Profile;
struct Roughness;

/// Why a profile has no IRI (None: it has one). to_string gives the text of the output's `reason`.
enum class IriReason {
    None,
    NoValidProfile,     ///< "no valid profile"
    StretchTooShort,    ///< "valid stretch too short for IRI"
    TooSparse,          ///< "too few bins with points for IRI": below IriConfig::min_backed_fraction
    ClassDeclined,      ///< "roughness class declined": the same profile has no ISO 8608 class
    SegmentNotCovered,  ///< "segment not covered by one valid stretch" (a route segment)
    // The frame's FrameStatus, with its text: the frame has no profiles.
    NoFinitePoints,  ///< "no finite points"
    NoRoiPoints,     ///< "no points in the region of interest"
    NoGround,        ///< "no ground"
    TiltedGround,    ///< "no ground within the tilt limit"
    VehicleStopped,  ///< "vehicle stopped"
};

/// The documented text ("valid stretch too short for IRI", ...); "" for None.
const char* to_string(IriReason reason) noexcept;

struct Iri {
    std::optional<double> value;  ///< m/km; nullopt with a reason
    double length_m = 0.0;        ///< length of the stretch it covers
    IriReason reason = IriReason::None;     ///< None when there is a value
    std::optional<double> backed_fraction;  ///< bins of the stretch that hold points; nullopt: unknown
    /// m/km, the IRI the stretch's bin errors alone would give (docs/method.md §6); nullopt: the errors are unknown
    std::optional<double> noise;
};

/// |sprung − unsprung slope| (m/m) of the golden car after each step of the 250 mm moving average of an
/// all-finite profile sampled every ds m (count − k values for a k-sample average); the car starts with
/// the profile's mean slope over its first 11 m.
std::vector<double> iri_rectified_slope(const double* z, std::size_t count, double ds);

/// IRI of an all-finite profile, m/km: the mean of iri_rectified_slope × 1000.
double iri(const double* z, std::size_t count, double ds);

/// The IRI (m/km) that the bin errors of a stretch alone would give (docs/method.md §6): their noise PSD without
/// a window (support.hpp's noise_psd, w = 1) through the IRI filter's power gain, × √(2/π); nullopt when the
/// bins' variances are unknown.
std::optional<double> iri_noise(const std::int32_t* count, const double* spread, std::size_t bins, double ds);

/// IRI over the longest valid stretch of a profile (NaN = missing bin), if it is at least cfg.min_length_m long.
Iri profile_iri(const std::vector<double>& z, double ds, const IriConfig& cfg);

/// A wheel's IRI as the pipeline reports it (docs/method.md §6): profile_iri over the longest valid stretch,
/// with the share of its bins that hold points and the IRI of their errors alone (from their counts and spreads);
/// null when that share is below cfg.min_backed_fraction (IriReason::TooSparse) or when `wheel`, the roughness of
/// the same profile, has no class (ClassDeclined).
Iri wheel_iri(const Profile& profile, const Roughness& wheel, const IriConfig& cfg);

/// Mean of both wheels' IRI (the mean roughness index) when both have one; its backed fraction and its noise are
/// their means (when both wheels have them).
Iri vehicle_iri(const Iri& left, const Iri& right);

}  // namespace roadpreview
