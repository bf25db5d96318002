// SPDX-License-Identifier: BSD-3-Clause
// Replay of a capture's UDP payloads with their recorded timing: the way to test and demo live input.
#include <sys/socket.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstring>
#include <map>
#include <optional>
#include <random>
#include <stdexcept>
#include <thread>
#include <utility>

#include "roadpreview/io/live.hpp"
#include "roadpreview/io/pcap.hpp"
#include "core/text.hpp"
#include "udp.hpp"

namespace roadpreview {
namespace {

// The destination port that carries the most bytes in the capture's first datagrams: the lidar's.
int busiest_port(const std::string& capture) {
    PcapReader reader(capture);
    UdpDatagram d;
    std::map<int, std::size_t> bytes;
    for (int i = 0; i < 4000 && reader.next(d); ++i) bytes[d.dst_port] += d.payload.size();
    if (bytes.empty()) {
        const PcapCounts& c = reader.counts();
        throw std::runtime_error(capture + ": no UDP datagrams to replay (" + std::to_string(c.records) + " records, " +
                                 std::to_string(c.other) + " of them not IPv4 UDP)");
    }
    auto best = bytes.begin();
    for (auto it = bytes.begin(); it != bytes.end(); ++it)
        if (it->second > best->second) best = it;
    return best->first;
}

class Sender {
public:
    Sender(const UdpEndpoint& to, int lidar_port)
        : socket_(to.text), shift_(to.port - lidar_port), address_(resolve_ipv4(to.address, to.port, to.text)),
          where_(to.text) {}

    void send(const UdpDatagram& d) {
        const int port = d.dst_port + shift_;
        if (port < 1 || port > 65535) return;  // a port the shift moves out of range: not the sensor's
        sockaddr_in a = address_;
        a.sin_port = htons(static_cast<std::uint16_t>(port));
        for (int attempt = 0;; ++attempt) {
            if (sendto(socket_.fd(), d.payload.data(), d.payload.size(), 0, reinterpret_cast<const sockaddr*>(&a),
                       sizeof a) >= 0)
                return;
            if ((errno != ENOBUFS && errno != EAGAIN && errno != EINTR) || attempt > 1000)
                throw std::runtime_error(where_ + ": cannot send a datagram of " + std::to_string(d.payload.size()) +
                                         " bytes to port " + std::to_string(port) + ": " + std::strerror(errno));
            std::this_thread::sleep_for(std::chrono::microseconds(100));
        }
    }

private:
    UdpSocket socket_;
    int shift_;
    sockaddr_in address_;
    std::string where_;
};

using Clock = std::chrono::steady_clock;

// One pass through the capture; returns the capture time of its first datagram and its span.
struct Pass {
    const std::string& capture;
    const ReplayOptions& options;
    Sender& sender;
    ReplayStats& stats;
    std::mt19937& random;
    Clock::time_point start;  // when the pass's first datagram is due

    // False when the progress callback asked to stop.
    bool run() {
        PcapReader reader(capture);
        UdpDatagram d;
        std::optional<UdpDatagram> held;  // sent after the next one (reordered)
        std::optional<double> first_s;
        double closed_s = 0.0, last_s = 0.0;  // the clock's jumps closed so far; the last record's offset
        std::uniform_real_distribution<double> uniform(0.0, 1.0);
        while (reader.next(d)) {
            if (!first_s) first_s = d.timestamp;
            double offset_s = d.timestamp - *first_s - closed_s;
            if (std::abs(offset_s - last_s) > kMaxReplayGapS) {  // a jump of the clock, not a silence: close it
                closed_s += offset_s - last_s;
                offset_s = last_s;
                ++stats.clock_jumps;
            }
            last_s = offset_s;
            stats.capture_seconds = std::max(stats.capture_seconds, offset_s);
            wait_until(offset_s);
            const double u = uniform(random);
            if (u < options.drop_fraction) {
                ++stats.dropped;
                continue;
            }
            if (!held && u < options.drop_fraction + options.reorder_fraction) {
                held = d;
                ++stats.reordered;
                continue;
            }
            if (!sent(d)) return false;
            if (held && !sent(*std::exchange(held, std::nullopt))) return false;
        }
        return !held || sent(*held);
    }

    void wait_until(double offset_s) const {
        if (options.rate <= 0.0) return;
        // At most a billion seconds: a capture whose clock jumps by decades must not overflow the clock's ticks.
        const double wait_s = std::min(offset_s / options.rate, 1e9);
        std::this_thread::sleep_until(start + std::chrono::duration_cast<Clock::duration>(
                                                  std::chrono::duration<double>(wait_s)));
    }

    bool sent(const UdpDatagram& d) {
        sender.send(d);
        ++stats.sent;
        stats.bytes += static_cast<std::int64_t>(d.payload.size());
        return !options.progress || options.progress(stats.sent);
    }
};

void check_options(const std::string& capture, const UdpEndpoint& to, const ReplayOptions& o) {
    if (!(o.rate == 0.0 || (o.rate >= kMinReplayRate && std::isfinite(o.rate))))
        throw std::invalid_argument(capture + ": the replay rate must be at least " + number_text(kMinReplayRate) +
                                    "× the recorded speed (or max), got " + number_text(o.rate));
    if (o.loops < 1) throw std::invalid_argument(capture + ": --loop must be >= 1");
    if (!(o.drop_fraction >= 0.0 && o.reorder_fraction >= 0.0 && o.drop_fraction + o.reorder_fraction <= 1.0))
        throw std::invalid_argument(capture + ": the drop and reorder fractions must be in [0, 1]");
    if (to.port < 1) throw std::invalid_argument(to.text + ": give the port to send to (ADDR:PORT)");
}

}  // namespace

ReplayStats replay_pcap(const std::string& capture, const UdpEndpoint& to, const ReplayOptions& options) {
    check_options(capture, to, options);
    ReplayStats stats;
    stats.lidar_port = busiest_port(capture);
    Sender sender(to, stats.lidar_port);
    std::mt19937 random(options.seed);
    const Clock::time_point began = Clock::now();
    Clock::time_point start = began;
    for (int loop = 0; loop < options.loops; ++loop) {
        Pass pass{capture, options, sender, stats, random, start};
        if (!pass.run()) break;
        // The next pass starts where this one's timing ended (a frame period's gap is in the capture already).
        const double span_s = options.rate > 0.0 ? stats.capture_seconds / options.rate : 0.0;
        start += std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(span_s + 1e-3));
    }
    stats.seconds = std::chrono::duration<double>(Clock::now() - began).count();
    return stats;
}

}  // namespace roadpreview
