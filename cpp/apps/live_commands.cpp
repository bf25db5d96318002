// SPDX-License-Identifier: BSD-3-Clause
#include "live_commands.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <memory>
#include <string>

#include "cli_checks.hpp"

namespace rp = roadpreview;

namespace {

struct ReplayArgs {
    std::string capture;
    std::string to = "127.0.0.1:7502";
    std::string rate = "1.0";
    int loops = 1;
    double drop = 0.0, reorder = 0.0;
    unsigned seed = 1;
    bool quiet = false;
};

double parse_rate(const std::string& text) {
    if (text == "max") return 0.0;
    std::size_t used = 0;
    double v = -1.0;
    try {
        v = std::stod(text, &used);
    } catch (const std::exception&) {
    }
    if (used != text.size() || !std::isfinite(v) || v < rp::kMinReplayRate)
        throw roadpreview::cli::UsageError("--rate " + text + ": expected a factor of at least 0.001 (1.0 = "
                                           "recorded speed) or max");
    static_assert(rp::kMinReplayRate == 1e-3, "the message above names it");
    return v;
}

int replay(const ReplayArgs& a) {
    rp::ReplayOptions o;
    o.rate = parse_rate(a.rate);
    o.loops = a.loops;
    o.drop_fraction = a.drop;
    o.reorder_fraction = a.reorder;
    o.seed = a.seed;
    const rp::UdpEndpoint to = [&] {
        try {
            return rp::parse_udp_endpoint(a.to, false);
        } catch (const std::invalid_argument& e) {
            throw roadpreview::cli::UsageError(std::string("--to: ") + e.what());
        }
    }();
    if (!a.quiet) std::fprintf(stderr, "roadpreview: replaying %s to %s at %s\n", a.capture.c_str(), a.to.c_str(),
                               o.rate > 0.0 ? (a.rate + "×").c_str() : "max rate");
    const rp::ReplayStats s = rp::replay_pcap(a.capture, to, o);
    std::fprintf(stderr,
                 "roadpreview: sent %lld datagrams (%.1f MB) in %.2f s, %d loop(s) of %.2f s of capture; the lidar "
                 "port %d went to %d; %lld dropped and %lld reordered on purpose\n",
                 static_cast<long long>(s.sent), 1e-6 * static_cast<double>(s.bytes), s.seconds, a.loops,
                 s.capture_seconds, s.lidar_port, to.port, static_cast<long long>(s.dropped),
                 static_cast<long long>(s.reordered));
    if (s.clock_jumps)
        std::fprintf(stderr, "roadpreview: warning: %s: its clock jumped by more than %g s %lld time(s) between two "
                             "records; those were sent one after the other\n",
                     a.capture.c_str(), rp::kMaxReplayGapS, static_cast<long long>(s.clock_jumps / a.loops));
    return 0;
}

}  // namespace

std::function<int()> add_replay_command(CLI::App& app) {
    auto a = std::make_shared<ReplayArgs>();
    CLI::App* cmd = app.add_subcommand(
        "replay", "Send a capture's UDP payloads to an address with their recorded timing (to test live input)");
    cmd->add_option("CAPTURE", a->capture, "A .pcap or .pcapng recording")->required();
    cmd->add_option("--to", a->to, "ADDR:PORT for the lidar datagrams; other ports keep their distance from it "
                                   "(default 127.0.0.1:7502)");
    cmd->add_option("--rate", a->rate, "Times the recorded speed, or max (default 1.0)");
    cmd->add_option("--loop", a->loops, "Times through the capture (default 1)")
        ->check(roadpreview::cli::positive_finite());
    cmd->add_option("--drop", a->drop, "Test hook: fraction of datagrams not sent (default 0)")
        ->check(CLI::Range(0.0, 1.0));
    cmd->add_option("--reorder", a->reorder, "Test hook: fraction of datagrams sent after the next one (default 0)")
        ->check(CLI::Range(0.0, 1.0));
    cmd->add_option("--seed", a->seed, "Seed of the drop and reorder draws (default 1)");
    cmd->add_flag("-q,--quiet", a->quiet, "Only the final count on stderr");
    return [cmd, a] { return cmd->parsed() ? replay(*a) : -1; };
}

void add_live_options(CLI::App* run, LiveRunOptions& o) {
    run->add_option("--duration", o.duration_s, "udp:// input: end the run after S seconds")
        ->check(roadpreview::cli::positive_finite());
    run->add_option("--timeout", o.timeout_s,
                    "udp:// input: no datagram for S seconds ends the stream; none at all is an error (default 5)")
        ->check(roadpreview::cli::positive_finite());
    run->add_flag("--busy-wait", o.busy_wait,
                  "udp:// input: wait for datagrams on a busy core instead of sleeping (lower latency tail, one core "
                  "kept busy)");
}

void LiveStats::add(const rp::Frame& f, double result_s) {
    ++frames_;
    if (f.arrival_s > 0.0) {
        const double written_s = rp::steady_now_s();
        latency_ms_.add(1e3 * (written_s - f.arrival_s));
        completing_ms_.add(1e3 * (f.completed_s - f.arrival_s));
        output_ms_.add(1e3 * (written_s - result_s));
    }
    const rp::FrameDiagnostics& d = f.diagnostics;
    affected_ += d.lost_packets || d.late_packets || d.missing_columns || d.skipped_packets;
    skipped_ += d.skipped_packets;
    lost_ += d.lost_packets;
    late_ += d.late_packets;
    duplicate_ += d.duplicate_packets;
    missing_columns_ += d.missing_columns;
}

std::string LiveStats::describe(const rp::FrameDiagnostics& d) {
    std::string out;
    if (d.lost_packets) out += ", " + std::to_string(d.lost_packets) + " packets lost";
    if (d.late_packets) out += ", " + std::to_string(d.late_packets) + " late packets dropped";
    if (d.duplicate_packets) out += ", " + std::to_string(d.duplicate_packets) + " duplicate packets";
    return out;
}

void LiveStats::print(const rp::SourceInfo& info) const {
    std::fprintf(stderr, "roadpreview: live: %lld datagrams received, %lld dropped by a full queue; %lld of %lld "
                 "frames affected (%lld packets lost, %lld late, %lld duplicates, %lld bad packets skipped, %lld "
                 "columns missing)",
                 static_cast<long long>(info.datagrams_received), static_cast<long long>(info.datagrams_dropped),
                 static_cast<long long>(affected_), static_cast<long long>(frames_), static_cast<long long>(lost_),
                 static_cast<long long>(late_), static_cast<long long>(duplicate_), static_cast<long long>(skipped_),
                 static_cast<long long>(missing_columns_));
    if (!latency_ms_.empty())
        std::fprintf(stderr, "; latency last packet → result p50 %.2f ms, p99 %.2f ms, max %.2f ms (outside the "
                     "pipeline, medians: frame complete %.2f ms after its last packet, output line %.2f ms)",
                     latency_ms_.percentile(0.5), latency_ms_.percentile(0.99), latency_ms_.max(),
                     completing_ms_.percentile(0.5), output_ms_.percentile(0.5));
    std::fprintf(stderr, "\n");
}
