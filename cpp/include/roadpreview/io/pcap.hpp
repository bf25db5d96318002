// SPDX-License-Identifier: BSD-3-Clause
// UDP datagrams of a pcap or pcapng capture, one at a time: libpcap reads the records, libtins parses the
// link layer (Ethernet, Linux cooked SLL, raw IP, BSD loopback), IPv4 and UDP and reassembles IP fragments.
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

namespace roadpreview {

struct UdpDatagram {
    double timestamp = 0.0;  ///< s, capture time (UNIX epoch) of the record that completed the datagram
    std::uint16_t src_port = 0;
    std::uint16_t dst_port = 0;
    std::int64_t record = 0;            ///< 1-based index of that record in the file (live: of the datagram)
    double arrival_s = 0.0;             ///< live: steady-clock time of arrival, s; 0 from files
    std::vector<std::uint8_t> payload;  ///< UDP payload, reassembled when the datagram was fragmented
};

struct PcapCounts {
    std::int64_t records = 0;      ///< records read
    std::int64_t datagrams = 0;    ///< UDP datagrams returned
    std::int64_t other = 0;        ///< records that are not IPv4 UDP (ARP, TCP, IPv6, ...) or are malformed
    std::int64_t fragments = 0;    ///< records that were IP fragments
    std::int64_t dropped_fragments = 0;  ///< fragments given up because their datagram never completed
};

/// Streams the UDP datagrams of one capture file; memory stays bounded whatever the file size.
class PcapReader {
public:
    /// Throws std::runtime_error naming the file when it is missing, not a capture, or of a link type
    /// other than Ethernet, Linux cooked (SLL), raw IPv4 or BSD loopback.
    explicit PcapReader(const std::string& path);
    ~PcapReader();
    PcapReader(PcapReader&&) noexcept;
    PcapReader& operator=(PcapReader&&) noexcept;

    /// The next UDP datagram, or false at the end of the file. A truncated or corrupt record throws
    /// std::runtime_error naming the file and the record; the datagrams before it have been returned.
    bool next(UdpDatagram& out);

    const PcapCounts& counts() const;
    const std::string& path() const;

private:
    struct Impl;
    std::unique_ptr<Impl> impl_;
};

}  // namespace roadpreview
