// SPDX-License-Identifier: BSD-3-Clause
// International Roughness Index (docs/method.md §6): the ASTM E1926 golden quarter-car at 80 km/h on a wheel's
// profile after the 250 mm moving average; IRI = mean rectified suspension slope, m/km.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "roadpreview/core/config.hpp"

namespace roadpreview {

struct Profile;
struct Roughness;

struct Iri {
    std::optional<double> value;  ///< m/km; nullopt with a reason
    double length_m = 0.0;        ///< length of the stretch it covers
    std::string reason;           ///< empty when there is a value
    std::optional<double> backed_fraction;  ///< bins of the stretch that hold points; nullopt: unknown
};

inline constexpr char kIriTooSparse[] = "too few bins with points for IRI";
inline constexpr char kIriClassDeclined[] = "roughness class declined";

/// |sprung − unsprung slope| (m/m) of the golden car after each step of the 250 mm moving average of an
/// all-finite profile sampled every ds m (count − k values for a k-sample average); the car starts with
/// the profile's mean slope over its first 11 m.
std::vector<double> iri_rectified_slope(const double* z, std::size_t count, double ds);

/// IRI of an all-finite profile, m/km: the mean of iri_rectified_slope × 1000.
double iri(const double* z, std::size_t count, double ds);

/// IRI over the longest valid stretch of a profile (NaN = missing bin), if it is at least cfg.min_length_m long.
Iri profile_iri(const std::vector<double>& z, double ds, const IriConfig& cfg);

/// A wheel's IRI as the pipeline reports it (docs/method.md §6): profile_iri over the longest valid stretch,
/// with the share of its bins that hold points; null when that share is below cfg.min_backed_fraction
/// (kIriTooSparse) or when `wheel`, the roughness of the same profile, has no class (kIriClassDeclined).
Iri wheel_iri(const Profile& profile, const Roughness& wheel, const IriConfig& cfg);

/// Mean of both wheels' IRI (the mean roughness index) when both have one; its backed fraction is their mean.
Iri vehicle_iri(const Iri& left, const Iri& right);

}  // namespace roadpreview
