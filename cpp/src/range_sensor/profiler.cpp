// SPDX-License-Identifier: BSD-3-Clause
// Range-sensor samples binned into windows along the track, then the roughness and IRI stages
// (docs/method.md §11.5); the window's output line (docs/output.md).
#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>
#include <stdexcept>
#include <string>

#include "core/text.hpp"
#include "pipeline/output_json.hpp"
#include "roadpreview/range_sensor/range_sensor.hpp"
#include "roadpreview/roughness/support.hpp"

namespace roadpreview {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr double kQuietSensorMargin_m = 5.0;  // beyond any layout's spread of sample positions
constexpr int kMaxWindowBins = 1'000'000;     // 100 km at 0.1 m: a window is a stretch of road, not a drive

double median_in_place(std::vector<double>& v) {
    const auto mid = v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2);
    std::nth_element(v.begin(), mid, v.end());
    if (v.size() % 2) return *mid;
    return 0.5 * (*mid + *std::max_element(v.begin(), mid));
}

double sample_std(const std::vector<double>& v) {
    if (v.size() < 2) return kNaN;
    const double mean = std::accumulate(v.begin(), v.end(), 0.0) / static_cast<double>(v.size());
    double ss = 0.0;
    for (double x : v) ss += (x - mean) * (x - mean);
    return std::sqrt(ss / static_cast<double>(v.size() - 1));
}

// The highest frequency (cycles/m) of `n` (the grid of the PSD of the profile's longest stretch, as the roughness
// has it) up to which the readings' spacing resolves the road: Φ ≥ min_resolved_fraction, the rule by which the
// noise-aware fit ends its band (docs/noise-aware-roughness.md §3); infinite when every ordinate is resolved.
double resolved_band_max(const Profile& p, const std::vector<double>& n, double min_resolved_fraction) {
    const auto [first, last] = longest_valid_stretch(p.z);
    if (n.size() < 2 || last <= first) return std::numeric_limits<double>::infinity();
    const std::vector<double> phi = resolved_fraction(p.count.data() + first, last - first, p.ds, n);
    for (std::size_t k = 1; k < n.size(); ++k)  // n[0] = 0: the mean, not in any band
        if (phi[k] < min_resolved_fraction) return n[k - 1];
    return std::numeric_limits<double>::infinity();
}

// Noise-aware roughness needs bins of 2+ readings to measure the noise. With single-reading bins only, the plain
// fit of §4 over the band the readings' spacing resolves (`resolved_max`, cycles/m; band_limit "sampling" when it
// is the limit): between sparse readings the interpolation smooths the short waves away, and a fit up to
// 4 cycles/m read a class C road as A.
template <class Analyze>
Roughness plain_fit_over_resolved_band(const RoughnessConfig& cfg, double resolved_max, Analyze&& analyze) {
    RoughnessConfig plain = cfg;
    plain.noise_aware = false;
    const bool sampling = resolved_max < plain.band_max_cpm;
    plain.band_max_cpm = std::min(plain.band_max_cpm, resolved_max);
    Roughness r = analyze(plain);
    if (sampling) r.band_limit = BandLimit::Sampling;
    return r;
}

Roughness wheel_roughness(const Profile& p, const RangeProfilerConfig& cfg) {
    Roughness r = analyze_roughness(p, cfg.roughness);
    if (r.reason == RoughnessReason::NoiseUnknown)
        r = plain_fit_over_resolved_band(
            cfg.roughness, resolved_band_max(p, r.spectrum.n, cfg.roughness.min_resolved_fraction),
            [&](const RoughnessConfig& plain) { return analyze_roughness(p, plain); });
    r.iri = wheel_iri(p, r, cfg.iri);  // backed fraction, noise, and declined where too sparse
    return r;
}

}  // namespace

Profile bin_samples(const std::vector<RangeSample>& samples, const std::vector<std::uint8_t>& take, double s0_m,
                    double length_m, double ds_m, double max_gap_m) {
    const auto bins = static_cast<std::size_t>(std::ceil(length_m / ds_m - 1e-9));
    std::vector<std::vector<double>> heights(bins);
    for (std::size_t i = 0; i < samples.size(); ++i) {
        if (!take[i]) continue;
        const double u = (samples[i].s_m - s0_m) / ds_m;
        if (u >= 0 && u < static_cast<double>(bins)) heights[static_cast<std::size_t>(u)].push_back(samples[i].z_m);
    }
    Profile p;
    p.ds = ds_m;
    p.s0 = s0_m + 0.5 * ds_m;
    for (std::size_t k = 0; k < bins; ++k) {
        p.s.push_back(p.s0 + static_cast<double>(k) * ds_m);
        p.count.push_back(static_cast<std::int32_t>(heights[k].size()));
        p.spread.push_back(sample_std(heights[k]));
        p.z.push_back(heights[k].empty() ? kNaN : median_in_place(heights[k]));
    }
    p.blocked.assign(bins, 0);
    fill_gaps(p.z, ds_m, max_gap_m);
    return p;
}

RangeProfiler::RangeProfiler(std::vector<RangeSensor> layout, RangeCalibration cal, RangeProfilerConfig cfg)
    : layout_(std::move(layout)), cal_(std::move(cal)), cfg_(cfg) {
    if (layout_.empty()) throw std::invalid_argument("the sensor layout is empty");
    if (!(cfg_.frame_length_m > 0 && cfg_.ds_m > 0 && cfg_.frame_length_m >= 2 * cfg_.ds_m))
        throw std::invalid_argument("frame_length_m and ds_m must be > 0 with at least two bins per window");
    if (!(cfg_.frame_length_m / cfg_.ds_m <= kMaxWindowBins))  // a window's bins are allocated
        throw std::invalid_argument("frame_length_m / ds_m must be at most " + std::to_string(kMaxWindowBins) +
                                    " bins per window, got " + number_text(cfg_.frame_length_m) + " m / " +
                                    number_text(cfg_.ds_m) + " m");
    // A calibration of another layout's sensors would leave these on their geometric foot, silently.
    for (const auto& [id, calibration] : cal_.sensors)
        if (std::none_of(layout_.begin(), layout_.end(), [&](const RangeSensor& s) { return s.id == id; }))
            throw std::invalid_argument("the calibration names sensor '" + id + "', which the layout does not hold");
    latest_.assign(layout_.size(), -std::numeric_limits<double>::infinity());
}

std::optional<RangeWindow> RangeProfiler::add(const RangeSample& sample) {
    const double end = static_cast<double>(index_ + 1) * cfg_.frame_length_m;
    if (sample.s_m < end) open_.push_back(sample);
    else next_.push_back(sample);
    double& latest = latest_[static_cast<std::size_t>(sample.sensor)];
    latest = std::max(latest, sample.s_m);
    // Closed once every sensor heard from is past its end (sensors further ahead reach it first), or one is
    // far past it (another has gone quiet): memory stays bounded.
    if (latest >= end + kQuietSensorMargin_m) return close_window();
    for (double s : latest_)
        if (s != -std::numeric_limits<double>::infinity() && s < end) return std::nullopt;
    return close_window();
}

std::optional<RangeWindow> RangeProfiler::finish() {
    std::optional<RangeWindow> out;
    if (!open_.empty()) out = close_window();
    return out;
}

RangeWindow RangeProfiler::close_window() {
    RangeWindow w;
    w.index = index_;
    w.s_start_m = static_cast<double>(index_) * cfg_.frame_length_m;
    w.s_end_m = w.s_start_m + cfg_.frame_length_m;
    w.samples.swap(open_);
    const auto behind = std::remove_if(w.samples.begin(), w.samples.end(),  // behind the window (reversing): dropped
                                       [&](const RangeSample& s) { return s.s_m < w.s_start_m; });
    dropped_behind_ += w.samples.end() - behind;
    w.samples.erase(behind, w.samples.end());
    // The next window holds about as many: one allocation instead of a doubling chain (copies of megabytes,
    // and the allocator handing pages back and faulting them in again, window after window).
    open_.reserve(w.samples.size());
    std::vector<std::uint8_t> left(w.samples.size()), right(w.samples.size());
    double speed = 0.0;
    for (std::size_t i = 0; i < w.samples.size(); ++i) {
        const bool is_left = layout_[static_cast<std::size_t>(w.samples[i].sensor)].wheel == Wheel::Left;
        left[i] = is_left;
        right[i] = !is_left;
        speed += w.samples[i].speed_mps;
    }
    if (!w.samples.empty()) {
        w.t_first_s = w.samples.front().t_s;
        w.t_last_s = w.samples.back().t_s;
        w.mean_speed_mps = speed / static_cast<double>(w.samples.size());
    }
    w.left = bin_samples(w.samples, left, w.s_start_m, cfg_.frame_length_m, cfg_.ds_m, cfg_.max_gap_m);
    w.right = bin_samples(w.samples, right, w.s_start_m, cfg_.frame_length_m, cfg_.ds_m, cfg_.max_gap_m);
    w.left.roughness = wheel_roughness(w.left, cfg_);
    w.right.roughness = wheel_roughness(w.right, cfg_);
    w.vehicle = vehicle_roughness(w.left, w.right, cfg_.roughness);
    if (w.vehicle.reason == RoughnessReason::NoiseUnknown) {
        const double f = cfg_.roughness.min_resolved_fraction;
        const double resolved = std::min(resolved_band_max(w.left, w.vehicle.spectrum.n, f),
                                         resolved_band_max(w.right, w.vehicle.spectrum.n, f));
        w.vehicle = plain_fit_over_resolved_band(
            cfg_.roughness, resolved,
            [&](const RoughnessConfig& plain) { return vehicle_roughness(w.left, w.right, plain); });
    }
    w.vehicle.iri = vehicle_iri(w.left.roughness.iri, w.right.roughness.iri);
    if (std::none_of(left.begin(), left.end(), [](auto v) { return v; })) w.reason = "no left-wheel samples";
    else if (std::none_of(right.begin(), right.end(), [](auto v) { return v; })) w.reason = "no right-wheel samples";
    ++index_;
    open_.clear();
    // Samples already beyond this window wait for theirs (a window may also be empty).
    const double end = static_cast<double>(index_ + 1) * cfg_.frame_length_m;
    std::vector<RangeSample> later;
    for (const RangeSample& s : next_) (s.s_m < end ? open_ : later).push_back(s);
    next_ = std::move(later);
    return w;
}

namespace {

using detail::JsonWriter;

// One of the samples' arrays: a window holds thousands of samples, streamed as they are.
template <typename Write>
void write_samples(JsonWriter& w, const char* name, const std::vector<RangeSample>& samples, Write write) {
    w.Key(name);
    w.StartArray();
    for (const RangeSample& x : samples) write(x);
    w.EndArray();
}

void write_samples(JsonWriter& w, const std::vector<RangeSample>& samples, const std::vector<RangeSensor>& layout) {
    using detail::write_number;
    w.StartObject();
    write_samples(w, "t", samples, [&](const RangeSample& x) { write_number(w, x.t_s); });
    write_samples(w, "sensor", samples, [&](const RangeSample& x) {
        detail::write_string(w, layout[static_cast<std::size_t>(x.sensor)].id, "sensor id");
    });
    write_samples(w, "s", samples, [&](const RangeSample& x) { write_number(w, x.s_m); });
    write_samples(w, "z", samples, [&](const RangeSample& x) { write_number(w, x.z_m); });
    write_samples(w, "ahead", samples, [&](const RangeSample& x) { write_number(w, x.ahead_m); });
    write_samples(w, "time_to_wheel", samples, [&](const RangeSample& x) { write_number(w, x.time_to_wheel_s); });
    w.EndObject();
}

}  // namespace

std::string range_window_to_json(const RangeWindow& w, const std::vector<RangeSensor>& layout,
    const std::string& source) {
    using detail::write_number;
    rapidjson::StringBuffer text;
    JsonWriter out(text);
    out.StartObject();
    out.Key("frame"), out.Int64(w.index);
    out.Key("source"), out.String("range");
    out.Key("input"), detail::write_string(out, source, "input name");
    out.Key("timestamp"), detail::write_optional_number(out, w.samples.empty() ? std::nullopt
                                                                                : std::optional<double>(w.t_first_s));
    out.Key("window"), out.StartObject();
    out.Key("s_start"), write_number(out, w.s_start_m);
    out.Key("s_end"), write_number(out, w.s_end_m);
    out.Key("t_first"), write_number(out, w.t_first_s);
    out.Key("t_last"), write_number(out, w.t_last_s);
    out.Key("mean_speed"), write_number(out, w.mean_speed_mps);
    out.EndObject();
    detail::write_profiles_and_roughness(out, w.left, w.right, w.vehicle);
    out.Key("reason"), detail::write_string_or_null(out, w.reason, "reason");
    out.Key("samples"), write_samples(out, w.samples, layout);
    out.EndObject();
    return std::string(text.GetString(), text.GetSize());
}

}  // namespace roadpreview
