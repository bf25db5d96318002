// SPDX-License-Identifier: BSD-3-Clause
// Live sensors over UDP: a receive thread per source fills a bounded queue; the packets are assembled into frames
// by the same decoders as the pcap readers. And the replay of a capture's UDP payloads with their recorded timing.
#pragma once

#include <atomic>
#include <cstdint>
#include <functional>
#include <memory>
#include <string>

#include "roadpreview/io/frame_source.hpp"
#include "roadpreview/io/readers.hpp"

namespace roadpreview {

/// An address to receive on or send to, from "udp://[ADDR][:PORT]" (or "ADDR:PORT" for replay's --to).
struct UdpEndpoint {
    std::string address;  ///< numeric IPv4 or a host name; empty: every local address (0.0.0.0)
    int port = 0;         ///< 0: not given
    std::string text;     ///< as given, for messages
};

/// Parses "udp://ADDR:PORT", "udp://:PORT", "udp://ADDR" (`with_scheme`), or "ADDR:PORT". Throws
/// std::invalid_argument naming the text when it is malformed (a port outside 1..65535, a missing scheme).
UdpEndpoint parse_udp_endpoint(const std::string& text, bool with_scheme = true);

/// True for an input given as "udp://...".
bool is_udp_url(const std::string& input);

struct LiveOptions {
    SourceOptions source;  ///< meta given: Ouster (its lidar and IMU ports), else Velodyne (data port 2368)
    /// No datagram for this long: before the first one an error naming the address; after it the stream has
    /// ended (the frame being assembled is returned, then the end).
    double timeout_s = 5.0;
    double duration_s = 0.0;  ///< > 0: the stream ends after this long (s, from opening)
    /// When given, the stream ends as soon as it is true (as at `duration_s`): a signal handler's flag, so that a
    /// run stopped by Ctrl-C still returns its last frame and its caller writes its summary.
    const std::atomic<bool>* stop = nullptr;
    /// the receive queue's size, a ring allocated and zeroed once when the input opens (in memory in full from
    /// the start): datagrams that do not fit are dropped and counted
    std::size_t queue_bytes = std::size_t{64} << 20;
    int receive_buffer_bytes = 16 << 20;               ///< the sockets' kernel receive buffer (SO_RCVBUF)
    /// The reader waits for the next datagram by polling the queue (yielding the core to any other thread that
    /// wants it) instead of sleeping until woken: a core kept busy between datagrams, and each frame processed on a
    /// core that did not go idle — the 99th percentile of the latency about 1 ms lower (README "Live sensors").
    bool busy_wait = false;
};

/// Opens UDP sockets on the endpoint (Ouster: the URL's port, else the metadata's lidar port, and the metadata's
/// IMU port moved by as much as the lidar port was, or the next port when the metadata names none; Velodyne: the
/// URL's port, else 2368) and returns frames as
/// they complete. Each frame's `arrival_s` is the steady-clock time of the datagram that completed it, its
/// diagnostics count lost, late and duplicate packets and missing columns. Throws std::runtime_error naming the
/// address when a port is in use or cannot be bound; next() throws when no datagram arrives within the timeout,
/// or when a datagram does not fit the sensor (size, serial number) unless source.skip_bad_packets.
std::unique_ptr<FrameSource> open_live(const std::string& url, const LiveOptions& options = {});

/// Seconds on the steady clock, the clock of Frame::arrival_s.
double steady_now_s();

/// The slowest replay: 1000 times slower than recorded (slower, a capture's offsets overflow the clock's ticks).
constexpr double kMinReplayRate = 1e-3;

struct ReplayOptions {
    double rate = 1.0;  ///< times the recorded speed, at least kMinReplayRate; 0: as fast as possible ("max")
    int loops = 1;      ///< times through the capture
    /// Test hook: fractions of the datagrams dropped and sent late (swapped with the next one), drawn with `seed`.
    double drop_fraction = 0.0;
    double reorder_fraction = 0.0;
    std::uint32_t seed = 1;
    /// Called after each datagram sent, with the count so far; returning false stops the replay.
    std::function<bool(std::int64_t)> progress;
};

struct ReplayStats {
    std::int64_t sent = 0, dropped = 0, reordered = 0, bytes = 0;
    int lidar_port = 0;          ///< the capture's port that carried the most bytes (sent to the given port)
    double seconds = 0.0;        ///< wall time
    double capture_seconds = 0.0;  ///< the capture's span, per loop, its clock's jumps closed
    /// Steps of the capture's clock of more than kMaxReplayGapS between two records, per loop: sent one after the
    /// other instead of after the gap (a clock set while capturing; a record from 1970 or 2106).
    std::int64_t clock_jumps = 0;
};

/// Longest silence a replay keeps, s: a sensor sends every millisecond.
constexpr double kMaxReplayGapS = 5.0;

/// Sends the UDP payloads of `capture` (pcap or pcapng) to `to` with their recorded timing: the capture's busiest
/// destination port goes to `to.port`, every other port keeps its distance from it (Ouster IMU: lidar port + 1).
/// Throws std::runtime_error naming the file when it holds no UDP datagram, and naming the address when sending
/// fails.
ReplayStats replay_pcap(const std::string& capture, const UdpEndpoint& to, const ReplayOptions& options = {});

}  // namespace roadpreview
