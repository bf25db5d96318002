// SPDX-License-Identifier: BSD-3-Clause
// Packet layouts follow the Ouster sensor documentation ("Sensor Data", lidar and IMU packet formats);
// XYZ follows its "Lidar Range to XYZ" section, which the vendor SDK's XYZLut implements.
#include "roadpreview/io/ouster.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <fstream>
#include <limits>
#include <sstream>
#include <stdexcept>
#include <type_traits>
#include <utility>

#include <Eigen/Core>
#include <Eigen/LU>
#include <nlohmann/json.hpp>

#include "bytes.hpp"
#include "core/input_file.hpp"
#include "core/text.hpp"

namespace roadpreview {
namespace {

using json = nlohmann::json;

constexpr double kPi = 3.14159265358979323846;
constexpr double kStandardGravity = 9.80665;  // m/s² per g
constexpr int kMaxOusterRows = 512;            // beams: Ouster's largest sensors have 128

struct Layout {
    std::size_t packet_header, column_header, pixel, column_footer, packet_footer;
    std::uint32_t range_mask;
    int range_shift;  // left shift to millimetres (RNG15 profiles count 8 mm steps)
    std::size_t reflectivity_offset;
    bool reflectivity_16bit;
};

Layout layout_of(OusterProfile p) {
    switch (p) {
        case OusterProfile::Legacy:
            return {0, 16, 12, 4, 0, 0x000fffff, 0, 4, true};
        case OusterProfile::Rng19Rfl8Sig16Nir16:
            return {32, 12, 12, 0, 32, 0x0007ffff, 0, 4, false};
        case OusterProfile::Rng19Rfl8Sig16Nir16Dual:
            return {32, 12, 16, 0, 32, 0x0007ffff, 0, 3, false};
        case OusterProfile::Rng15Rfl8Nir8:
            return {32, 12, 4, 0, 32, 0x7fff, 3, 2, false};
        case OusterProfile::FusaRng15Rfl8Nir8Dual:
            return {32, 12, 8, 0, 32, 0x7fff, 3, 2, false};
    }
    throw std::logic_error("unknown Ouster profile");
}

std::size_t column_bytes(const Layout& l, int pixels) {
    return l.column_header + static_cast<std::size_t>(pixels) * l.pixel + l.column_footer;
}

OusterProfile profile_from(const std::string& name, const std::string& source) {
    for (auto p : {OusterProfile::Legacy, OusterProfile::Rng19Rfl8Sig16Nir16, OusterProfile::Rng19Rfl8Sig16Nir16Dual,
                   OusterProfile::Rng15Rfl8Nir8, OusterProfile::FusaRng15Rfl8Nir8Dual})
        if (name == to_string(p)) return p;
    throw std::runtime_error(source + ": udp_profile_lidar \"" + name +
                             "\" is not supported (LEGACY, RNG19_RFL8_SIG16_NIR16, RNG19_RFL8_SIG16_NIR16_DUAL, "
                             "RNG15_RFL8_NIR8, FUSA_RNG15_RFL8_NIR8_DUAL are)");
}

Mat4 identity4() { return {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1}; }

// The vendor's defaults for files that predate these fields (reduced legacy metadata).
double default_beam_origin_mm(const std::string& prod_line) {
    if (prod_line.rfind("OS-0-", 0) == 0) return 27.67;
    if (prod_line.rfind("OS-1-", 0) == 0) return 15.806;
    if (prod_line.rfind("OS-2-", 0) == 0) return 13.762;
    return 12.163;  // first-generation OS-1
}
const Mat4 kDefaultLidarToSensor = {-1, 0, 0, 0, 0, -1, 0, 0, 0, 0, 1, 36.18, 0, 0, 0, 1};
const Mat4 kDefaultImuToSensor = {1, 0, 0, 6.253, 0, 1, 0, -11.775, 0, 0, 1, 7.645, 0, 0, 0, 1};

// A field of the nested layout (section.key) or of the flat one (flat_section.key or key).
const json* find_field(const json& j, const char* section, const char* flat_section, const char* key) {
    for (const char* s : {section, flat_section}) {
        if (s && j.contains(s) && j[s].is_object() && j[s].contains(key)) return &j[s][key];
    }
    return j.contains(key) ? &j[key] : nullptr;
}

// An integer field's value out of its type's reach (parse_ouster_metadata adds the file's name).
struct FieldError : std::runtime_error {
    using std::runtime_error::runtime_error;
};

// nlohmann casts a JSON number to an integer unchecked: undefined for 1.9e83 into an int (fuzzing found it in
// pixel_shift_by_row). Integer fields must hold whole numbers within their type.
template <typename I>
bool fits(const json& v) {
    constexpr auto lo = static_cast<std::int64_t>(std::numeric_limits<I>::min());
    constexpr auto hi = static_cast<std::uint64_t>(std::numeric_limits<I>::max());
    if (v.is_number_unsigned()) return v.get<std::uint64_t>() <= hi;
    if (!v.is_number_integer()) return false;  // a float, whole or not
    const auto x = v.get<std::int64_t>();
    return x < 0 ? x >= lo : static_cast<std::uint64_t>(x) <= hi;
}

template <typename I>
void check_integer(const json& v, const char* key) {
    if (v.is_number() && !fits<I>(v))  // not a number at all: nlohmann's type error says so
        throw FieldError(std::string(key) + " must hold whole numbers from " + std::to_string(std::numeric_limits<I>::min()) +
                         " to " + std::to_string(std::numeric_limits<I>::max()) + ", got " + v.dump());
}

template <typename T>
T checked_get(const json& f, const char* key) {
    if constexpr (std::is_integral_v<T>) {
        check_integer<T>(f, key);
    } else if constexpr (std::is_same_v<T, std::vector<int>>) {
        if (f.is_array())
            for (const json& v : f) check_integer<int>(v, key);
    }
    return f.get<T>();
}

template <typename T>
T get_or(const json& j, const char* section, const char* flat_section, const char* key, T fallback) {
    const json* f = find_field(j, section, flat_section, key);
    return f && !f->is_null() ? checked_get<T>(*f, key) : fallback;
}

template <typename T>
T require_field(const json& j, const char* section, const char* flat_section, const char* key,
                const std::string& source) {
    const json* f = find_field(j, section, flat_section, key);
    if (!f || f->is_null()) throw std::runtime_error(source + ": Ouster metadata has no " + key);
    return checked_get<T>(*f, key);
}

Mat4 mat4_or(const json& j, const char* section, const char* key, const Mat4& fallback, const std::string& source) {
    const json* f = find_field(j, section, nullptr, key);
    if (!f) return fallback;
    const auto v = f->get<std::vector<double>>();
    if (v.size() != 16) throw std::runtime_error(source + ": " + key + " must hold 16 numbers (4×4 row-major)");
    Mat4 m{};
    std::copy(v.begin(), v.end(), m.begin());
    return m;
}

// "1024x10" → (1024, 10).
std::pair<int, double> parse_lidar_mode(const std::string& mode, const std::string& source) {
    const auto x = mode.find('x');
    if (x != std::string::npos) {
        const auto columns = parse_number(std::string_view(mode).substr(0, x));
        const auto hz = parse_number(std::string_view(mode).substr(x + 1));
        if (columns && hz && *columns == std::floor(*columns) && std::abs(*columns) < 1e9)
            return {static_cast<int>(*columns), *hz};
    }
    throw std::runtime_error(source + ": lidar_mode \"" + mode + "\" is not of the form COLUMNSxHZ (e.g. 1024x10)");
}

// A rigid transform in millimetres: finite, a rotation (orthonormal within 1e-3, not a reflection) and a translation
// within a metre (Ouster's own lie within centimetres).
bool rigid_mm(const Mat4& t) {
    const Eigen::Map<const Eigen::Matrix<double, 4, 4, Eigen::RowMajor>> m(t.data());
    if (!m.allFinite() || std::abs(m(3, 0)) + std::abs(m(3, 1)) + std::abs(m(3, 2)) > 0.0 || m(3, 3) != 1.0) return false;
    const Eigen::Matrix3d r = m.topLeftCorner<3, 3>();
    return (r * r.transpose() - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff() < 1e-3 && r.determinant() > 0.0 &&
           m.topRightCorner<3, 1>().cwiseAbs().maxCoeff() <= 1000.0;
}

void validate(const OusterMetadata& m) {
    const auto bad = [&](const std::string& what) { throw std::runtime_error(m.source + ": " + what); };
    const int H = m.pixels_per_column;
    if (H <= 0 || H > kMaxOusterRows)
        bad("pixels_per_column must be 1.." + std::to_string(kMaxOusterRows) + ", got " + std::to_string(H));
    if (!(m.frame_rate_hz > 0.0 && m.frame_rate_hz <= 100.0))
        bad("lidar_mode \"" + m.lidar_mode + "\" gives a frame rate of " + number_text(m.frame_rate_hz) + " Hz");
    for (const auto& [name, angles] : {std::pair{"beam_altitude_angles", &m.beam_altitude_deg},
                                       std::pair{"beam_azimuth_angles", &m.beam_azimuth_deg}})
        for (const double a : *angles)
            if (!(std::abs(a) <= 180.0)) bad(std::string(name) + " must lie within ±180°, got " + number_text(a));
    for (const auto& [name, t] : {std::pair{"beam_to_lidar_transform", &m.beam_to_lidar},
                                  std::pair{"lidar_to_sensor_transform", &m.lidar_to_sensor},
                                  std::pair{"imu_to_sensor_transform", &m.imu_to_sensor}})
        if (!rigid_mm(*t))
            bad(std::string(name) + " must be a rigid transform in mm (a rotation, a translation within 1 m, last "
                                    "row 0 0 0 1)");
    for (const auto& [name, port] : {std::pair{"udp_port_lidar", m.udp_port_lidar}, std::pair{"udp_port_imu", m.udp_port_imu}})
        if (port < 0 || port > 65535) bad(std::string(name) + " must be 0..65535, got " + std::to_string(port));
    const int W = m.columns_per_frame;
    if (W != 512 && W != 1024 && W != 2048 && W != 4096)
        bad("columns_per_frame must be 512, 1024, 2048 or 4096, got " + std::to_string(W));
    if (m.columns_per_packet <= 0 || m.columns_per_packet > W)
        bad("columns_per_packet must be 1.." + std::to_string(W) + ", got " + std::to_string(m.columns_per_packet));
    if (static_cast<int>(m.beam_altitude_deg.size()) != H || static_cast<int>(m.beam_azimuth_deg.size()) != H)
        bad("beam_altitude_angles and beam_azimuth_angles must have pixels_per_column = " + std::to_string(H) +
            " entries, got " + std::to_string(m.beam_altitude_deg.size()) + " and " +
            std::to_string(m.beam_azimuth_deg.size()));
    if (static_cast<int>(m.pixel_shift_by_row.size()) != H)
        bad("pixel_shift_by_row must have " + std::to_string(H) + " entries");
    for (int u = 0; u < H; ++u) {
        const int shift = m.pixel_shift_by_row[static_cast<std::size_t>(u)];
        if (shift <= -W || shift >= W)
            bad("pixel_shift_by_row must lie within ±" + std::to_string(W - 1) + " (columns_per_frame − 1), got " +
                std::to_string(shift) + " for row " + std::to_string(u));
    }
    for (int c : m.column_window)
        if (c < 0 || c >= W) bad("column_window must lie in 0.." + std::to_string(W - 1));
    if (m.lidar_packet_bytes() > 65507) bad("the lidar packet would exceed a UDP datagram");
}

}  // namespace

const char* to_string(OusterProfile p) {
    switch (p) {
        case OusterProfile::Legacy: return "LEGACY";
        case OusterProfile::Rng19Rfl8Sig16Nir16: return "RNG19_RFL8_SIG16_NIR16";
        case OusterProfile::Rng19Rfl8Sig16Nir16Dual: return "RNG19_RFL8_SIG16_NIR16_DUAL";
        case OusterProfile::Rng15Rfl8Nir8: return "RNG15_RFL8_NIR8";
        case OusterProfile::FusaRng15Rfl8Nir8Dual: return "FUSA_RNG15_RFL8_NIR8_DUAL";
    }
    return "?";
}

std::size_t OusterMetadata::lidar_packet_bytes() const {
    const Layout l = layout_of(profile);
    return l.packet_header + static_cast<std::size_t>(columns_per_packet) * column_bytes(l, pixels_per_column) +
           l.packet_footer;
}

int OusterMetadata::window_columns() const {
    const int a = column_window[0], b = column_window[1];
    return a <= b ? b - a + 1 : columns_per_frame - a + b + 1;
}

OusterMetadata parse_ouster_metadata(const std::string& json_text, const std::string& source) {
    OusterMetadata m;
    m.source = source;
    try {
        const json j = json::parse(json_text);
        if (!j.is_object()) throw std::runtime_error(source + ": Ouster metadata must be a JSON object");
        // Nested (firmware 2.x/3.x) sections first, then the flat layout's data_format / top level.
        m.prod_line = get_or<std::string>(j, "sensor_info", nullptr, "prod_line", "");
        const json* sn = find_field(j, "sensor_info", nullptr, "prod_sn");
        if (sn && !sn->is_null())
            m.prod_sn = sn->is_string() ? sn->get<std::string>() : std::to_string(checked_get<std::uint64_t>(*sn, "prod_sn"));
        m.init_id = get_or<std::uint32_t>(j, "sensor_info", nullptr, "initialization_id", 0);
        m.lidar_mode = require_field<std::string>(j, "config_params", nullptr, "lidar_mode", source);
        const auto [mode_columns, rate] = parse_lidar_mode(m.lidar_mode, source);
        m.frame_rate_hz = rate;
        m.profile = profile_from(get_or<std::string>(j, "lidar_data_format", "data_format", "udp_profile_lidar", "LEGACY"), source);
        m.beam_altitude_deg = require_field<std::vector<double>>(j, "beam_intrinsics", nullptr, "beam_altitude_angles", source);
        m.beam_azimuth_deg = require_field<std::vector<double>>(j, "beam_intrinsics", nullptr, "beam_azimuth_angles", source);
        m.pixels_per_column = get_or<int>(j, "lidar_data_format", "data_format", "pixels_per_column",
                                          static_cast<int>(m.beam_altitude_deg.size()));
        m.columns_per_packet = get_or<int>(j, "lidar_data_format", "data_format", "columns_per_packet", 16);
        m.columns_per_frame = get_or<int>(j, "lidar_data_format", "data_format", "columns_per_frame", mode_columns);
        const auto window = get_or<std::vector<int>>(j, "lidar_data_format", "data_format", "column_window",
                                                     {0, m.columns_per_frame - 1});
        if (window.size() != 2) throw std::runtime_error(source + ": column_window must hold 2 numbers");
        m.column_window = {window[0], window[1]};
        // The default sized by pixels_per_column only once that is known to be sane (validate says why not).
        const bool sane_rows = m.pixels_per_column > 0 && m.pixels_per_column <= kMaxOusterRows;
        m.pixel_shift_by_row = get_or<std::vector<int>>(
            j, "lidar_data_format", "data_format", "pixel_shift_by_row",
            std::vector<int>(sane_rows ? static_cast<std::size_t>(m.pixels_per_column) : 0, 0));
        Mat4 beam = identity4();
        beam[3] = get_or<double>(j, "beam_intrinsics", nullptr, "lidar_origin_to_beam_origin_mm",
                                 default_beam_origin_mm(m.prod_line));
        m.beam_to_lidar = mat4_or(j, "beam_intrinsics", "beam_to_lidar_transform", beam, source);
        m.lidar_to_sensor = mat4_or(j, "lidar_intrinsics", "lidar_to_sensor_transform", kDefaultLidarToSensor, source);
        m.imu_to_sensor = mat4_or(j, "imu_intrinsics", "imu_to_sensor_transform", kDefaultImuToSensor, source);
        m.udp_port_lidar = get_or<int>(j, "config_params", nullptr, "udp_port_lidar", 0);
        m.udp_port_imu = get_or<int>(j, "config_params", nullptr, "udp_port_imu", 0);
    } catch (const json::exception& e) {
        throw std::runtime_error(source + ": not valid Ouster metadata (" + e.what() + ")");
    } catch (const FieldError& e) {
        throw std::runtime_error(source + ": " + e.what());
    }
    validate(m);
    return m;
}

OusterMetadata read_ouster_metadata(const std::string& path) {
    require_input_file<std::runtime_error>(path, "Ouster metadata file");
    std::ifstream in(path);
    if (!in) throw std::runtime_error(path + ": cannot open Ouster metadata file");
    std::stringstream text;
    text << in.rdbuf();
    return parse_ouster_metadata(text.str(), path);
}

ImuSample decode_ouster_imu(const std::uint8_t* data, std::size_t size, double capture_time, const Mat4& imu_to_sensor) {
    if (size != kOusterImuPacketBytes)
        throw std::invalid_argument("IMU packet of " + std::to_string(size) + " bytes, expected 48");
    ImuSample s;
    s.timestamp = capture_time;
    for (int r = 0; r < 3; ++r) {
        for (int c = 0; c < 3; ++c) {
            const double R = imu_to_sensor[static_cast<std::size_t>(4 * r + c)];
            s.linear_acceleration[r] += R * read_le<float>(data + 24 + 4 * c) * kStandardGravity;
            s.angular_velocity[r] += R * read_le<float>(data + 36 + 4 * c) * kPi / 180.0;
        }
    }
    return s;
}

OusterDecoder::OusterDecoder(OusterMetadata meta) : meta_(std::move(meta)) {
    validate(meta_);
    const int H = meta_.pixels_per_column, W = meta_.columns_per_frame;
    // validate() holds every shift within ±(W − 1).
    for (const int shift : meta_.pixel_shift_by_row) row_shift_.push_back(shift < 0 ? shift + W : shift);
    const std::size_t pixels = static_cast<std::size_t>(H) * static_cast<std::size_t>(W);
    lut_.direction.resize(3 * pixels);
    lut_.offset.resize(3 * pixels);
    const Mat4& B = meta_.beam_to_lidar;
    const Mat4& T = meta_.lidar_to_sensor;
    const double beam_x = B[3], beam_z = B[11];
    const double beam_dist = beam_z != 0.0 ? std::hypot(beam_x, beam_z) : beam_x;
    // Each column's encoder angle and each beam's altitude: their cosines and sines once, not at every pixel.
    std::vector<double> encoder(static_cast<std::size_t>(W)), cos_encoder(encoder.size()), sin_encoder(encoder.size());
    for (std::size_t v = 0; v < encoder.size(); ++v) {
        encoder[v] = 2.0 * kPi * (1.0 - static_cast<double>(v) / W);
        cos_encoder[v] = std::cos(encoder[v]);
        sin_encoder[v] = std::sin(encoder[v]);
    }
    for (int u = 0; u < H; ++u) {
        const double azimuth = -meta_.beam_azimuth_deg[static_cast<std::size_t>(u)] * kPi / 180.0;
        const double altitude = meta_.beam_altitude_deg[static_cast<std::size_t>(u)] * kPi / 180.0;
        const double cos_altitude = std::cos(altitude), sin_altitude = std::sin(altitude);
        for (int v = 0; v < W; ++v) {
            const auto c = static_cast<std::size_t>(v);
            const double d[3] = {std::cos(encoder[c] + azimuth) * cos_altitude,
                                 std::sin(encoder[c] + azimuth) * cos_altitude, sin_altitude};
            const double o[3] = {cos_encoder[c] * beam_x - d[0] * beam_dist,
                                 sin_encoder[c] * beam_x - d[1] * beam_dist, -d[2] * beam_dist + beam_z};
            const std::size_t i = 3 * lut_pixel(u, v);
            const double range_offset_mm = meta_.beam_range_offset_m.empty()
                                               ? 0.0 : 1e3 * meta_.beam_range_offset_m[static_cast<std::size_t>(u)];
            for (int r = 0; r < 3; ++r) {
                const double* R = &T[static_cast<std::size_t>(4 * r)];
                const double direction = R[0] * d[0] + R[1] * d[1] + R[2] * d[2];
                lut_.direction[i + r] = static_cast<float>(1e-3 * direction);
                lut_.offset[i + r] = static_cast<float>(
                    1e-3 * (R[0] * o[0] + R[1] * o[1] + R[2] * o[2] + R[3] - direction * range_offset_mm));
            }
        }
    }
    xyzr_.resize(4 * pixels);
    returned_.resize(pixels);
    column_state_.assign(static_cast<std::size_t>(W), 0);
    closed_state_.assign(static_cast<std::size_t>(W), 0);
    column_ns_.assign(static_cast<std::size_t>(W), 0);
}

void OusterDecoder::check_header(const std::uint8_t* data) const {
    if (meta_.profile == OusterProfile::Legacy || meta_.prod_sn.empty()) return;
    const std::size_t at = meta_.profile == OusterProfile::FusaRng15Rfl8Nir8Dual ? 11 : 7;
    std::uint64_t sn = 0;
    std::memcpy(&sn, data + at, 5);  // 40-bit serial number
    if (sn != 0 && std::to_string(sn) != meta_.prod_sn)
        throw std::invalid_argument("packet from sensor serial " + std::to_string(sn) + ", but " + meta_.source +
                                    " describes serial " + meta_.prod_sn + ": the metadata belongs to another sensor");
}

// Catches metadata whose columns_per_frame or rate does not match the recording: the measured time between
// columns must be the metadata's 1 / (rate × columns_per_frame).
void OusterDecoder::check_column_spacing(const std::uint8_t* data) {
    if (spacing_checked_ || meta_.frame_rate_hz <= 0.0) return;
    const Layout l = layout_of(meta_.profile);
    const std::size_t col_bytes = column_bytes(l, meta_.pixels_per_column);
    const std::uint8_t* a = data + l.packet_header;
    const std::uint8_t* b = a + (meta_.columns_per_packet - 1) * col_bytes;
    const int steps = read_le<std::uint16_t>(b + 8) - read_le<std::uint16_t>(a + 8);
    const auto ta = read_le<std::uint64_t>(a), tb = read_le<std::uint64_t>(b);
    if (steps <= 0 || ta == 0 || tb <= ta) return;  // one column per packet, a wrap, or no clock: try the next
    spacing_checked_ = true;
    const double measured_us = 1e-3 * static_cast<double>(tb - ta) / steps;
    const double expected_us = 1e6 / (meta_.frame_rate_hz * meta_.columns_per_frame);
    if (measured_us > 1.5 * expected_us || measured_us < expected_us / 1.5) {
        std::ostringstream msg;
        msg.precision(3);
        msg << "columns arrive " << measured_us << " µs apart, but " << meta_.source << " (lidar_mode "
            << meta_.lidar_mode << ", " << meta_.columns_per_frame << " columns per frame) implies " << expected_us
            << " µs: the metadata's column count or rate does not match the recording";
        throw std::invalid_argument(msg.str());
    }
}

void OusterDecoder::check_measurement_ids(const std::uint8_t* first_col, std::size_t col_bytes) const {
    for (int c = 0; c < meta_.columns_per_packet; ++c) {
        const int mid = read_le<std::uint16_t>(first_col + static_cast<std::size_t>(c) * col_bytes + 8);
        if (mid >= meta_.columns_per_frame)
            throw std::invalid_argument("measurement id " + std::to_string(mid) + " is beyond the " +
                                        std::to_string(meta_.columns_per_frame) + " columns per frame of " +
                                        meta_.source + ": the metadata's column count does not match the recording");
    }
}

void OusterDecoder::start_frame(std::int64_t id, double capture_time) {
    open_ = true;
    frame_id_ = id;
    frame_time_ = capture_time;
    first_column_ns_ = 0;
    std::fill(column_state_.begin(), column_state_.end(), 0);
    std::fill(returned_.begin(), returned_.end(), 0);
}

std::optional<Frame> OusterDecoder::add_packet(const std::uint8_t* data, std::size_t size, double capture_time) {
    const std::size_t expected = meta_.lidar_packet_bytes();
    if (size != expected)
        throw std::invalid_argument("lidar packet of " + std::to_string(size) + " bytes, but " + meta_.source + " (" +
                                    to_string(meta_.profile) + ", " + std::to_string(meta_.pixels_per_column) +
                                    " pixels × " + std::to_string(meta_.columns_per_packet) + " columns) implies " +
                                    std::to_string(expected) + ": the metadata does not match the recording");
    check_header(data);
    check_column_spacing(data);
    const Layout l = layout_of(meta_.profile);
    const std::size_t col_bytes = column_bytes(l, meta_.pixels_per_column);
    const std::uint8_t* first_col = data + l.packet_header;
    std::int64_t id = 0;
    switch (meta_.profile) {
        case OusterProfile::Legacy: id = read_le<std::uint16_t>(first_col + 10); break;
        case OusterProfile::FusaRng15Rfl8Nir8Dual: id = read_le<std::uint32_t>(data + 4); break;
        default: id = read_le<std::uint16_t>(data + 2); break;
    }
    check_measurement_ids(first_col, col_bytes);
    bool any_in_window = false;
    for (int c = 0; c < meta_.columns_per_packet && !any_in_window; ++c)
        any_in_window = in_window(read_le<std::uint16_t>(first_col + static_cast<std::size_t>(c) * col_bytes + 8));
    if (!any_in_window) {  // columns the window leaves out (keep_columns_reaching)
        ++outside_window_;
        return std::nullopt;
    }
    // A packet of the frame last returned (while no frame or the next is open): late, reordered on the way (its
    // columns are missing there, and counted so), or a copy (they are not) — unless it opens the column window:
    // then the same id came again, a sensor restarted or a capture of one frame looped.
    if (id == closed_id_ && !(open_ && id == frame_id_) && !opens_window(first_col, col_bytes)) {
        ++(closed_missing_any(first_col, col_bytes) ? late_packets_ : duplicate_packets_);
        return std::nullopt;
    }
    std::optional<Frame> done;
    if (open_ && id != frame_id_) done = build_frame();  // a new frame id, or an older one: the sensor restarted
    if (!open_) start_frame(id, capture_time);

    bool news = false, last_of_window = false;
    for (int c = 0; c < meta_.columns_per_packet; ++c) {
        const std::uint8_t* col = first_col + static_cast<std::size_t>(c) * col_bytes;
        const int mid = read_le<std::uint16_t>(col + 8);
        if (!in_window(mid)) continue;
        const std::uint32_t status = l.column_footer ? read_le<std::uint32_t>(col + col_bytes - 4)
                                                     : read_le<std::uint16_t>(col + 10);
        const auto ts = read_le<std::uint64_t>(col);
        if (first_column_ns_ == 0) first_column_ns_ = ts;
        column_ns_[static_cast<std::size_t>(mid)] = ts;
        news = news || column_state_[static_cast<std::size_t>(mid)] == 0;
        last_of_window = last_of_window || mid == meta_.column_window[1];
        if (!(status & 1u)) {
            column_state_[static_cast<std::size_t>(mid)] = 2;
            forget_column(mid);  // a valid copy of it may have come before
            continue;
        }
        column_state_[static_cast<std::size_t>(mid)] = 1;
        decode_column(col + l.column_header, mid);
    }
    if (!news) ++duplicate_packets_;
    // The window's last column closes the frame at once (no wait for the next frame's first packet: live latency).
    if (last_of_window && !done) done = build_frame();
    return done;
}

bool OusterDecoder::opens_window(const std::uint8_t* first_col, std::size_t col_bytes) const {
    for (int c = 0; c < meta_.columns_per_packet; ++c)
        if (read_le<std::uint16_t>(first_col + static_cast<std::size_t>(c) * col_bytes + 8) == meta_.column_window[0])
            return true;
    return false;
}

bool OusterDecoder::closed_missing_any(const std::uint8_t* first_col, std::size_t col_bytes) const {
    for (int c = 0; c < meta_.columns_per_packet; ++c) {
        const int mid = read_le<std::uint16_t>(first_col + static_cast<std::size_t>(c) * col_bytes + 8);
        if (in_window(mid) && closed_state_[static_cast<std::size_t>(mid)] == 0) return true;
    }
    return false;
}

void OusterDecoder::decode_column(const std::uint8_t* px, int column) {
    const Layout l = layout_of(meta_.profile);
    const int H = meta_.pixels_per_column, W = meta_.columns_per_frame;
    for (int u = 0; u < H; ++u, px += l.pixel) {
        const std::size_t i = lut_pixel(u, column);
        const std::size_t at = static_cast<std::size_t>(u) * W + static_cast<std::size_t>(destaggered(u, column));
        const std::uint32_t range_mm = (read_le<std::uint32_t>(px) & l.range_mask) << l.range_shift;
        const float r = static_cast<float>(range_mm);
        const float* direction = &lut_.direction[3 * i];
        const float* offset = &lut_.offset[3 * i];
        float* out = &xyzr_[4 * at];
        for (int c = 0; c < 3; ++c) out[c] = direction[c] * r + offset[c];
        out[3] = static_cast<float>(l.reflectivity_16bit ? read_le<std::uint16_t>(px + l.reflectivity_offset)
                                                         : px[l.reflectivity_offset]);
        returned_[at] = range_mm != 0;
    }
}

void OusterDecoder::forget_column(int column) {
    const int H = meta_.pixels_per_column, W = meta_.columns_per_frame;
    for (int u = 0; u < H; ++u)
        returned_[static_cast<std::size_t>(u) * W + static_cast<std::size_t>(destaggered(u, column))] = 0;
}

std::size_t OusterDecoder::lut_pixel(int u, int column) const {
    return static_cast<std::size_t>(column) * static_cast<std::size_t>(meta_.pixels_per_column) +
           static_cast<std::size_t>(u);
}

bool OusterDecoder::in_window(int column) const {
    const int a = meta_.column_window[0], b = meta_.column_window[1];
    return a <= b ? column >= a && column <= b : column >= a || column <= b;
}

std::string OusterDecoder::keep_columns_reaching(const std::vector<SensorRoi>& regions) {
    const int H = meta_.pixels_per_column, W = meta_.columns_per_frame, first = meta_.column_window[0];
    std::vector<RigidTransform> sensor_to_base;
    for (const SensorRoi& roi : regions) sensor_to_base.push_back(to_rigid_transform(roi.sensor));
    const auto reaches = [&](int v) {
        for (std::size_t r = 0; r < regions.size(); ++r) {
            for (int u = 0; u < H; ++u) {
                const std::size_t i = 3 * lut_pixel(u, v);
                const double origin[3] = {lut_.offset[i], lut_.offset[i + 1], lut_.offset[i + 2]};
                const double direction[3] = {lut_.direction[i], lut_.direction[i + 1], lut_.direction[i + 2]};
                if (ray_reaches(regions[r], sensor_to_base[r], origin, direction)) return true;
            }
        }
        return false;
    };
    int from = -1, to = -1;  // in window order: k-th column sent = (first + k) mod W
    for (int k = 0; k < meta_.window_columns(); ++k) {
        if (!reaches((first + k) % W)) continue;
        if (from < 0) from = k;
        to = k;
    }
    if (from < 0)
        throw std::invalid_argument(meta_.source + ": no column of the sensor's window (" + std::to_string(first) +
                                    "–" + std::to_string(meta_.column_window[1]) +
                                    ") can see the region of interest: check the sensor's mounting");
    const int sent = meta_.window_columns();
    if (to - from + 1 == sent)
        return "every column decoded: the region of interest (roi_columns) is seen at both ends of the sensor's frame";
    meta_.column_window = {(first + from) % W, (first + to) % W};
    return "columns " + std::to_string(meta_.column_window[0]) + "–" + std::to_string(meta_.column_window[1]) +
           " decoded, " + std::to_string(to - from + 1) + " of the " + std::to_string(sent) +
           " the sensor sends: those that can see the region of interest (roi_columns)";
}

std::int64_t OusterDecoder::missing_run(bool from_start) const {
    const int W = meta_.columns_per_frame, n = meta_.window_columns();
    std::int64_t run = 0;
    for (int k = 0; k < n; ++k) {
        const int v = (meta_.column_window[0] + (from_start ? k : n - 1 - k)) % W;
        if (column_state_[static_cast<std::size_t>(v)] != 0) break;
        ++run;
    }
    return run;
}

Frame OusterDecoder::build_frame(bool at_end) {
    const int H = meta_.pixels_per_column, W = meta_.columns_per_frame;
    Frame f;
    f.frame_id = frame_id_;
    f.timestamp = frame_time_;
    f.imu = std::move(imu_);
    imu_.clear();
    for (int k = 0, v = meta_.column_window[0]; k < meta_.window_columns(); ++k, v = (v + 1) % W)
        if (column_state_[static_cast<std::size_t>(v)] == 0) ++f.diagnostics.missing_columns;
    for (std::uint8_t s : column_state_)
        if (s == 2) ++f.diagnostics.invalid_columns;
    f.diagnostics.complete = f.diagnostics.missing_columns == 0;
    // A capture (or a stream) begins and ends within frames: those columns were never sent to it, not lost.
    const std::int64_t cut = (built_any_ ? 0 : missing_run(true)) + (at_end ? missing_run(false) : 0);
    f.diagnostics.cut_columns = std::min(cut, f.diagnostics.missing_columns);
    built_any_ = true;
    const std::int64_t lost_columns = f.diagnostics.missing_columns - f.diagnostics.cut_columns;
    f.diagnostics.lost_packets = (lost_columns + meta_.columns_per_packet - 1) / meta_.columns_per_packet;
    f.diagnostics.late_packets = std::exchange(late_packets_, 0);
    f.diagnostics.duplicate_packets = std::exchange(duplicate_packets_, 0);

    // Each column's time since the frame's first, once per column rather than once per pixel.
    column_s_.resize(static_cast<std::size_t>(W));
    for (std::size_t v = 0; v < column_s_.size(); ++v)
        column_s_[v] =
            static_cast<float>(1e-9 * static_cast<double>(static_cast<std::int64_t>(column_ns_[v] - first_column_ns_)));
    const auto n = static_cast<Eigen::Index>(std::count(returned_.begin(), returned_.end(), 1));
    f.points.resize(n, 4);
    f.point_times.resize(static_cast<std::size_t>(n));
    f.beams.resize(static_cast<std::size_t>(n));
    // The pixels in destaggered order (staggered column v = v_d − shift[u] mod W), copied without a branch: every
    // pixel is written, a returned one as the next point, the others into a sink (the pattern of returns is
    // irregular, a branch on it mispredicted). Only the column window's pixels can have returned: in each row they
    // are one run of destaggered columns, or two when the run passes the row's end.
    float* const points = f.points.data();  // row-major n × 4
    std::int32_t* const beams = f.beams.data();
    float* const times = f.point_times.data();
    float sink_point[4], sink_time;
    std::int32_t sink_beam;
    const float* column_s = column_s_.data();
    const int span = meta_.window_columns();
    Eigen::Index k = 0;
    const auto copy_run = [&](int u, int first_vd, int last_vd) {  // [first_vd, last_vd)
        const std::size_t at = static_cast<std::size_t>(u) * static_cast<std::size_t>(W);
        const float* xyzr = xyzr_.data() + 4 * (at + static_cast<std::size_t>(first_vd));
        const std::uint8_t* returned = returned_.data() + at + static_cast<std::size_t>(first_vd);
        for (int vd = first_vd, v = (first_vd - destaggered(u, 0) + W) % W; vd < last_vd; ++vd, ++v, xyzr += 4,
                 ++returned) {
            if (v == W) v = 0;
            const bool keep = *returned;
            std::copy_n(xyzr, 4, keep ? points + 4 * k : sink_point);
            *(keep ? beams + k : &sink_beam) = u;
            *(keep ? times + k : &sink_time) = column_s[v];
            k += keep;
        }
    };
    for (int u = 0; u < H; ++u) {
        const int first = destaggered(u, meta_.column_window[0]);
        if (first + span > W) copy_run(u, 0, first + span - W);
        copy_run(u, first, std::min(first + span, W));
    }
    open_ = false;
    closed_id_ = frame_id_;
    closed_state_ = column_state_;  // the same size every frame: a copy, no allocation
    return f;
}

std::optional<Frame> OusterDecoder::finish() {
    if (!open_) return std::nullopt;
    return build_frame(true);
}

}  // namespace roadpreview
