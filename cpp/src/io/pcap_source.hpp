// SPDX-License-Identifier: BSD-3-Clause
// The part every pcap reader shares: datagrams in, lidar packets routed by UDP port to a decoder, frames out,
// bad packets turned into errors naming the file and record (or skipped and counted on request).
#pragma once

#include <deque>
#include <memory>
#include <string>

#include "roadpreview/io/readers.hpp"
#include "roadpreview/io/pcap.hpp"

namespace roadpreview {

class PcapSource : public FrameSource {
public:
    std::optional<Frame> next() final;
    SourceInfo info() const final { return info_; }

protected:
    /// `packet_bytes`: size of a lidar packet; `port` 0 means: the port of the first datagram of that size.
    PcapSource(const std::string& path, std::size_t packet_bytes, int port, const std::string& port_origin,
               bool skip_bad_packets);

    /// Decodes one datagram on the lidar port; completed frames go to `ready`. Throws std::invalid_argument
    /// describing what is wrong with the packet.
    virtual void on_lidar(const UdpDatagram& d, std::deque<Frame>& ready) = 0;
    /// Any other datagram (IMU, position packets, unrelated traffic).
    virtual void on_other(const UdpDatagram&) {}
    /// Frames still being assembled at the end of the file go to `ready`.
    virtual void on_end(std::deque<Frame>& ready) = 0;

    [[noreturn]] void fail(const std::string& what) const;
    const std::string& path() const { return reader_.path(); }

    SourceInfo info_;

private:
    bool is_lidar(const UdpDatagram& d);
    void read_until_frame();

    PcapReader reader_;
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

/// Readers for one pcap (io/ouster_source.cpp, io/velodyne_source.cpp).
std::unique_ptr<FrameSource> open_ouster_pcap(const std::string& path, const std::string& meta_path,
                                              const SourceOptions& options);
std::unique_ptr<FrameSource> open_velodyne_pcap(const std::string& path, const SourceOptions& options);
/// True when the first datagrams of the file include a Velodyne data packet (1206 bytes).
bool looks_like_velodyne(const std::string& path);

}  // namespace roadpreview
