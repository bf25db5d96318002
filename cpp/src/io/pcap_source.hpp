// SPDX-License-Identifier: BSD-3-Clause
// The part every packet reader shares: datagrams in (a pcap file, or a UDP socket: io/live.cpp), lidar packets
// routed by UDP port to a decoder, frames out, bad packets turned into errors naming the input and the record or
// datagram (or skipped and counted on request).
#pragma once

#include <deque>
#include <memory>
#include <string>

#include "roadpreview/io/readers.hpp"
#include "roadpreview/io/pcap.hpp"

namespace roadpreview {

/// Where a packet reader's datagrams come from: a capture file, or UDP sockets (io/live.cpp).
class DatagramInput {
public:
    virtual ~DatagramInput() = default;
    /// The next datagram, or false at the end of the input. Throws std::runtime_error naming the input.
    virtual bool next(UdpDatagram& out) = 0;
    virtual const std::string& name() const = 0;  ///< the file, or udp://ADDR:PORT
    virtual const char* kind() const = 0;         ///< "pcap" or "udp"
    virtual const char* unit() const = 0;         ///< what UdpDatagram::record counts: "record" or "datagram"
    virtual std::int64_t units_read() const = 0;  ///< records or datagrams read so far
    /// Counters worth a user's attention, added to the source's info (live: datagrams dropped by the queue).
    virtual void describe(SourceInfo&) const {}
};

/// The UDP datagrams of one pcap or pcapng file.
std::unique_ptr<DatagramInput> pcap_input(const std::string& path);

class PcapSource : public FrameSource {
public:
    std::optional<Frame> next() final;
    SourceInfo info() const final;

protected:
    /// `packet_bytes`: size of a lidar packet; `port` 0 means: the port of the first datagram of that size.
    PcapSource(std::unique_ptr<DatagramInput> input, std::size_t packet_bytes, int port,
               const std::string& port_origin, bool skip_bad_packets);

    /// Decodes one datagram on the lidar port; completed frames go to `ready`. Throws std::invalid_argument
    /// describing what is wrong with the packet.
    virtual void on_lidar(const UdpDatagram& d, std::deque<Frame>& ready) = 0;
    /// Any other datagram (IMU, position packets, unrelated traffic).
    virtual void on_other(const UdpDatagram&) {}
    /// Frames still being assembled at the end of the file go to `ready`.
    virtual void on_end(std::deque<Frame>& ready) = 0;

    [[noreturn]] void fail(const std::string& what) const;
    const std::string& path() const { return input_->name(); }
    const char* kind() const { return input_->kind(); }

    SourceInfo info_;

private:
    bool is_lidar(const UdpDatagram& d);
    void read_until_frame();

    std::unique_ptr<DatagramInput> input_;
    UdpDatagram datagram_;
    std::deque<Frame> ready_;
    std::size_t packet_bytes_;
    bool skip_bad_packets_;
    bool ended_ = false;
    std::int64_t decoded_ = 0;   // lidar packets decoded
    std::int64_t skipped_ = 0;   // bad lidar packets skipped since the last frame
    std::string first_problem_;  // of a skipped packet, for the end-of-file message
    std::size_t largest_ = 0;    // largest datagram seen, and its port, for the end-of-file message
    int largest_port_ = 0;
};

/// Readers of Ouster and Velodyne packets from any datagram input (io/ouster_source.cpp, io/velodyne_source.cpp).
std::unique_ptr<FrameSource> open_ouster_packets(std::unique_ptr<DatagramInput> input, const std::string& meta_path,
                                                 const SourceOptions& options);
std::unique_ptr<FrameSource> open_velodyne_packets(std::unique_ptr<DatagramInput> input, const SourceOptions& options);

/// Readers for one pcap.
inline std::unique_ptr<FrameSource> open_ouster_pcap(const std::string& path, const std::string& meta_path,
                                                     const SourceOptions& options) {
    return open_ouster_packets(pcap_input(path), meta_path, options);
}
inline std::unique_ptr<FrameSource> open_velodyne_pcap(const std::string& path, const SourceOptions& options) {
    return open_velodyne_packets(pcap_input(path), options);
}
/// True when the first datagrams of the file include a Velodyne data packet (1206 bytes).
bool looks_like_velodyne(const std::string& path);
/// True when the file holds a UDP datagram the size of a LiDAR data packet (at least kMinLidarPacketBytes): a
/// capture without one holds other traffic only (a SICK scanner's telegrams travel over TCP, mDNS over UDP).
constexpr std::size_t kMinLidarPacketBytes = 512;  // Velodyne's are 1206 bytes, Ouster's lidar packets 3 kB and more
bool holds_lidar_sized_datagrams(const std::string& path);

}  // namespace roadpreview
