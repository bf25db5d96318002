// SPDX-License-Identifier: BSD-3-Clause
// Ouster OS sensors: metadata JSON (legacy flat and firmware 2.x/3.x nested layouts), lidar packet
// profiles, XYZ from the beam intrinsics, frames assembled by frame id, IMU packets.
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "roadpreview/core/frames.hpp"
#include "roadpreview/io/frame_source.hpp"

namespace roadpreview {

enum class OusterProfile { Legacy, Rng19Rfl8Sig16Nir16, Rng19Rfl8Sig16Nir16Dual, Rng15Rfl8Nir8, FusaRng15Rfl8Nir8Dual };

/// The name the metadata uses ("LEGACY", "RNG15_RFL8_NIR8", ...).
const char* to_string(OusterProfile p);

using Mat4 = std::array<double, 16>;  ///< row-major 4×4 homogeneous transform, translation in mm

struct OusterMetadata {
    std::string source;     ///< the JSON file, for messages
    std::string prod_line;  ///< e.g. "OS-1-128"; empty in reduced legacy files
    std::string prod_sn;    ///< serial number; empty when unknown
    std::uint32_t init_id = 0;  ///< initialization id; 0 when unknown
    std::string lidar_mode;     ///< e.g. "1024x10"
    double frame_rate_hz = 0.0; ///< from lidar_mode; 0 when unknown
    OusterProfile profile = OusterProfile::Legacy;
    int pixels_per_column = 0;   ///< beams
    int columns_per_packet = 16;
    int columns_per_frame = 0;   ///< 512, 1024, 2048 or 4096
    std::array<int, 2> column_window{0, 0};  ///< first and last measurement id sent (may wrap)
    std::vector<int> pixel_shift_by_row;     ///< destagger shift per beam (zeros when unknown)
    std::vector<double> beam_altitude_deg;   ///< per beam, from the top beam down
    std::vector<double> beam_azimuth_deg;
    std::vector<double> beam_range_offset_m; ///< per beam, subtracted from its ranges (beam calibration); empty: none
    Mat4 beam_to_lidar{};    ///< beam origin in the lidar frame (mm)
    Mat4 lidar_to_sensor{};  ///< lidar frame → sensor frame (mm)
    Mat4 imu_to_sensor{};    ///< IMU frame → sensor frame (mm)
    int udp_port_lidar = 0;  ///< 0: not in the metadata
    int udp_port_imu = 0;

    std::size_t lidar_packet_bytes() const;
    int window_columns() const;  ///< columns per frame inside the column window
};

/// Parses either layout. Throws std::runtime_error naming `source` and the missing or invalid field.
OusterMetadata parse_ouster_metadata(const std::string& json_text, const std::string& source);
OusterMetadata read_ouster_metadata(const std::string& path);

/// Bytes of one Ouster IMU packet.
inline constexpr std::size_t kOusterImuPacketBytes = 48;

/// Gyro and accelerometer of one IMU packet, rotated into the sensor frame. Throws std::invalid_argument
/// for a packet of the wrong size.
ImuSample decode_ouster_imu(const std::uint8_t* data, std::size_t size, double capture_time, const Mat4& imu_to_sensor);

/// Turns lidar packets into frames. Points are in the sensor frame (m) with reflectivity as the fourth
/// channel, ordered by beam then destaggered column, only valid columns and non-zero ranges.
class OusterDecoder {
public:
    explicit OusterDecoder(OusterMetadata meta);

    /// Adds one lidar packet. Returns the frame it completes: the previous one when this packet starts a new
    /// frame id (or an older one: the sensor restarted), this one when it holds the column window's last column.
    /// A packet of the frame just returned (it came late) is dropped and counted in the next frame's diagnostics.
    /// Throws std::invalid_argument describing the problem when the packet does not fit the metadata
    /// (size, measurement id, serial number, column spacing).
    std::optional<Frame> add_packet(const std::uint8_t* data, std::size_t size, double capture_time);
    /// Attaches an IMU reading to the frame being assembled.
    void add_imu(const ImuSample& s) { imu_.push_back(s); }
    /// The frame being assembled, if any (call at the end of the input).
    std::optional<Frame> finish();

    const OusterMetadata& metadata() const { return meta_; }

    /// Narrows the column window (metadata().column_window) to the columns, in the order the window sends them,
    /// from the first to the last with a beam that can reach one of `regions` (SourceOptions::roi_columns):
    /// columns outside it are not decoded and the frame ends at its last. Returns a note for the user saying
    /// which columns are kept. Throws std::invalid_argument naming the metadata when no column can reach them.
    std::string keep_columns_reaching(const std::vector<SensorRoi>& regions);
    /// Lidar packets whose every column lay outside the column window (left out, not counted as late).
    std::int64_t packets_outside_window() const { return outside_window_; }

private:
    struct Lut {  // by column, then beam (lut_pixel): a column's pixels decode from consecutive entries
        std::vector<float> direction;  // 3 per pixel, m per mm of range
        std::vector<float> offset;     // 3 per pixel, m
    };
    void check_header(const std::uint8_t* data) const;
    void check_column_spacing(const std::uint8_t* data);
    void check_measurement_ids(const std::uint8_t* first_col, std::size_t col_bytes) const;
    void start_frame(std::int64_t id, double capture_time);
    /// The pixels of one valid staggered column (its first pixel at `pixels`) into xyzr_ and returned_.
    void decode_column(const std::uint8_t* pixels, int column);
    /// A column found invalid: none of its pixels returned.
    void forget_column(int column);
    /// The lookup table's pixel of beam u in staggered column `column`.
    std::size_t lut_pixel(int u, int column) const;
    /// The destaggered column of row u's pixel of staggered column `column` (0 ≤ column < W): column + shift[u]
    /// (mod W), without a division per pixel.
    int destaggered(int u, int column) const {
        const int vd = column + row_shift_[static_cast<std::size_t>(u)];
        return vd >= meta_.columns_per_frame ? vd - meta_.columns_per_frame : vd;
    }
    /// The frame assembled; `at_end`: the input ends with it (its missing last columns were cut, not lost).
    Frame build_frame(bool at_end = false);
    /// Missing columns (column_state_ 0) at the start of the window (`from_start`) or at its end, up to the first
    /// column received.
    std::int64_t missing_run(bool from_start) const;
    bool in_window(int column) const;
    /// Whether the packet (its first column at `first_col`) holds the column window's first column.
    bool opens_window(const std::uint8_t* first_col, std::size_t col_bytes) const;
    /// Whether a column of the packet in the window was missing from the frame last returned.
    bool closed_missing_any(const std::uint8_t* first_col, std::size_t col_bytes) const;

    OusterMetadata meta_;
    Lut lut_;
    std::vector<int> row_shift_;  // pixel_shift_by_row taken into [0, W)
    bool open_ = false;
    bool spacing_checked_ = false;
    std::int64_t frame_id_ = -1;
    std::int64_t closed_id_ = -1;  // the frame last returned
    bool built_any_ = false;       // a frame has been returned: the next no longer began with the input
    std::int64_t late_packets_ = 0, duplicate_packets_ = 0;  // since the last frame returned
    std::int64_t outside_window_ = 0;
    double frame_time_ = 0.0;
    std::uint64_t first_column_ns_ = 0;
    // Beam × column, destaggered: each pixel's x, y, z and reflectivity, made as its column arrives (so that the
    // frame's last packet leaves only a copy to do), and whether it returned (a valid column, a range > 0).
    std::vector<float> xyzr_;
    std::vector<std::uint8_t> returned_;
    std::vector<std::uint8_t> column_state_;  // 0 missing, 1 valid, 2 invalid
    std::vector<std::uint8_t> closed_state_;  // column_state_ of the frame last returned
    std::vector<std::uint64_t> column_ns_;
    std::vector<float> column_s_;  // each column's time since the frame's first, made when a frame is built
    std::vector<ImuSample> imu_;
};

}  // namespace roadpreview
