// SPDX-License-Identifier: BSD-3-Clause
#include "roadpreview/io/pcap.hpp"

#include <pcap/pcap.h>
#include <tins/ethernetII.h>
#include <tins/exceptions.h>
#include <tins/ip.h>
#include <tins/ip_reassembler.h>
#include <tins/loopback.h>
#include <tins/rawpdu.h>
#include <tins/sll.h>
#include <tins/udp.h>

#include <memory>
#include <stdexcept>

namespace roadpreview {
namespace {

// A datagram needs at most 45 fragments (64 KiB / 1480 B); past this many fragments without a completed
// datagram the pending ones are lost for good, so they are dropped to keep memory bounded.
constexpr std::int64_t kMaxPendingFragments = 1024;

[[noreturn]] void fail(const std::string& path, const std::string& what) {
    throw std::runtime_error(path + ": " + what);
}

bool supported_link_type(int link_type) {
    for (int t : {DLT_EN10MB, DLT_LINUX_SLL, DLT_NULL, DLT_LOOP, DLT_RAW, DLT_IPV4})
        if (link_type == t) return true;
    return false;
}

// The link layer of one record, parsed by libtins (throws Tins::malformed_packet on bad bytes).
std::unique_ptr<Tins::PDU> parse_link_layer(int link_type, const std::uint8_t* data, std::uint32_t size) {
    switch (link_type) {
        case DLT_EN10MB:
            return std::make_unique<Tins::EthernetII>(data, size);
        case DLT_LINUX_SLL:
            return std::make_unique<Tins::SLL>(data, size);
        case DLT_NULL:
        case DLT_LOOP:
            return std::make_unique<Tins::Loopback>(data, size);
        case DLT_RAW:
        case DLT_IPV4:
            return std::make_unique<Tins::IP>(data, size);
        default:
            return nullptr;
    }
}

}  // namespace

struct PcapReader::Impl {
    std::string path;
    pcap_t* handle = nullptr;
    int link_type = 0;
    Tins::IPv4Reassembler reassembler;
    std::int64_t pending_fragments = 0;
    PcapCounts counts;

    ~Impl() {
        if (handle) pcap_close(handle);
    }

    bool not_udp() {
        ++counts.other;
        return false;
    }

    // Fills `out` from one record; false when the record holds no complete UDP datagram.
    bool decode(const pcap_pkthdr& header, const std::uint8_t* data, UdpDatagram& out) {
        std::unique_ptr<Tins::PDU> pdu;
        try {
            pdu = parse_link_layer(link_type, data, header.caplen);
        } catch (const Tins::exception_base&) {
            pdu.reset();
        }
        const Tins::IP* ip = pdu ? pdu->find_pdu<Tins::IP>() : nullptr;
        if (!ip) return not_udp();
        if (ip->is_fragmented()) {
            ++counts.fragments;
            const auto status = reassembler.process(*pdu);
            if (status == Tins::IPv4Reassembler::FRAGMENTED) {
                if (++pending_fragments > kMaxPendingFragments) {
                    counts.dropped_fragments += pending_fragments;
                    pending_fragments = 0;
                    reassembler.clear_streams();
                }
                return false;
            }
            pending_fragments = 0;
        }
        const auto* udp = pdu->find_pdu<Tins::UDP>();
        const auto* raw = pdu->find_pdu<Tins::RawPDU>();
        if (!udp) return not_udp();
        out.timestamp = static_cast<double>(header.ts.tv_sec) + 1e-9 * static_cast<double>(header.ts.tv_usec);
        out.src_port = udp->sport();
        out.dst_port = udp->dport();
        out.record = counts.records;
        if (raw) {
            out.payload.assign(raw->payload().begin(), raw->payload().end());
        } else {
            out.payload.clear();
        }
        return true;
    }
};

PcapReader::PcapReader(const std::string& path) : impl_(std::make_unique<Impl>()) {
    impl_->path = path;
    char err[PCAP_ERRBUF_SIZE] = {};
    // Nanosecond precision: libpcap scales microsecond files up, so tv_usec holds nanoseconds.
    impl_->handle = pcap_open_offline_with_tstamp_precision(path.c_str(), PCAP_TSTAMP_PRECISION_NANO, err);
    if (!impl_->handle) fail(path, std::string("cannot read as pcap or pcapng (libpcap: ") + err + ")");
    impl_->link_type = pcap_datalink(impl_->handle);
    if (!supported_link_type(impl_->link_type)) {
        const char* name = pcap_datalink_val_to_name(impl_->link_type);
        fail(path, "link type " + std::to_string(impl_->link_type) + " (" + (name ? name : "unknown") +
                       ") is not supported (expected Ethernet, Linux cooked SLL, raw IPv4 or loopback)");
    }
}

PcapReader::~PcapReader() = default;
PcapReader::PcapReader(PcapReader&&) noexcept = default;
PcapReader& PcapReader::operator=(PcapReader&&) noexcept = default;

bool PcapReader::next(UdpDatagram& out) {
    Impl& d = *impl_;
    for (;;) {
        pcap_pkthdr* header = nullptr;
        const u_char* data = nullptr;
        const int status = pcap_next_ex(d.handle, &header, &data);
        if (status == PCAP_ERROR_BREAK) return false;  // end of file
        if (status != 1)
            fail(d.path, "record " + std::to_string(d.counts.records + 1) +
                             " cannot be read, the file is truncated or corrupt (libpcap: " + pcap_geterr(d.handle) + ")");
        ++d.counts.records;
        if (d.decode(*header, data, out)) {
            ++d.counts.datagrams;
            return true;
        }
    }
}

const PcapCounts& PcapReader::counts() const { return impl_->counts; }
const std::string& PcapReader::path() const { return impl_->path; }

}  // namespace roadpreview
