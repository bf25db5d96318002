// SPDX-License-Identifier: BSD-3-Clause
// Velodyne VLP-16, VLP-32C, HDL-32E and HDL-64E data packets (1206-byte UDP payloads): azimuth interpolated
// per firing, frames cut where the azimuth crosses a chosen angle, per-point times.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "roadpreview/core/frames.hpp"
#include "roadpreview/io/frame_source.hpp"

namespace roadpreview {

enum class VelodyneModel { Vlp16, Vlp32c, Hdl32e, Hdl64e };

const char* to_string(VelodyneModel m);  ///< "VLP-16", "VLP-32C", "HDL-32E", "HDL-64E"
/// Accepts those names (case-insensitive); throws std::invalid_argument listing them otherwise.
VelodyneModel velodyne_model_from_name(const std::string& name);

inline constexpr std::size_t kVelodynePacketBytes = 1206;

/// One laser's corrections, as in the ROS velodyne_pointcloud calibration files (metres, radians).
struct VelodyneLaser {
    double vert_correction = 0.0;    ///< elevation of the beam
    double rot_correction = 0.0;     ///< azimuth offset, subtracted from the firing's azimuth
    double dist_correction = 0.0;    ///< added to every range
    double vert_offset_correction = 0.0;
    double horiz_offset_correction = 0.0;
};

struct VelodyneCalibration {
    std::string source;  ///< file, or "built-in <model>"
    double distance_resolution_m = 0.002;
    std::vector<VelodyneLaser> lasers;
};

/// The manufacturer's nominal angles for VLP-16, VLP-32C and HDL-32E. HDL-64E units are calibrated one by
/// one: they need a calibration file (throws std::invalid_argument).
VelodyneCalibration default_velodyne_calibration(VelodyneModel m);
/// A ROS velodyne_pointcloud calibration YAML (`lasers:` with laser_id, vert_correction, rot_correction,
/// dist_correction, vert_offset_correction, horiz_offset_correction; `distance_resolution`).
/// The two-point near-range corrections and intensity fields are not used. Throws naming the file.
VelodyneCalibration read_velodyne_calibration(const std::string& path);

/// What the factory bytes (payload bytes 1204–1205) say.
struct VelodyneFactory {
    std::optional<VelodyneModel> model;  ///< nullopt: a product id this decoder does not know
    bool dual = false;                   ///< dual return mode (0x39)
    std::string return_mode;             ///< "strongest", "last", "dual" or "unknown (0x..)"
    int product_id = 0;
};
VelodyneFactory velodyne_factory(const std::uint8_t* packet);

/// The cut angle (deg, clockwise from ahead, as SourceOptions::cut_angle_deg) after which no firing's beams can reach
/// one of `regions` before the sweep ends: the first firing azimuth past the arc of those that can (0.1° steps),
/// so that the arc is scanned last and whole in every sweep (SourceOptions::roi_columns). nullopt when every
/// azimuth can; std::invalid_argument when none can.
std::optional<double> velodyne_cut_after(const std::vector<SensorRoi>& regions, const VelodyneCalibration& calibration);

/// µs between two data packets of `model` (12 blocks of firings; half the blocks in dual mode).
double velodyne_packet_period_us(VelodyneModel model, bool dual);

/// Microsecond timestamp of a data packet (µs past the hour).
std::uint32_t velodyne_packet_time_us(const std::uint8_t* packet);

/// Turns data packets into sweeps. Points are in the sensor frame with x forward, y left, z up (the
/// Velodyne manual's y-forward, x-right frame turned by 90°), reflectivity as the fourth channel; dual
/// return packets contribute their last return (even blocks).
class VelodyneDecoder {
public:
    /// Throws std::invalid_argument when the calibration does not fit the model.
    VelodyneDecoder(VelodyneModel model, VelodyneCalibration calibration, double cut_angle_deg = 0.0);

    /// Adds one data packet; sweeps it completes are appended to `done`. Throws std::invalid_argument
    /// for a packet of the wrong size or layout. A packet older than the previous one (reordered) or a duplicate
    /// is dropped and counted in the sweep's diagnostics; a jump back over 0.1 s or ahead over 1 s starts a new
    /// sweep (the sensor restarted).
    void add_packet(const std::uint8_t* data, std::size_t size, double capture_time, std::vector<Frame>& done);
    /// The sweep being assembled, if it has points (call at the end of the input).
    std::optional<Frame> finish();

    VelodyneModel model() const { return model_; }

private:
    struct Firing;
    void add_firing(const Firing& f, std::vector<Frame>& done);
    void close_sweep(bool at_cut, std::vector<Frame>& done);
    bool in_time_order(double t_us, bool dual, std::vector<Frame>& done);

    VelodyneModel model_;
    VelodyneCalibration calibration_;
    std::vector<double> cos_elevation_, sin_elevation_;  // of each laser's vert_correction, made once
    double cut_angle_deg_;
    double previous_relative_deg_ = -1.0;
    std::int64_t sweeps_ = 0;
    bool started_at_cut_ = false;
    // The sweep being assembled.
    std::vector<float> xyzi_;
    std::vector<float> times_;
    std::vector<std::int32_t> beams_;
    double sweep_time_ = 0.0;       // capture time of its first packet
    double sweep_first_us_ = 0.0;   // sensor time of its first firing
    double packet_capture_time_ = 0.0;
    double packet_us_ = -1.0;  // sensor time of the current packet, unwrapped across hours
    std::int64_t lost_packets_ = 0, late_packets_ = 0, duplicate_packets_ = 0;  // of the sweep being assembled
};

}  // namespace roadpreview
