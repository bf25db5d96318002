// SPDX-License-Identifier: BSD-3-Clause
// The beams file (beams.yaml, docs/output.md "Beams file"), its sensor check, the beam index of points that do
// not carry one (KITTI .bin: by their place in the file's scan order, else by elevation angle) and the correction
// of such points.
#include <algorithm>
#include <cmath>
#include <fstream>
#include <sstream>

#include <yaml-cpp/yaml.h>

#include "roadpreview/calibration/calibration.hpp"

#include "core/input_file.hpp"
#include "core/median.hpp"
#include "core/text.hpp"

namespace roadpreview {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr const char* kFormat = "roadpreview beam calibration 1";
constexpr double kMaxElevationOffsetDeg = 5.0;  // a calibration corrects tenths of a degree
constexpr double kMaxRangeOffsetM = 1.0;        // and centimetres

double deg(double rad) { return rad * 180.0 / kPi; }
double rad(double deg) { return deg * kPi / 180.0; }

// NaN as YAML null (σ of an offset that was not determined).
void emit_number(YAML::Emitter& e, double v) {
    if (std::isfinite(v)) e << v;
    else e << YAML::Null;
}

double read_number(const YAML::Node& n, double fallback) {
    if (!n || n.IsNull()) return fallback;
    return n.as<double>();
}

BeamOffsets read_beam(const YAML::Node& n) {
    BeamOffsets b;
    const double nan = std::numeric_limits<double>::quiet_NaN();
    b.determined = n["determined"].as<bool>();
    b.elevation_offset_deg = read_number(n["elevation_offset_deg"], 0.0);
    b.elevation_sigma_deg = read_number(n["elevation_sigma_deg"], nan);
    b.range_offset_m = read_number(n["range_offset_m"], 0.0);
    b.range_sigma_m = read_number(n["range_sigma_m"], nan);
    b.observations = n["observations"] ? n["observations"].as<std::int64_t>() : 0;
    b.elevation_deg = read_number(n["elevation_deg"], nan);
    // A beam off by more than a few degrees or a metre is another sensor's beam, not a calibration's correction.
    if (!(std::abs(b.elevation_offset_deg) <= kMaxElevationOffsetDeg))
        throw std::runtime_error("elevation_offset_deg must lie within ±" + number_text(kMaxElevationOffsetDeg) +
                                 "°, got " + number_text(b.elevation_offset_deg));
    if (!(std::abs(b.range_offset_m) <= kMaxRangeOffsetM))
        throw std::runtime_error("range_offset_m must lie within ±" + number_text(kMaxRangeOffsetM) + " m, got " +
                                 number_text(b.range_offset_m));
    for (const double sigma : {b.elevation_sigma_deg, b.range_sigma_m})
        if (sigma < 0.0 || std::isinf(sigma)) throw std::runtime_error("a sigma must be finite and >= 0 (or null)");
    return b;
}

// Elevation less the common tilt (deg) of a point at azimuth az (rad).
double untilted_elevation_deg(double el_deg, double az, const double tilt[2]) {
    return el_deg - tilt[0] * (std::cos(az) - 1.0) - tilt[1] * std::sin(az);
}

// A point that takes part in finding the beam centres: its elevation (deg), cos φ − 1 and sin φ.
struct CentreSample {
    double elevation_deg, cos_az_minus_1, sin_az;
};

// The front half, beyond 4 m (near the sensor the lasers' own offsets from its origin shift the elevation).
std::vector<CentreSample> centre_samples(const std::vector<PointsView>& frames) {
    std::vector<CentreSample> out;
    for (const PointsView& f : frames)
        for (Eigen::Index k = 0; k < f.rows(); ++k) {
            const double x = f(k, 0), y = f(k, 1), z = f(k, 2), r = std::sqrt(x * x + y * y + z * z);
            if (!std::isfinite(r) || r < 4.0 || x <= 0) continue;
            const double az = std::atan2(y, x);
            out.push_back({deg(std::asin(z / r)), std::cos(az) - 1.0, std::sin(az)});
        }
    return out;
}

constexpr double kHistogramStepDeg = 0.02;
constexpr double kMinBeamGapDeg = 0.25;  // beams closer than this in elevation are taken for one (HDL-64E: ≥ 0.33°)

std::vector<double> histogram(const std::vector<CentreSample>& samples, const double tilt[2], double lo,
                              std::size_t bins) {
    std::vector<double> h(bins, 0.0);
    for (const CentreSample& s : samples) {
        const double el = s.elevation_deg - tilt[0] * s.cos_az_minus_1 - tilt[1] * s.sin_az;
        const double k = std::floor((el - lo) / kHistogramStepDeg);
        if (k >= 0 && k < static_cast<double>(bins)) h[static_cast<std::size_t>(k)] += 1.0;
    }
    return h;
}

double sharpness(const std::vector<double>& h) {
    double s = 0.0;
    for (double v : h) s += v * v;
    return s;
}

// Each point's ring in a file that lists the points ring by ring, each ring one turn starting just past azimuth 0
// (KITTI's .bin files): the ring number goes up where the azimuth steps from below 0 to 0 or above; a large step
// (across ±180°) is no ring start. Points without a finite x, y stay in the ring they are in.
std::vector<std::int32_t> rings_in_order(PointsView points) {
    std::vector<std::int32_t> ring(static_cast<std::size_t>(points.rows()), 0);
    std::int32_t current = 0;
    double last = std::numeric_limits<double>::quiet_NaN();
    for (Eigen::Index k = 0; k < points.rows(); ++k) {
        const double x = points(k, 0), y = points(k, 1);
        if (std::isfinite(x) && std::isfinite(y) && (x != 0.0 || y != 0.0)) {
            const double az = std::atan2(y, x);
            if (last < 0.0 && az >= 0.0 && az - last < 1.0) ++current;
            last = az;
        }
        ring[static_cast<std::size_t>(k)] = current;
    }
    return ring;
}

// core/median.hpp's median of a copy; NaN for none.
double median_of(std::vector<double> v) {
    return v.empty() ? std::numeric_limits<double>::quiet_NaN() : median(v.begin(), v.end());
}

// The median elevation (deg) of each ring beyond 4 m; NaN for a ring without such points.
std::vector<double> ring_elevations(PointsView points, const std::vector<std::int32_t>& ring, int rings) {
    std::vector<std::vector<double>> el(static_cast<std::size_t>(rings));
    for (Eigen::Index k = 0; k < points.rows(); ++k) {
        const double x = points(k, 0), y = points(k, 1), z = points(k, 2), r = std::sqrt(x * x + y * y + z * z);
        const auto b = ring[static_cast<std::size_t>(k)];
        if (std::isfinite(r) && r >= 4.0 && b < rings) el[static_cast<std::size_t>(b)].push_back(deg(std::asin(z / r)));
    }
    std::vector<double> out;
    for (auto& e : el) out.push_back(median_of(std::move(e)));
    return out;
}

// Whether a frame lists exactly `beams` rings in scan order, from the top beam down (their median elevations
// fall from ring to ring); fills `ring` (per point) and `elevations` (per ring).
bool in_scan_order(PointsView points, int beams, std::vector<std::int32_t>& ring, std::vector<double>& elevations) {
    ring = rings_in_order(points);
    if (ring.empty() || ring.back() + 1 != beams) return false;
    elevations = ring_elevations(points, ring, beams);
    double above = INFINITY;
    for (double e : elevations) {
        if (std::isnan(e)) continue;
        if (!(e < above)) return false;
        above = e;
    }
    return true;
}

}  // namespace

BeamCalibration read_beam_calibration(const std::string& path) {
    require_input_file<std::runtime_error>(path, "beams file");
    BeamCalibration c;
    c.source = path;
    try {
        const YAML::Node root = YAML::LoadFile(path);
        if (!root["format"] || root["format"].as<std::string>() != kFormat)
            throw std::runtime_error(std::string("not a beams file (`format: ") + kFormat + "` missing)");
        const YAML::Node units = root["units"];  // written by roadpreview calibrate: degrees and metres
        if (units && ((units["angles"] && units["angles"].as<std::string>() != "deg") ||
                      (units["ranges"] && units["ranges"].as<std::string>() != "m")))
            throw std::runtime_error("units must be {angles: deg, ranges: m}");
        c.sensor_model = root["sensor_model"] ? root["sensor_model"].as<std::string>() : "";
        c.serial = root["serial"] ? root["serial"].as<std::string>() : "";
        c.beam_count = root["beam_count"].as<int>();
        const std::string index = root["beam_index"].as<std::string>();
        if (index != "decoder" && index != "elevation" && index != "scan_order")
            throw std::runtime_error("beam_index must be `decoder`, `elevation` or `scan_order`, got `" + index + "`");
        c.index = index == "elevation"    ? BeamIndexMethod::Elevation
                  : index == "scan_order" ? BeamIndexMethod::ScanOrder
                                          : BeamIndexMethod::Decoder;
        if (c.index == BeamIndexMethod::Elevation) {
            c.tilt_deg[0] = root["elevation_tilt_deg"][0].as<double>();
            c.tilt_deg[1] = root["elevation_tilt_deg"][1].as<double>();
            c.index_tolerance_deg = root["index_tolerance_deg"].as<double>();
        }
        const YAML::Node drive = root["drive"];
        if (drive) {
            c.frames = drive["frames"].as<std::int64_t>();
            c.travel_m = drive["travel_m"].as<double>();
            c.residual_m = drive["residual_m"].as<double>();
        }
        const YAML::Node beams = root["beams"];
        if (!beams || !beams.IsSequence() || static_cast<int>(beams.size()) != c.beam_count)
            throw std::runtime_error("`beams` must list beam_count = " + std::to_string(c.beam_count) + " beams");
        for (std::size_t b = 0; b < beams.size(); ++b) {
            if (beams[b]["beam"].as<std::size_t>() != b)
                throw std::runtime_error("beams must be listed in order; entry " + std::to_string(b) + " is beam " +
                                         beams[b]["beam"].as<std::string>());
            c.beams.push_back(read_beam(beams[b]));
            if (c.index == BeamIndexMethod::Elevation && !std::isfinite(c.beams.back().elevation_deg))
                throw std::runtime_error("beam " + std::to_string(b) + " has no elevation_deg (beam_index: elevation)");
        }
    } catch (const YAML::Exception& e) {
        throw std::runtime_error(path + ": invalid beams file: " + e.what());
    } catch (const std::runtime_error& e) {
        throw std::runtime_error(path + ": " + e.what());
    }
    return c;
}

std::string beam_calibration_to_yaml(const BeamCalibration& c) {
    YAML::Emitter e;
    e.SetDoublePrecision(8);
    e << YAML::BeginMap << YAML::Key << "format" << YAML::Value << kFormat;
    e << YAML::Key << "sensor_model" << YAML::Value << c.sensor_model;
    e << YAML::Key << "serial" << YAML::Value << YAML::DoubleQuoted << c.serial;
    e << YAML::Key << "beam_count" << YAML::Value << c.beam_count;
    e << YAML::Key << "units" << YAML::Value << YAML::Flow << YAML::BeginMap << YAML::Key << "angles"
      << YAML::Value << "deg" << YAML::Key << "ranges" << YAML::Value << "m" << YAML::EndMap;
    e << YAML::Key << "beam_index" << YAML::Value
      << (c.index == BeamIndexMethod::Elevation   ? "elevation"
          : c.index == BeamIndexMethod::ScanOrder ? "scan_order"
                                                  : "decoder");
    if (c.index == BeamIndexMethod::Elevation) {
        e << YAML::Key << "elevation_tilt_deg" << YAML::Value << YAML::Flow << YAML::BeginSeq << c.tilt_deg[0]
          << c.tilt_deg[1] << YAML::EndSeq;
        e << YAML::Key << "index_tolerance_deg" << YAML::Value << c.index_tolerance_deg;
    }
    e << YAML::Key << "drive" << YAML::Value << YAML::Flow << YAML::BeginMap << YAML::Key << "frames" << YAML::Value
      << c.frames << YAML::Key << "travel_m" << YAML::Value << c.travel_m << YAML::Key << "residual_m"
      << YAML::Value << c.residual_m << YAML::EndMap;
    e << YAML::Key << "beams" << YAML::Value << YAML::BeginSeq;
    for (std::size_t b = 0; b < c.beams.size(); ++b) {
        const BeamOffsets& o = c.beams[b];
        e << YAML::Flow << YAML::BeginMap << YAML::Key << "beam" << YAML::Value << b;
        e << YAML::Key << "determined" << YAML::Value << o.determined;
        e << YAML::Key << "elevation_offset_deg" << YAML::Value << o.elevation_offset_deg;
        e << YAML::Key << "elevation_sigma_deg" << YAML::Value;
        emit_number(e, o.elevation_sigma_deg);
        e << YAML::Key << "range_offset_m" << YAML::Value << o.range_offset_m;
        e << YAML::Key << "range_sigma_m" << YAML::Value;
        emit_number(e, o.range_sigma_m);
        e << YAML::Key << "observations" << YAML::Value << o.observations;
        if (c.index != BeamIndexMethod::Decoder) e << YAML::Key << "elevation_deg" << YAML::Value << o.elevation_deg;
        e << YAML::EndMap;
    }
    e << YAML::EndSeq << YAML::EndMap;
    return std::string(e.c_str()) + "\n";
}

void write_beam_calibration(const BeamCalibration& c, const std::string& path) {
    std::ofstream out(path);
    out << beam_calibration_to_yaml(c);
    out.flush();  // a full disk shows here, not in the destructor
    if (!out) throw std::runtime_error(path + ": cannot write the beams file");
}

std::vector<double> calibrated_beam_sigmas_deg(const BeamCalibration& c, double others_deg) {
    std::vector<double> sigmas;
    for (const BeamOffsets& b : c.beams)
        sigmas.push_back(b.determined && std::isfinite(b.elevation_sigma_deg) ? b.elevation_sigma_deg : others_deg);
    return sigmas;
}

void check_beam_calibration(const BeamCalibration& c, int beam_count, const std::string& sensor_model,
                            const std::string& serial) {
    const std::string name = c.source.empty() ? std::string("beam calibration") : c.source;
    if (c.beam_count != beam_count)
        throw std::runtime_error(name + ": a beams file for a " + std::to_string(c.beam_count) +
                                 "-beam sensor, but this one has " + std::to_string(beam_count) + " beams");
    if (!c.serial.empty() && !serial.empty() && c.serial != serial)
        throw std::runtime_error(name + ": a beams file for serial " + c.serial + ", but this sensor is " + serial);
    if (!c.sensor_model.empty() && !sensor_model.empty() && c.sensor_model != sensor_model)
        throw std::runtime_error(name + ": a beams file for a " + c.sensor_model + ", but this sensor is a " +
                                 sensor_model);
}

void find_beam_centres(const std::vector<PointsView>& frames, int beam_count, BeamCalibration& c) {
    // Scan order where every frame keeps it: exact, where elevations are not — a KITTI ring's elevation wanders
    // by up to 0.9° around the turn, more than the 0.33–0.5° between its beams (method.md §8).
    std::vector<std::vector<double>> elevations(frames.size());
    std::vector<std::int32_t> ring;
    bool ordered = !frames.empty();
    for (std::size_t f = 0; f < frames.size() && ordered; ++f)
        ordered = in_scan_order(frames[f], beam_count, ring, elevations[f]);
    if (ordered) {
        c.index = BeamIndexMethod::ScanOrder;
        c.tilt_deg[0] = c.tilt_deg[1] = 0.0;
        c.index_tolerance_deg = 0.0;
        c.beam_count = beam_count;
        c.beams.assign(static_cast<std::size_t>(beam_count), BeamOffsets{});
        for (std::size_t b = 0; b < c.beams.size(); ++b) {  // for information: the median over the frames
            std::vector<double> e;
            for (const auto& frame : elevations)
                if (!std::isnan(frame[b])) e.push_back(frame[b]);
            c.beams[b].elevation_deg = median_of(std::move(e));
        }
        return;
    }
    const auto samples = centre_samples(frames);
    if (samples.empty()) throw CalibrationError("no points ahead beyond 4 m to find the beams' elevations from");
    double lo = INFINITY, hi = -INFINITY;
    for (const CentreSample& s : samples) lo = std::min(lo, s.elevation_deg), hi = std::max(hi, s.elevation_deg);
    lo -= 1.0;
    const auto bins = static_cast<std::size_t>((hi + 1.0 - lo) / kHistogramStepDeg) + 1;
    // the common tilt that makes the rings sharpest: a 0.1° grid over t_c ∈ [−0.5, 0.5], t_s ∈ [−0.6, 0.6], then
    // 0.02° steps within ±0.1° of its best
    double best[2] = {0.0, 0.0};
    const auto search = [&](double a0, double a1, double b0, double b1, double step) {
        double best_sharpness = -1.0, found[2] = {best[0], best[1]};
        for (double a = a0; a <= a1 + 1e-9; a += step)
            for (double b = b0; b <= b1 + 1e-9; b += step) {
                const double tilt[2] = {a, b};
                const double s = sharpness(histogram(samples, tilt, lo, bins));
                if (s > best_sharpness) best_sharpness = s, found[0] = a, found[1] = b;
            }
        best[0] = found[0], best[1] = found[1];
    };
    search(-0.5, 0.5, -0.6, 0.6, 0.1);
    search(best[0] - 0.1, best[0] + 0.1, best[1] - 0.1, best[1] + 0.1, 0.02);
    const std::vector<double> h = histogram(samples, best, lo, bins);
    std::vector<std::size_t> peaks;  // local maxima, the beam_count tallest
    for (std::size_t k = 1; k + 1 < h.size(); ++k)
        if (h[k] > 0 && h[k] >= h[k - 1] && h[k] > h[k + 1]) peaks.push_back(k);
    std::sort(peaks.begin(), peaks.end(), [&](std::size_t a, std::size_t b) { return h[a] > h[b]; });
    std::vector<std::size_t> kept;  // a ring's histogram can show two maxima: the taller one stands for it
    for (std::size_t k : peaks)
        if (std::none_of(kept.begin(), kept.end(), [&](std::size_t q) {
                return std::abs(static_cast<double>(k) - static_cast<double>(q)) * kHistogramStepDeg < kMinBeamGapDeg;
            }))
            kept.push_back(k);
    peaks = kept;
    if (static_cast<int>(peaks.size()) < beam_count)
        throw CalibrationError("found " + std::to_string(peaks.size()) + " beam elevations in the points, expected " +
                               std::to_string(beam_count));
    peaks.resize(static_cast<std::size_t>(beam_count));
    std::sort(peaks.begin(), peaks.end(), std::greater<>());  // beam 0 at the top, as sensors number them
    c.index = BeamIndexMethod::Elevation;
    c.tilt_deg[0] = best[0];
    c.tilt_deg[1] = best[1];
    c.beam_count = beam_count;
    c.beams.assign(static_cast<std::size_t>(beam_count), BeamOffsets{});
    std::vector<double> gaps;
    for (std::size_t b = 0; b < peaks.size(); ++b) {
        c.beams[b].elevation_deg = lo + (static_cast<double>(peaks[b]) + 0.5) * kHistogramStepDeg;
        if (b) gaps.push_back(c.beams[b - 1].elevation_deg - c.beams[b].elevation_deg);
    }
    std::sort(gaps.begin(), gaps.end());
    c.index_tolerance_deg = gaps.empty() ? kMinBeamGapDeg : 0.5 * gaps[gaps.size() / 2];
}

void adopt_beam_indexing(BeamCalibration& out, const BeamCalibration& indexing) {
    if (indexing.beams.empty()) return;
    out.index = indexing.index;
    out.tilt_deg[0] = indexing.tilt_deg[0];
    out.tilt_deg[1] = indexing.tilt_deg[1];
    out.index_tolerance_deg = indexing.index_tolerance_deg;
    for (std::size_t b = 0; b < out.beams.size() && b < indexing.beams.size(); ++b)
        out.beams[b].elevation_deg = indexing.beams[b].elevation_deg;
}

std::vector<std::int32_t> beams_of_points(PointsView points, const BeamCalibration& c, const std::string& name) {
    if (c.index != BeamIndexMethod::ScanOrder) return beams_by_elevation(points, c);
    std::vector<std::int32_t> ring;
    std::vector<double> elevations;
    if (!in_scan_order(points, c.beam_count, ring, elevations))
        throw std::runtime_error(name + ": its points are not " + std::to_string(c.beam_count) +
                                 " rings in scan order, as the beams file " + c.source + " (beam_index: scan_order) needs");
    return ring;
}

std::vector<std::int32_t> beams_by_elevation(PointsView points, const BeamCalibration& c) {
    if (c.index != BeamIndexMethod::Elevation || c.beams.empty())
        throw std::invalid_argument(c.source + ": the beams file does not index beams by elevation");
    std::vector<double> centres;  // descending
    for (const BeamOffsets& b : c.beams) centres.push_back(b.elevation_deg);
    std::vector<std::int32_t> out(static_cast<std::size_t>(points.rows()), -1);
    for (Eigen::Index k = 0; k < points.rows(); ++k) {
        const double x = points(k, 0), y = points(k, 1), z = points(k, 2), r = std::sqrt(x * x + y * y + z * z);
        if (!(r > 0) || !std::isfinite(r)) continue;
        const double el = untilted_elevation_deg(deg(std::asin(z / r)), std::atan2(y, x), c.tilt_deg);
        const auto it = std::lower_bound(centres.begin(), centres.end(), el, std::greater<>());  // first ≤ el
        std::size_t best = 0;
        double best_d = INFINITY;
        for (auto cand : {it - centres.begin() - 1, it - centres.begin()}) {
            if (cand < 0 || cand >= static_cast<std::ptrdiff_t>(centres.size())) continue;
            const double d = std::abs(centres[static_cast<std::size_t>(cand)] - el);
            if (d < best_d) best_d = d, best = static_cast<std::size_t>(cand);
        }
        if (best_d <= c.index_tolerance_deg) out[static_cast<std::size_t>(k)] = static_cast<std::int32_t>(best);
    }
    return out;
}

void apply_beam_calibration(float* xyz, std::int64_t rows, std::int64_t stride, const std::vector<std::int32_t>& beams,
                            const BeamCalibration& c) {
    for (std::int64_t k = 0; k < rows; ++k) {
        const std::int32_t b = beams[static_cast<std::size_t>(k)];
        if (b < 0) continue;
        const BeamOffsets& o = c.beams[static_cast<std::size_t>(b)];
        float* p = xyz + k * stride;
        const double r = std::sqrt(double(p[0]) * p[0] + double(p[1]) * p[1] + double(p[2]) * p[2]);
        if (!(r > 0) || !std::isfinite(r)) continue;
        const double el = std::asin(p[2] / r) + rad(o.elevation_offset_deg), az = std::atan2(p[1], p[0]);
        const double range = r - o.range_offset_m;
        p[0] = static_cast<float>(range * std::cos(el) * std::cos(az));
        p[1] = static_cast<float>(range * std::cos(el) * std::sin(az));
        p[2] = static_cast<float>(range * std::sin(el));
    }
}

}  // namespace roadpreview
