// SPDX-License-Identifier: BSD-3-Clause
// Ouster packets (a pcap or live UDP): lidar packets to OusterDecoder, IMU packets attached to the frame being
// assembled.
#include <algorithm>
#include <array>

#include "roadpreview/calibration/calibration.hpp"
#include "roadpreview/io/ouster.hpp"
#include "pcap_source.hpp"

namespace roadpreview {
namespace {

class OusterPcapSource : public PcapSource {
public:
    OusterPcapSource(std::unique_ptr<DatagramInput> input, OusterMetadata meta, const SourceOptions& o)
        : PcapSource(std::move(input), meta.lidar_packet_bytes(), o.lidar_port ? o.lidar_port : meta.udp_port_lidar,
                     o.lidar_port ? "option" : "metadata", o.skip_bad_packets),
          imu_port_(o.imu_port ? o.imu_port : meta.udp_port_imu),
          decoder_(std::move(meta)) {
        const OusterMetadata& m = decoder_.metadata();
        info_.format = std::string("ouster ") + kind();
        info_.sensor_model = m.prod_line.empty() ? "Ouster (model not in the metadata)" : m.prod_line;
        info_.profile = to_string(m.profile);
        info_.metadata = m.source;
        info_.frame_rate_hz = m.frame_rate_hz;
        info_.beams = m.pixels_per_column;
        info_.serial = m.prod_sn;
        if (!o.roi_columns.empty()) info_.notes.push_back(decoder_.keep_columns_reaching(o.roi_columns));
    }

private:
    void on_lidar(const UdpDatagram& d, std::deque<Frame>& ready) override {
        if (auto f = decoder_.add_packet(d.payload.data(), d.payload.size(), d.timestamp)) emit(std::move(*f), ready);
    }

    void on_other(const UdpDatagram& d) override {
        const bool imu = imu_port_ ? d.dst_port == imu_port_ : d.payload.size() == kOusterImuPacketBytes;
        if (!imu || d.payload.size() != kOusterImuPacketBytes || seen_before(d)) return;
        decoder_.add_imu(decode_ouster_imu(d.payload.data(), d.payload.size(), d.timestamp,
                                           decoder_.metadata().imu_to_sensor));
    }

    void on_end(std::deque<Frame>& ready) override {
        if (auto f = decoder_.finish()) emit(std::move(*f), ready);
        if (!frames_ && decoder_.packets_outside_window()) {
            const auto window = decoder_.metadata().column_window;
            fail("none of its " + std::to_string(decoder_.packets_outside_window()) + " lidar packets holds a column "
                 "that can see the region of interest (roi_columns: columns " + std::to_string(window[0]) + "–" +
                 std::to_string(window[1]) + ")");
        }
    }

    void emit(Frame f, std::deque<Frame>& ready) {
        ++frames_;
        ready.push_back(std::move(f));
    }

    using ImuBytes = std::array<std::uint8_t, kOusterImuPacketBytes>;

    // A copy the network made of an IMU datagram (its sensor timestamps and all, byte for byte) is one reading,
    // not two: remembered over the last few, as a copy comes close behind its original.
    bool seen_before(const UdpDatagram& d) {
        ImuBytes bytes;
        std::copy_n(d.payload.begin(), bytes.size(), bytes.begin());
        if (std::find(recent_imu_.begin(), recent_imu_.begin() + recent_count_, bytes) !=
            recent_imu_.begin() + recent_count_)
            return true;
        recent_imu_[next_recent_] = bytes;
        next_recent_ = (next_recent_ + 1) % recent_imu_.size();
        recent_count_ = std::min(recent_count_ + 1, recent_imu_.size());
        return false;
    }

    std::array<ImuBytes, 8> recent_imu_{};
    std::size_t recent_count_ = 0, next_recent_ = 0;
    std::int64_t frames_ = 0;
    int imu_port_;
    OusterDecoder decoder_;
};

// The beams file's offsets folded into the beam intrinsics the decoder's XYZ table is built from.
OusterMetadata calibrated(OusterMetadata meta, const std::string& beams_file) {
    if (beams_file.empty()) return meta;
    const BeamCalibration c = read_beam_calibration(beams_file);
    check_beam_calibration(c, meta.pixels_per_column, meta.prod_line, meta.prod_sn);
    if (c.index != BeamIndexMethod::Decoder)
        throw std::runtime_error(beams_file + ": indexes beams by elevation; an Ouster needs one by beam number");
    meta.beam_range_offset_m.assign(c.beams.size(), 0.0);
    for (std::size_t b = 0; b < c.beams.size(); ++b) {
        meta.beam_altitude_deg[b] += c.beams[b].elevation_offset_deg;
        meta.beam_range_offset_m[b] = c.beams[b].range_offset_m;
    }
    return meta;
}

}  // namespace

std::unique_ptr<FrameSource> open_ouster_packets(std::unique_ptr<DatagramInput> input, const std::string& meta_path,
                                                 const SourceOptions& options) {
    return std::make_unique<OusterPcapSource>(
        std::move(input), calibrated(read_ouster_metadata(meta_path), options.beam_calibration), options);
}

}  // namespace roadpreview
