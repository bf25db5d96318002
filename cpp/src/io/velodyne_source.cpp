// SPDX-License-Identifier: BSD-3-Clause
// A Velodyne pcap. The model comes from --sensor-model, else from the factory byte checked against the firing
// timing (the time between the first two packets): some early VLP-16 firmware reports an HDL-32E.
#include <cmath>
#include <cstdio>
#include <sstream>
#include <string>
#include <utility>

#include "roadpreview/calibration/calibration.hpp"
#include "roadpreview/io/velodyne.hpp"
#include "pcap_source.hpp"

namespace roadpreview {
namespace {

// The model whose packet period (in the packet's return mode) is within 10 % of the measured one.
std::optional<VelodyneModel> model_by_timing(double period_us, bool dual) {
    for (auto m : {VelodyneModel::Vlp16, VelodyneModel::Vlp32c, VelodyneModel::Hdl32e}) {
        const double expected = velodyne_packet_period_us(m, dual);
        if (std::abs(period_us - expected) < 0.1 * expected) return m;
    }
    return std::nullopt;
}

class VelodynePcapSource : public PcapSource {
public:
    VelodynePcapSource(std::unique_ptr<DatagramInput> input, const SourceOptions& o)
        : PcapSource(std::move(input), kVelodynePacketBytes, o.lidar_port, "option", o.skip_bad_packets), options_(o) {
        info_.format = std::string("velodyne ") + kind();
        if (!o.sensor_model.empty()) forced_ = velodyne_model_from_name(o.sensor_model);
        if (forced_ == VelodyneModel::Hdl64e && o.calibration.empty())
            fail("an HDL-64E needs its calibration file (--calibration)");

    }

private:
    void on_lidar(const UdpDatagram& d, std::deque<Frame>& ready) override {
        if (d.payload.size() != kVelodynePacketBytes)
            throw std::invalid_argument("Velodyne data packet of " + std::to_string(d.payload.size()) +
                                        " bytes, expected 1206");
        if (!decoder_) {
            if (first_.payload.empty()) {  // the model needs two packets' timing
                first_ = d;
                return;
            }
            start(&d);
            feed(first_, ready);
        }
        feed(d, ready);
    }

    void on_end(std::deque<Frame>& ready) override {
        if (!decoder_ && !first_.payload.empty()) {
            start(nullptr);
            feed(first_, ready);
        }
        if (!decoder_) return;
        if (auto f = decoder_->finish()) ready.push_back(std::move(*f));
    }

    void feed(const UdpDatagram& d, std::deque<Frame>& ready) {
        done_.clear();
        decoder_->add_packet(d.payload.data(), d.payload.size(), d.timestamp, done_);
        for (Frame& f : done_) ready.push_back(std::move(f));
    }

    void start(const UdpDatagram* second) {
        const VelodyneFactory factory = velodyne_factory(first_.payload.data());
        info_.profile = factory.return_mode;
        VelodyneModel model;
        if (forced_) {
            model = *forced_;
            std::string note = std::string("model given: ") + to_string(model);
            const auto [detected, how] = detect_model(factory, second);
            if (detected && *detected != model)
                note += "; the packets say " + std::string(to_string(*detected)) + " (" + how + "): decoded as given";
            info_.notes.push_back(note);
        } else {
            model = choose_model(factory, second);
        }
        info_.sensor_model = to_string(model);
        VelodyneCalibration calibration = options_.calibration.empty() ? default_velodyne_calibration(model)
                                                                       : read_velodyne_calibration(options_.calibration);
        info_.metadata = calibration.source;
        if (!options_.beam_calibration.empty()) apply_beams_file(calibration, model);
        info_.frame_rate_hz = 0.0;
        info_.beams = static_cast<int>(calibration.lasers.size());
        const double cut = cut_angle_deg(calibration);
        decoder_.emplace(model, std::move(calibration), cut);
    }

    // The cut angle given, or with roi_columns the one after which the region of interest is scanned: each sweep
    // then holds the region whole, and ends as soon as it has been scanned.
    double cut_angle_deg(const VelodyneCalibration& calibration) {
        if (options_.roi_columns.empty()) return options_.cut_angle_deg;
        std::optional<double> cut;
        try {
            cut = velodyne_cut_after(options_.roi_columns, calibration);
        } catch (const std::invalid_argument& e) {
            fail(e.what());  // the mounting's fault, not a packet's: never skipped
        }
        if (!cut) {
            info_.notes.push_back("every azimuth can see the region of interest (roi_columns): sweeps end at the cut "
                                  "angle given");
            return options_.cut_angle_deg;
        }
        char note[160];
        std::snprintf(note, sizeof note, "sweeps end at %.1f°, where the region of interest has been scanned "
                      "(roi_columns)", *cut);
        info_.notes.push_back(note);
        return *cut;
    }

    // The beams file's offsets folded into the lasers' corrections (the decoder adds dist_correction).
    void apply_beams_file(VelodyneCalibration& calibration, VelodyneModel model) const {
        const BeamCalibration c = read_beam_calibration(options_.beam_calibration);
        check_beam_calibration(c, static_cast<int>(calibration.lasers.size()), to_string(model), "");
        if (c.index != BeamIndexMethod::Decoder)
            fail(options_.beam_calibration + " indexes beams by elevation; a Velodyne recording needs laser ids");
        for (std::size_t b = 0; b < c.beams.size(); ++b) {
            calibration.lasers[b].vert_correction += c.beams[b].elevation_offset_deg * 3.14159265358979323846 / 180.0;
            calibration.lasers[b].dist_correction -= c.beams[b].range_offset_m;
        }
    }

    // The model the factory byte and the time between the first two packets point to (the timing wins), and
    // how it was told.
    std::pair<std::optional<VelodyneModel>, std::string> detect_model(const VelodyneFactory& factory,
                                                                      const UdpDatagram* second) const {
        std::optional<VelodyneModel> timed;
        double period = 0.0;
        if (second) {
            const double t0 = velodyne_packet_time_us(first_.payload.data());
            const double t1 = velodyne_packet_time_us(second->payload.data());
            period = std::fmod(t1 - t0 + 3600e6, 3600e6);
            timed = model_by_timing(period, factory.dual);
        }
        std::ostringstream note;
        note << "factory byte 0x" << std::hex << factory.product_id << std::dec << " ("
             << (factory.model ? to_string(*factory.model) : "unknown") << ")";
        if (second) note << ", packets " << period << " µs apart (" << (timed ? to_string(*timed) : "no known model") << ")";
        return {timed ? timed : factory.model, note.str()};
    }

    VelodyneModel choose_model(const VelodyneFactory& factory, const UdpDatagram* second) {
        const auto [model, how] = detect_model(factory, second);
        if (!model) fail("cannot tell the Velodyne model: " + how + "; pass --sensor-model");
        info_.notes.push_back(how + ": decoded as " + to_string(*model));
        return *model;
    }

    SourceOptions options_;
    std::optional<VelodyneModel> forced_;
    std::optional<VelodyneDecoder> decoder_;
    UdpDatagram first_;
    std::vector<Frame> done_;
};

}  // namespace

std::unique_ptr<FrameSource> open_velodyne_packets(std::unique_ptr<DatagramInput> input, const SourceOptions& options) {
    return std::make_unique<VelodynePcapSource>(std::move(input), options);
}

}  // namespace roadpreview
