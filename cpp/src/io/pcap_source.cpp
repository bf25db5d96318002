// SPDX-License-Identifier: BSD-3-Clause
#include "pcap_source.hpp"

#include <stdexcept>

#include "roadpreview/io/live.hpp"
#include "roadpreview/io/velodyne.hpp"

namespace roadpreview {

namespace {

class PcapInput : public DatagramInput {
public:
    explicit PcapInput(const std::string& path) : reader_(path) {}
    bool next(UdpDatagram& out) override { return reader_.next(out); }
    const std::string& name() const override { return reader_.path(); }
    const char* kind() const override { return "pcap"; }
    const char* unit() const override { return "record"; }
    std::int64_t units_read() const override { return reader_.counts().records; }

private:
    PcapReader reader_;
};

}  // namespace

std::unique_ptr<DatagramInput> pcap_input(const std::string& path) { return std::make_unique<PcapInput>(path); }

PcapSource::PcapSource(std::unique_ptr<DatagramInput> input, std::size_t packet_bytes, int port,
                       const std::string& port_origin, bool skip_bad_packets)
    : input_(std::move(input)), packet_bytes_(packet_bytes), skip_bad_packets_(skip_bad_packets) {
    info_.lidar_port = port;
    info_.lidar_port_origin = port ? port_origin : "detected";
}

SourceInfo PcapSource::info() const {
    SourceInfo i = info_;
    input_->describe(i);
    return i;
}

void PcapSource::fail(const std::string& what) const { throw std::runtime_error(path() + ": " + what); }

bool PcapSource::is_lidar(const UdpDatagram& d) {
    if (info_.lidar_port) return d.dst_port == info_.lidar_port;
    if (d.payload.size() != packet_bytes_) return false;
    info_.lidar_port = d.dst_port;
    return true;
}

void PcapSource::read_until_frame() {
    while (ready_.empty() && !ended_) {
        if (!input_->next(datagram_)) {
            ended_ = true;
            if (decoded_ == 0) {
                if (!first_problem_.empty()) fail("no lidar packet could be decoded; the first problem: " + first_problem_);
                if (input_->units_read() == 0)  // a live run that ended (--duration) before anything came
                    fail(std::string(input_->kind()) == "udp" ? "no datagram arrived before the run ended"
                                                              : "holds no records");
                // Found by size, LiDAR-sized datagrams of another size are most likely another sensor's or
                // profile's packets than the metadata (or model) describes.
                const bool other_size = !info_.lidar_port && largest_ >= kMinLidarPacketBytes;
                fail("no lidar packets (" + std::to_string(packet_bytes_) + "-byte UDP datagrams" +
                     (info_.lidar_port ? " on port " + std::to_string(info_.lidar_port) + ", from the " +
                                             info_.lidar_port_origin
                                       : std::string()) +
                     ") in " + std::to_string(input_->units_read()) + " " + input_->unit() + "s; the largest datagram is " +
                     std::to_string(largest_) + " bytes on port " + std::to_string(largest_port_) +
                     (other_size ? ": if those are the LiDAR's, the metadata or sensor model given is another "
                                   "sensor's or lidar profile's (check --meta / --sensor-model); --lidar-port "
                                   "chooses the port"
                                 : " (--lidar-port chooses the port)"));
            }
            try {
                on_end(ready_);
            } catch (const std::invalid_argument& e) {
                fail(e.what());
            }
            return;
        }
        if (datagram_.payload.size() > largest_) {
            largest_ = datagram_.payload.size();
            largest_port_ = datagram_.dst_port;
        }
        if (!is_lidar(datagram_)) {
            on_other(datagram_);
            continue;
        }
        try {
            const std::size_t before = ready_.size();
            on_lidar(datagram_, ready_);
            ++decoded_;
            // The frames this datagram completed: their latency counts from its arrival.
            const double completed_s = datagram_.arrival_s > 0.0 && ready_.size() > before ? steady_now_s() : 0.0;
            for (std::size_t k = before; k < ready_.size(); ++k) {
                ready_[k].arrival_s = datagram_.arrival_s;
                ready_[k].completed_s = completed_s;
            }
        } catch (const std::invalid_argument& e) {
            const std::string problem = input_->unit() + (" " + std::to_string(datagram_.record)) + " (UDP port " +
                                        std::to_string(datagram_.dst_port) + "): " + e.what();
            if (!skip_bad_packets_) fail(problem);
            if (first_problem_.empty()) first_problem_ = problem;
            ++skipped_;
        }
    }
}

std::optional<Frame> PcapSource::next() {
    read_until_frame();
    if (ready_.empty()) return std::nullopt;
    Frame f = std::move(ready_.front());
    ready_.pop_front();
    f.source = path();
    f.diagnostics.skipped_packets = skipped_;
    skipped_ = 0;
    return f;
}

bool looks_like_velodyne(const std::string& path) {
    PcapReader reader(path);
    UdpDatagram d;
    for (int i = 0; i < 1000 && reader.next(d); ++i)
        if (d.payload.size() == kVelodynePacketBytes) return true;
    return false;
}

bool holds_lidar_sized_datagrams(const std::string& path) {
    PcapReader reader(path);
    UdpDatagram d;
    while (reader.next(d))
        if (d.payload.size() >= kMinLidarPacketBytes) return true;
    return false;
}

}  // namespace roadpreview
