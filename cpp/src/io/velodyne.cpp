// SPDX-License-Identifier: BSD-3-Clause
// Packet layout, firing timing and nominal angles from the Velodyne user manuals (VLP-16, VLP-32C, HDL-32E,
// HDL-64E S3); the per-laser correction formula is that of the ROS velodyne_pointcloud calibration files.
#include "roadpreview/io/velodyne.hpp"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <stdexcept>
#include <utility>

#include <yaml-cpp/yaml.h>

#include "bytes.hpp"
#include "core/input_file.hpp"
#include "core/text.hpp"

namespace roadpreview {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr int kBlocks = 12;
constexpr std::size_t kBlockBytes = 100;
constexpr int kChannelsPerBlock = 32;
constexpr double kHourUs = 3600e6;
constexpr double kMaxCorrectionM = 5.0;  // a laser's distance and offset corrections: centimetres in real files
constexpr std::size_t kMaxSweepPoints = 4'000'000;  // far beyond any real sweep: a sensor that stops turning

// How a model fires: lasers per firing sequence, sequences per 32-channel block, timing in µs.
struct FiringPattern {
    int lasers;           // lasers in one sequence
    int sequences;        // sequences per block (VLP-16 packs two)
    double block_us;      // time one block covers
    double sequence_us;   // time between sequences
    double laser_us;      // time between consecutive firings within a sequence
    int lasers_per_slot;  // lasers fired together (VLP-32C fires pairs)
};

FiringPattern pattern_of(VelodyneModel m) {
    switch (m) {
        case VelodyneModel::Vlp16: return {16, 2, 110.592, 55.296, 2.304, 1};
        case VelodyneModel::Vlp32c: return {32, 1, 55.296, 55.296, 2.304, 2};
        case VelodyneModel::Hdl32e: return {32, 1, 46.080, 46.080, 1.152, 1};
        case VelodyneModel::Hdl64e: return {64, 1, 0.0, 0.0, 0.0, 64};  // upper + lower block fire together
    }
    throw std::logic_error("unknown Velodyne model");
}

double deg(double d) { return d * kPi / 180.0; }

VelodyneCalibration nominal(VelodyneModel m, const std::vector<double>& vert_deg, const std::vector<double>& rot_deg,
                            double resolution) {
    VelodyneCalibration c;
    c.source = std::string("built-in ") + to_string(m);
    c.distance_resolution_m = resolution;
    for (std::size_t i = 0; i < vert_deg.size(); ++i) {
        VelodyneLaser l;
        l.vert_correction = deg(vert_deg[i]);
        l.rot_correction = rot_deg.empty() ? 0.0 : deg(rot_deg[i]);
        c.lasers.push_back(l);
    }
    return c;
}

}  // namespace

struct VelodyneDecoder::Firing {
    const std::uint8_t* channels;  // 3 bytes per laser: distance u16, reflectivity u8
    int first_laser;               // calibration index of the first channel
    int lasers;
    double azimuth_deg;            // of the sequence's first firing
    double azimuth_rate;           // ° per µs within the sequence
    double time_us;                // sensor time of the sequence's first firing
    double laser_us;
    int lasers_per_slot;
};

const char* to_string(VelodyneModel m) {
    switch (m) {
        case VelodyneModel::Vlp16: return "VLP-16";
        case VelodyneModel::Vlp32c: return "VLP-32C";
        case VelodyneModel::Hdl32e: return "HDL-32E";
        case VelodyneModel::Hdl64e: return "HDL-64E";
    }
    return "?";
}

VelodyneModel velodyne_model_from_name(const std::string& name) {
    std::string upper = name;
    std::transform(upper.begin(), upper.end(), upper.begin(), [](unsigned char c) { return std::toupper(c); });
    for (auto m : {VelodyneModel::Vlp16, VelodyneModel::Vlp32c, VelodyneModel::Hdl32e, VelodyneModel::Hdl64e})
        if (upper == to_string(m)) return m;
    throw std::invalid_argument("unknown Velodyne model \"" + name + "\" (expected VLP-16, VLP-32C, HDL-32E or HDL-64E)");
}

VelodyneCalibration default_velodyne_calibration(VelodyneModel m) {
    switch (m) {
        case VelodyneModel::Vlp16:
            return nominal(m, {-15, 1, -13, 3, -11, 5, -9, 7, -7, 9, -5, 11, -3, 13, -1, 15}, {}, 0.002);
        case VelodyneModel::Hdl32e:
            return nominal(m, {-30.67, -9.33, -29.33, -8.00, -28.00, -6.67, -26.67, -5.33, -25.33, -4.00, -24.00,
                               -2.67, -22.67, -1.33, -21.33, 0.00, -20.00, 1.33, -18.67, 2.67, -17.33, 4.00,
                               -16.00, 5.33, -14.67, 6.67, -13.33, 8.00, -12.00, 9.33, -10.67, 10.67},
                           {}, 0.002);
        case VelodyneModel::Vlp32c:
            // The manual's azimuth offsets, negated: rot_correction is subtracted from the azimuth.
            return nominal(m, {-25, -1, -1.667, -15.639, -11.31, 0, -0.667, -8.843, -7.254, 0.333, -0.333,
                               -6.148, -5.333, 1.333, 0.667, -4, -4.667, 1.667, 1, -3.667, -3.333, 3.333, 2.333,
                               -2.667, -3, 7, 4.667, -2.333, -2, 15, 10.333, -1.333},
                           {-1.4, 4.2, -1.4, 1.4, -1.4, 1.4, -4.2, 1.4, -1.4, 4.2, -1.4, 1.4, -4.2, 1.4, -4.2, 1.4,
                            -1.4, 4.2, -1.4, 4.2, -4.2, 1.4, -1.4, 1.4, -1.4, 1.4, -1.4, 4.2, -4.2, 1.4, -1.4, 1.4},
                           0.004);
        case VelodyneModel::Hdl64e:
            break;
    }
    throw std::invalid_argument("HDL-64E units are calibrated one by one: give their calibration file");
}

VelodyneCalibration read_velodyne_calibration(const std::string& path) {
    require_input_file<std::runtime_error>(path, "Velodyne calibration");
    VelodyneCalibration c;
    c.source = path;
    try {
        const YAML::Node root = YAML::LoadFile(path);
        if (root["distance_resolution"]) c.distance_resolution_m = root["distance_resolution"].as<double>();
        const YAML::Node lasers = root["lasers"];
        if (!lasers || !lasers.IsSequence() || lasers.size() == 0)
            throw std::runtime_error(path + ": Velodyne calibration has no `lasers` list");
        c.lasers.resize(lasers.size());
        std::vector<bool> seen(lasers.size(), false);
        for (const auto& node : lasers) {
            const int id = node["laser_id"].as<int>();
            if (id < 0 || id >= static_cast<int>(lasers.size()))
                throw std::runtime_error(path + ": laser_id " + std::to_string(id) + " outside 0.." +
                                         std::to_string(lasers.size() - 1));
            if (seen[static_cast<std::size_t>(id)])  // and another laser would be left all zeros
                throw std::runtime_error(path + ": laser_id " + std::to_string(id) + " listed twice");
            seen[static_cast<std::size_t>(id)] = true;
            // Angles in radians within a turn, corrections in metres within a few: a sensor's, not garbage.
            const auto field = [&](const char* key, double limit, bool required) {
                const double v = required || node[key] ? node[key].as<double>() : 0.0;
                if (!(std::abs(v) <= limit))
                    throw std::runtime_error(path + ": laser " + std::to_string(id) + ": " + key + " must lie within ±" +
                                             number_text(limit) + ", got " + number_text(v));
                return v;
            };
            c.lasers[static_cast<std::size_t>(id)] = {
                field("vert_correction", kPi / 2, true), field("rot_correction", 2 * kPi, false),
                field("dist_correction", kMaxCorrectionM, false), field("vert_offset_correction", kMaxCorrectionM, false),
                field("horiz_offset_correction", kMaxCorrectionM, false)};
        }
    } catch (const YAML::Exception& e) {
        throw std::runtime_error(path + ": not a readable Velodyne calibration YAML (" + e.what() + ")");
    }
    if (!(c.distance_resolution_m > 0.0 && c.distance_resolution_m <= 0.1))
        throw std::runtime_error(path + ": distance_resolution must be > 0 and at most 0.1 m");
    return c;
}

VelodyneFactory velodyne_factory(const std::uint8_t* packet) {
    VelodyneFactory f;
    const std::uint8_t mode = packet[1204];
    f.product_id = packet[1205];
    f.dual = mode == 0x39;
    f.return_mode = mode == 0x37 ? "strongest" : mode == 0x38 ? "last" : mode == 0x39 ? "dual" : "unknown";
    switch (f.product_id) {
        case 0x21: f.model = VelodyneModel::Hdl32e; break;
        case 0x22: f.model = VelodyneModel::Vlp16; break;
        case 0x28: f.model = VelodyneModel::Vlp32c; break;
        default: break;
    }
    return f;
}

double velodyne_packet_period_us(VelodyneModel model, bool dual) {
    const FiringPattern f = pattern_of(model);
    return f.block_us * (dual ? kBlocks / 2 : kBlocks);
}

std::optional<double> velodyne_cut_after(const std::vector<SensorRoi>& regions, const VelodyneCalibration& calibration) {
    constexpr int kSteps = 3600;  // firing azimuths 0.1° apart
    std::vector<bool> reaches(kSteps, false);
    for (const SensorRoi& roi : regions) {
        const RigidTransform T = to_rigid_transform(roi.sensor);
        for (const VelodyneLaser& L : calibration.lasers) {
            for (int k = 0; k < kSteps; ++k) {
                if (reaches[static_cast<std::size_t>(k)]) continue;
                // The beam's direction in the decoder's frame (x forward, y left); its offsets are centimetres.
                const double azimuth = deg(k / 10.0) - L.rot_correction;
                const double origin[3] = {0.0, 0.0, 0.0};
                const double direction[3] = {std::cos(L.vert_correction) * std::cos(azimuth),
                                             -std::cos(L.vert_correction) * std::sin(azimuth),
                                             std::sin(L.vert_correction)};
                reaches[static_cast<std::size_t>(k)] = ray_reaches(roi, T, origin, direction);
            }
        }
    }
    if (std::none_of(reaches.begin(), reaches.end(), [](bool r) { return r; }))  // lasers without a direction
        throw std::invalid_argument("no azimuth of the sensor can see the region of interest: check its mounting");
    // The longest run of azimuths that cannot reach the regions, going round once: the cut is its first.
    int best_start = -1, best_length = 0;
    for (int k = 0; k < kSteps; ++k) {
        if (reaches[static_cast<std::size_t>(k)] || !reaches[static_cast<std::size_t>((k + kSteps - 1) % kSteps)])
            continue;  // not where such a run starts
        int length = 0;
        while (length < kSteps && !reaches[static_cast<std::size_t>((k + length) % kSteps)]) ++length;
        if (length > best_length) best_start = k, best_length = length;
    }
    if (best_start < 0) return std::nullopt;
    return best_start / 10.0;
}

std::uint32_t velodyne_packet_time_us(const std::uint8_t* packet) { return read_le<std::uint32_t>(packet + 1200); }

VelodyneDecoder::VelodyneDecoder(VelodyneModel model, VelodyneCalibration calibration, double cut_angle_deg)
    : model_(model), calibration_(std::move(calibration)), cut_angle_deg_(cut_angle_deg) {
    const int lasers = pattern_of(model).lasers;
    if (static_cast<int>(calibration_.lasers.size()) != lasers)
        throw std::invalid_argument(calibration_.source + ": " + std::to_string(calibration_.lasers.size()) +
                                    " lasers, but a " + to_string(model) + " has " + std::to_string(lasers));
    if (!std::isfinite(cut_angle_deg) || cut_angle_deg < 0.0 || cut_angle_deg >= 360.0)
        throw std::invalid_argument("cut angle must be in [0, 360) degrees, got " + number_text(cut_angle_deg));
    for (const VelodyneLaser& L : calibration_.lasers) {
        cos_elevation_.push_back(std::cos(L.vert_correction));
        sin_elevation_.push_back(std::sin(L.vert_correction));
    }
}

void VelodyneDecoder::add_packet(const std::uint8_t* data, std::size_t size, double capture_time,
                                 std::vector<Frame>& done) {
    if (size != kVelodynePacketBytes)
        throw std::invalid_argument("Velodyne data packet of " + std::to_string(size) + " bytes, expected 1206");
    const bool dual = data[1204] == 0x39;
    if (dual && model_ == VelodyneModel::Hdl64e) throw std::invalid_argument("dual-return HDL-64E packets are not supported");
    if (!in_time_order(velodyne_packet_time_us(data), dual, done)) return;
    packet_capture_time_ = capture_time;

    const FiringPattern spec = pattern_of(model_);
    const int step = dual ? 2 : (model_ == VelodyneModel::Hdl64e ? 2 : 1);  // blocks per firing slot
    double azimuth[kBlocks];
    for (int b = 0; b < kBlocks; ++b) {
        const std::uint8_t* block = data + b * kBlockBytes;
        const auto flag = read_le<std::uint16_t>(block);
        if (flag != 0xEEFF && flag != 0xDDFF)
            throw std::invalid_argument("Velodyne block " + std::to_string(b) + " starts with " + std::to_string(flag) +
                                        ", not a block flag (0xEEFF or 0xDDFF)");
        azimuth[b] = 0.01 * read_le<std::uint16_t>(block + 2);
    }
    const int slots = kBlocks / step;
    const auto turn = [](double from, double to) { return std::fmod(to - from + 360.0, 360.0); };
    for (int s = 0; s < slots; ++s) {
        const int b = s * step;
        // Degrees the head turns until the next slot (the last slot repeats the one before).
        const double gap = slots == 1       ? 0.0
                           : s + 1 < slots ? turn(azimuth[b], azimuth[b + step])
                                           : turn(azimuth[b - step], azimuth[b]);
        if (model_ == VelodyneModel::Hdl64e) {  // upper and lower block fire together; no per-laser timing
            for (int half = 0; half < 2; ++half) {
                const std::uint8_t* block = data + (b + half) * kBlockBytes;
                const int first = read_le<std::uint16_t>(block) == 0xDDFF ? 32 : 0;
                add_firing({block + 4, first, kChannelsPerBlock, azimuth[b], 0.0, packet_us_, 0.0, 1}, done);
            }
            continue;
        }
        const double rate = gap / spec.block_us;
        for (int q = 0; q < spec.sequences; ++q) {
            const double dt = q * spec.sequence_us;
            add_firing({data + b * kBlockBytes + 4 + q * spec.lasers * 3, 0, spec.lasers, azimuth[b] + rate * dt, rate,
                        packet_us_ + s * spec.block_us + dt, spec.laser_us, spec.lasers_per_slot},
                       done);
        }
    }
}

// Sensor time, unwrapped across the hour (the packets count µs past the hour). A packet up to 0.1 s older than
// the one before (reordered on the way) or of the same time (a duplicate) is dropped and counted; a jump back
// further, or ahead by more than a second, starts afresh (the sensor restarted or its clock was set); a gap of
// whole packet periods counts lost packets.
bool VelodyneDecoder::in_time_order(double t_us, bool dual, std::vector<Frame>& done) {
    constexpr double kLateUs = 1e5, kGapUs = 1e6;
    if (packet_us_ < 0.0) {
        packet_us_ = t_us;
        return true;
    }
    double step = std::fmod(t_us - std::fmod(packet_us_, kHourUs) + kHourUs, kHourUs);  // [0, 1 h)
    if (step > kHourUs / 2) step -= kHourUs;
    if (step == 0.0) return ++duplicate_packets_, false;
    if (step < 0.0 && step > -kLateUs) return ++late_packets_, false;
    if (step < 0.0 || step >= kGapUs) {
        close_sweep(false, done);
        previous_relative_deg_ = -1.0;
        packet_us_ = t_us;
        return true;
    }
    const double period = velodyne_packet_period_us(model_, dual);
    if (step > 1.5 * period) lost_packets_ += std::llround(step / period) - 1;
    packet_us_ += step;
    return true;
}

void VelodyneDecoder::add_firing(const Firing& f, std::vector<Frame>& done) {
    const double az0 = std::fmod(f.azimuth_deg, 360.0);
    const double relative = std::fmod(az0 - cut_angle_deg_ + 360.0, 360.0);
    // A drop of more than half a turn in the angle past the cut means the head passed the cut angle.
    if (previous_relative_deg_ >= 0.0 && previous_relative_deg_ - relative > 180.0) close_sweep(true, done);
    previous_relative_deg_ = relative;
    if (xyzi_.size() / 4 >= kMaxSweepPoints) close_sweep(false, done);
    if (xyzi_.empty()) {
        sweep_time_ = packet_capture_time_;
        sweep_first_us_ = f.time_us;
    }
    for (int k = 0; k < f.lasers; ++k) {
        const std::uint8_t* ch = f.channels + 3 * k;
        const std::uint16_t raw = read_le<std::uint16_t>(ch);
        if (raw == 0) continue;  // no return
        const auto laser = static_cast<std::size_t>(f.first_laser + k);
        const VelodyneLaser& L = calibration_.lasers[laser];
        const double fire_us = (k / f.lasers_per_slot) * f.laser_us;
        const double azimuth = deg(f.azimuth_deg + f.azimuth_rate * fire_us) - L.rot_correction;
        const double distance = raw * calibration_.distance_resolution_m + L.dist_correction;
        const double cos_v = cos_elevation_[laser], sin_v = sin_elevation_[laser];
        const double cos_a = std::cos(azimuth), sin_a = std::sin(azimuth);
        const double xy = distance * cos_v - L.vert_offset_correction * sin_v;
        // The manual's frame: y forward, x right; azimuth clockwise from y seen from above.
        const double x_right = xy * sin_a - L.horiz_offset_correction * cos_a;
        const double y_forward = xy * cos_a + L.horiz_offset_correction * sin_a;
        const double z = distance * sin_v + L.vert_offset_correction * cos_v;
        xyzi_.insert(xyzi_.end(), {static_cast<float>(y_forward), static_cast<float>(-x_right), static_cast<float>(z),
                                   static_cast<float>(ch[2])});
        times_.push_back(static_cast<float>(1e-6 * (f.time_us + fire_us - sweep_first_us_)));
        beams_.push_back(f.first_laser + k);
    }
}

void VelodyneDecoder::close_sweep(bool at_cut, std::vector<Frame>& done) {
    if (!xyzi_.empty()) {
        Frame f;
        f.frame_id = sweeps_++;
        f.timestamp = sweep_time_;
        f.points = Eigen::Map<const PointMatrix>(xyzi_.data(), static_cast<Eigen::Index>(xyzi_.size() / 4), 4);
        f.point_times = std::move(times_);
        f.beams = std::move(beams_);
        f.diagnostics.complete = started_at_cut_ && at_cut;
        f.diagnostics.lost_packets = std::exchange(lost_packets_, 0);
        f.diagnostics.late_packets = std::exchange(late_packets_, 0);
        f.diagnostics.duplicate_packets = std::exchange(duplicate_packets_, 0);
        done.push_back(std::move(f));
    }
    xyzi_.clear();
    times_.clear();
    beams_.clear();
    started_at_cut_ = at_cut;
}

std::optional<Frame> VelodyneDecoder::finish() {
    std::vector<Frame> done;
    close_sweep(false, done);
    if (done.empty()) return std::nullopt;
    return std::move(done.front());
}

}  // namespace roadpreview
