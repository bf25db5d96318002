// SPDX-License-Identifier: BSD-3-Clause
// Live UDP input against the replay on loopback: every bundled recording arrives whole and equal to its offline
// decode; dropped and reordered packets are flagged, never a crash; ports in use, silence, wrong-size datagrams
// and another sensor's packets are errors naming the address. Every run is bounded by a timeout and a duration.
#include <gtest/gtest.h>

#include <netinet/in.h>
#include <sys/socket.h>
#include <time.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cstdio>
#include <functional>
#include <future>
#include <thread>
#include <string>
#include <vector>

#include <roadpreview/io/live.hpp>
#include <roadpreview/io/readers.hpp>

namespace rp = roadpreview;

namespace {

const std::string kData = std::string(ROADPREVIEW_TEST_DATA) + "/";
const std::string kOs1 = kData + "ouster/OS-1-128_v2.3.0_1024x10_lb_n3.pcap";
const std::string kOs1Meta = kData + "ouster/OS-1-128_v2.3.0_1024x10.json";

// A socket bound to 127.0.0.1 (port 0: one the kernel picks); closed with the object.
struct BoundSocket {
    int fd = socket(AF_INET, SOCK_DGRAM, 0);
    int port = 0;
    explicit BoundSocket(int wanted = 0) {
        sockaddr_in a{};
        a.sin_family = AF_INET;
        a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
        a.sin_port = htons(static_cast<std::uint16_t>(wanted));
        if (bind(fd, reinterpret_cast<sockaddr*>(&a), sizeof a) != 0) return;
        socklen_t n = sizeof a;
        getsockname(fd, reinterpret_cast<sockaddr*>(&a), &n);
        port = ntohs(a.sin_port);
    }
    ~BoundSocket() { close(fd); }
    void send_to(int to_port, const std::vector<std::uint8_t>& bytes) const {
        sockaddr_in a{};
        a.sin_family = AF_INET;
        a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
        a.sin_port = htons(static_cast<std::uint16_t>(to_port));
        sendto(fd, bytes.data(), bytes.size(), 0, reinterpret_cast<sockaddr*>(&a), sizeof a);
    }
};

// A free port whose successor is free too (Ouster: lidar and IMU).
int free_port_pair() {
    for (int attempt = 0; attempt < 50; ++attempt) {
        BoundSocket a;
        if (a.port == 0 || a.port == 65535) continue;
        BoundSocket b(a.port + 1);
        if (b.port) return a.port;
    }
    return 0;
}

std::string url(int port) { return "udp://127.0.0.1:" + std::to_string(port); }

// The live source of the bundled OS1-128's packets on `port` (its IMU's on the next), ending after `timeout_s` of silence.
std::unique_ptr<rp::FrameSource> listen_os1(int port, double timeout_s) {
    rp::LiveOptions o;
    o.source.meta = kOs1Meta;
    o.timeout_s = timeout_s;
    return rp::open_live(url(port), o);
}

std::vector<rp::Frame> offline(const std::string& pcap, const std::string& meta,
                               const std::vector<rp::SensorRoi>& roi_columns = {}) {
    rp::SourceOptions o;
    o.meta = meta;
    o.roi_columns = roi_columns;
    auto source = rp::open_frames({pcap}, o);
    std::vector<rp::Frame> frames;
    while (auto f = source->next()) frames.push_back(std::move(*f));
    return frames;
}

struct LiveRun {
    std::vector<rp::Frame> frames;
    rp::SourceInfo info;
    rp::ReplayStats sent;
};

// Opens the live source, replays the capture to it from another thread and reads until the stream goes quiet.
LiveRun live(const std::string& pcap, const std::string& meta, rp::ReplayOptions replay = {},
             const std::vector<rp::SensorRoi>& roi_columns = {}, bool busy_wait = false) {
    const int port = free_port_pair();
    rp::LiveOptions o;
    o.busy_wait = busy_wait;
    o.source.meta = meta;
    o.source.roi_columns = roi_columns;
    // The silence that ends the stream, and the wait for its first datagram: ctest runs another test beside this
    // one (a max-rate replay fills both cores), and once the sender's first datagram came 0.5 s late.
    o.timeout_s = 1.0;
    o.duration_s = 30.0;  // a bound, never reached when all goes well
    auto source = rp::open_live(url(port), o);
    auto sender = std::async(std::launch::async, [&] {
        return rp::replay_pcap(pcap, rp::parse_udp_endpoint("127.0.0.1:" + std::to_string(port), false), replay);
    });
    LiveRun run;
    while (auto f = source->next()) run.frames.push_back(std::move(*f));
    run.sent = sender.get();
    run.info = source->info();
    return run;
}

rp::ReplayOptions at_max_rate() {
    rp::ReplayOptions r;
    r.rate = 0.0;
    return r;
}

std::string error_of(const std::function<void()>& f) {
    try {
        f();
    } catch (const std::exception& e) {
        return e.what();
    }
    return "";
}

void expect_same_frames(const std::vector<rp::Frame>& got, const std::vector<rp::Frame>& want) {
    ASSERT_EQ(got.size(), want.size());
    for (std::size_t k = 0; k < want.size(); ++k) {
        SCOPED_TRACE("frame " + std::to_string(k));
        EXPECT_EQ(got[k].frame_id, want[k].frame_id);
        ASSERT_EQ(got[k].points.rows(), want[k].points.rows());
        EXPECT_TRUE(got[k].points == want[k].points);
        EXPECT_EQ(got[k].beams, want[k].beams);
        EXPECT_EQ(got[k].point_times, want[k].point_times);
        EXPECT_EQ(got[k].imu.size(), want[k].imu.size());
        EXPECT_EQ(got[k].diagnostics.missing_columns, want[k].diagnostics.missing_columns);
        // A frame the end of the stream completes (its last columns never came) has no arrival to count from.
        if (k + 1 < want.size()) {
            EXPECT_GT(got[k].arrival_s, 0.0);
        }
        // Decoded and built after that datagram came; neither time for a frame the end of the stream completes.
        EXPECT_EQ(got[k].completed_s == 0.0, got[k].arrival_s == 0.0);
        EXPECT_GE(got[k].completed_s, got[k].arrival_s);
    }
}

// Every bundled Ouster and Velodyne recording with its metadata (Velodyne: none).
const std::vector<std::pair<std::string, std::string>> kRecordings = {
    {"ouster/OS-1-128_v2.3.0_1024x10_lb_n3.pcap", "ouster/OS-1-128_v2.3.0_1024x10.json"},
    {"ouster/OS-1-128_767798045_1024x10_20230712_120049.pcap", "ouster/OS-1-128_767798045_1024x10_20230712_120049.json"},
    {"ouster/OS-0-128-U1_v2.3.0_1024x10.pcap", "ouster/OS-0-128-U1_v2.3.0_1024x10.json"},
    {"ouster/OS-2-128-U1_v2.3.0_1024x10.pcap", "ouster/OS-2-128-U1_v2.3.0_1024x10.json"},
    {"ouster/OS-0-32-U1_v2.2.0_1024x10.pcap", "ouster/OS-0-32-U1_v2.2.0_1024x10.json"},
    {"ouster/OS-1-32-G_v2.1.1_1024x10.pcap", "ouster/OS-1-32-G_v2.1.1_1024x10.json"},
    {"ouster/OS-2-32-U0_v2.0.0_1024x10.pcap", "ouster/OS-2-32-U0_v2.0.0_1024x10.json"},
    {"ouster/OS-1-64_1024x10_fw20.pcap", "ouster/OS-1-64_sensor_config_reduced.json"},
    {"ouster/rust-lidar-utils/ouster_example.pcap", "ouster/rust-lidar-utils/ouster_example.json"},
    {"velodyne/hdl32_example.pcap", ""},
    {"velodyne/velodyne_example.pcap", ""},
    {"velodyne/velodyne_vlp16.pcap", ""},
    {"velodyne/velodyne_vlp32.pcap", ""},
};

void expect_every_recording_whole(const rp::ReplayOptions& replay) {
    for (const auto& [pcap, meta] : kRecordings) {
        SCOPED_TRACE(pcap);
        const std::string meta_path = meta.empty() ? "" : kData + meta;
        const LiveRun run = live(kData + pcap, meta_path, replay);
        EXPECT_EQ(run.info.datagrams_dropped, 0);
        EXPECT_EQ(run.info.format, meta.empty() ? "velodyne udp" : "ouster udp");
        expect_same_frames(run.frames, offline(kData + pcap, meta_path));
    }
}

}  // namespace

TEST(Live, EveryBundledRecordingArrivesWholeAtMaxRate) { expect_every_recording_whole(at_max_rate()); }

TEST(Live, EveryBundledRecordingArrivesWholeAtRecordedSpeed) { expect_every_recording_whole({}); }

TEST(Live, FramesLimitedToTheRegionsColumnsArriveAsOfflineAndEndAtTheirLastColumn) {
    rp::Config cfg;
    cfg.sensor_height = 1.97;
    const std::vector<rp::SensorRoi> ahead = {rp::sensor_roi(cfg, 1.0)};
    const auto want = offline(kOs1, kOs1Meta, ahead);
    const LiveRun got = live(kOs1, kOs1Meta, {}, ahead);  // at the recorded speed
    expect_same_frames(got.frames, want);
    // The region's columns (261–763 of 1024) span half a rotation: each frame ends 0.05 s after it began, a
    // quarter rotation before the sensor's last column would have ended it.
    for (const rp::Frame& f : got.frames) {
        EXPECT_TRUE(f.diagnostics.complete);
        EXPECT_LT(*std::max_element(f.point_times.begin(), f.point_times.end()), 0.05);
    }
}

TEST(Live, ABusyWaitingReaderGetsTheFramesOfASleepingOne) {
    expect_same_frames(live(kOs1, kOs1Meta, {}, {}, true).frames, offline(kOs1, kOs1Meta));  // recorded speed
    const std::string vlp16 = kData + "velodyne/velodyne_vlp16.pcap";
    expect_same_frames(live(vlp16, "", at_max_rate(), {}, true).frames, offline(vlp16, ""));
}

// CPU seconds of the calling thread.
double thread_cpu_s() {
    timespec t{};
    clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
    return static_cast<double>(t.tv_sec) + 1e-9 * static_cast<double>(t.tv_nsec);
}

TEST(Live, ABusyWaitingReaderKeepsItsCoreAndStillEndsAtTheTimeoutAndTheDuration) {
    rp::LiveOptions o;
    o.timeout_s = 0.3;
    // Waiting 0.3 s for a datagram that never comes: a sleeping reader uses next to no CPU, a busy one its core
    // (or its share of it beside the other tests ctest runs).
    double cpu_s[2];
    for (const bool busy : {false, true}) {
        o.busy_wait = busy;
        auto source = rp::open_live(url(free_port_pair()), o);
        const double t0 = rp::steady_now_s(), c0 = thread_cpu_s();
        const std::string e = error_of([&] { source->next(); });  // nothing sent
        cpu_s[busy] = thread_cpu_s() - c0;
        EXPECT_NE(e.find("no datagrams"), std::string::npos) << e;
        EXPECT_LT(rp::steady_now_s() - t0, 2.0);
    }
    EXPECT_LT(cpu_s[0], 0.03);
    EXPECT_GT(cpu_s[1], 0.06);

    o.busy_wait = true;
    o.timeout_s = 5.0;
    o.duration_s = 0.3;
    const double t0 = rp::steady_now_s();
    const std::string ended = error_of([&] { rp::open_live(url(free_port_pair()), o)->next(); });  // nothing sent
    EXPECT_NE(ended.find("no datagram arrived before the run ended"), std::string::npos) << ended;
    EXPECT_LT(rp::steady_now_s() - t0, 2.0);
}

TEST(Live, DroppedAndReorderedPacketsAreFlaggedNotFatal) {
    for (const std::string& pcap : {kOs1, kData + "velodyne/hdl32_example.pcap"}) {
        SCOPED_TRACE(pcap);
        const std::string meta = pcap == kOs1 ? kOs1Meta : "";
        rp::ReplayOptions r = at_max_rate();
        r.drop_fraction = 0.01;
        r.reorder_fraction = 0.01;
        r.loops = 4;  // 4 × the capture: ids (or sensor time) jump back at each loop, as after a sensor restart
        r.seed = 7;
        const LiveRun run = live(pcap, meta, r);
        ASSERT_GT(run.sent.dropped, 0);
        ASSERT_GT(run.sent.reordered, 0);
        const std::vector<rp::Frame> whole = offline(pcap, meta);
        // Every loop's frames come through (a restart starts a new frame), no more (a packet late across a frame's
        // end once made two more frames of one packet each); fewer points only where flagged.
        EXPECT_GE(run.frames.size(), whole.size() * 4 - 1);
        EXPECT_LE(run.frames.size(), whole.size() * 4);
        std::int64_t flagged = 0, lost = 0;
        for (const rp::Frame& f : run.frames) {
            const auto& d = f.diagnostics;
            const bool is_flagged = d.lost_packets > 0 || d.late_packets > 0 || !d.complete;
            flagged += is_flagged;
            lost += d.lost_packets + d.late_packets;
            const auto same = std::find_if(whole.begin(), whole.end(), [&](const rp::Frame& w) {
                return w.points.rows() == f.points.rows() && w.points == f.points;
            });
            if (same == whole.end()) {
                EXPECT_TRUE(is_flagged) << "frame " << f.frame_id << " differs but is not flagged";
            }
        }
        EXPECT_GT(flagged, 0);
        EXPECT_GE(lost, run.sent.dropped / 2);  // a dropped IMU or position packet is no lidar packet lost
    }
}

TEST(Live, APortInUseIsAnErrorNamingTheAddress) {
    BoundSocket taken;
    rp::LiveOptions o;
    const std::string e = error_of([&] { rp::open_live(url(taken.port), o); });
    EXPECT_NE(e.find(url(taken.port)), std::string::npos) << e;
    EXPECT_NE(e.find("already in use"), std::string::npos) << e;
}

TEST(Live, NoDatagramsWithinTheTimeoutIsAnErrorNamingTheAddress) {
    const int port = free_port_pair();
    rp::LiveOptions o;
    o.timeout_s = 0.3;
    auto source = rp::open_live(url(port), o);
    const std::string e = error_of([&] { source->next(); });
    EXPECT_NE(e.find(url(port)), std::string::npos) << e;
    EXPECT_NE(e.find("no datagrams within"), std::string::npos) << e;
}

// The IMU's datagrams alone once kept the run waiting for as long as they came: silence is the lidar port's.
TEST(Live, AnImuThatGoesOnAloneDoesNotKeepTheRunWaiting) {
    const int port = free_port_pair();
    auto source = listen_os1(port, 0.3);
    std::atomic<bool> stop{false};
    auto imu = std::async(std::launch::async, [&] {
        BoundSocket sender;
        for (int k = 0; k < 500 && !stop; ++k) {  // up to 5 s of an IMU at 100 Hz
            sender.send_to(port + 1, std::vector<std::uint8_t>(48, 0));
            std::this_thread::sleep_for(std::chrono::milliseconds(10));
        }
    });
    const double t0 = rp::steady_now_s();
    const std::string e = error_of([&] {
        while (source->next()) {
        }
    });
    const double took_s = rp::steady_now_s() - t0;
    stop = true;
    imu.get();
    EXPECT_NE(e.find(url(port) + ": no datagrams on this port within 0.3 s"), std::string::npos) << e;
    EXPECT_LT(took_s, 2.0);
}

TEST(Live, AWrongSizeDatagramIsAnErrorNamingTheAddress) {
    const int port = free_port_pair();
    auto source = listen_os1(port, 2.0);
    BoundSocket sender;
    sender.send_to(port, std::vector<std::uint8_t>(100, 0));
    const std::string e = error_of([&] { source->next(); });
    EXPECT_NE(e.find(url(port)), std::string::npos) << e;
    EXPECT_NE(e.find("datagram 1"), std::string::npos) << e;
    EXPECT_NE(e.find("100 bytes"), std::string::npos) << e;
}

TEST(Live, AnotherSensorsPacketsAreAnErrorNamingTheAddress) {
    const int port = free_port_pair();
    rp::LiveOptions o;
    o.source.meta = kOs1Meta;  // an OS-1-128 in RNG15_RFL8_NIR8; an OS-0-32 in RNG19_RFL8_SIG16_NIR16_DUAL is sent
    o.timeout_s = 2.0;
    auto source = rp::open_live(url(port), o);
    auto sender = std::async(std::launch::async, [&] {
        return rp::replay_pcap(kData + "ouster/OS-0-32-U1_v2.2.0_1024x10.pcap",
                               rp::parse_udp_endpoint("127.0.0.1:" + std::to_string(port), false), at_max_rate());
    });
    const std::string e = error_of([&] {
        while (source->next()) {
        }
    });
    sender.get();
    EXPECT_NE(e.find(url(port)), std::string::npos) << e;
    EXPECT_NE(e.find("the metadata belongs to another sensor"), std::string::npos) << e;
}

TEST(Live, TheDurationEndsAStreamThatNeverGoesQuiet) {
    const int port = free_port_pair();
    rp::LiveOptions o;
    o.source.meta = kOs1Meta;
    o.duration_s = 0.5;
    auto source = rp::open_live(url(port), o);
    rp::ReplayOptions r;
    r.loops = 1000;  // far longer than the duration; stopped below
    std::atomic<bool> stop{false};
    r.progress = [&](std::int64_t) { return !stop.load(); };
    auto sender = std::async(std::launch::async, [&] {
        return rp::replay_pcap(kOs1, rp::parse_udp_endpoint("127.0.0.1:" + std::to_string(port), false), r);
    });
    const double t0 = rp::steady_now_s();
    int frames = 0;
    while (source->next()) ++frames;
    const double took_s = rp::steady_now_s() - t0;
    stop = true;
    sender.get();
    EXPECT_GE(frames, 2);
    EXPECT_LT(took_s, 2.0);
}

TEST(Live, EndpointsAreParsedOrRefusedByName) {
    const rp::UdpEndpoint a = rp::parse_udp_endpoint("udp://127.0.0.1:7502");
    EXPECT_EQ(a.address, "127.0.0.1");
    EXPECT_EQ(a.port, 7502);
    const rp::UdpEndpoint b = rp::parse_udp_endpoint("udp://:2368");
    EXPECT_EQ(b.address, "");
    EXPECT_EQ(b.port, 2368);
    EXPECT_EQ(rp::parse_udp_endpoint("udp://10.5.5.1").port, 0);
    for (const std::string bad : {"udp://127.0.0.1:0", "udp://127.0.0.1:70000", "udp://127.0.0.1:x", "tcp://a:1"}) {
        const std::string e = error_of([&] { rp::parse_udp_endpoint(bad); });
        EXPECT_NE(e.find(bad), std::string::npos) << e;
    }
    EXPECT_NE(error_of([] { rp::parse_udp_endpoint("127.0.0.1", false); }).find("no port"), std::string::npos);
    // They read "cannot resolve the address (Name or service not known)".
    EXPECT_NE(error_of([] { rp::open_live("udp://[::1]:47560", {}); }).find("[::1] is an IPv6 address; give an IPv4"),
              std::string::npos);
    rp::ReplayOptions r;
    EXPECT_NE(error_of([&] { rp::replay_pcap(kOs1, rp::parse_udp_endpoint("udp://127.0.0.1:47560", false), r); })
                  .find("give the address as ADDR:PORT, without a scheme"),
              std::string::npos);
}

TEST(Live, ReplayOfACaptureWithoutUdpIsAnErrorNamingTheFile) {
    // A pcap of one ARP frame: no UDP datagram to send.
    const std::string path = testing::TempDir() + "arp_only.pcap";
    std::vector<std::uint8_t> bytes = {0xd4, 0xc3, 0xb2, 0xa1, 2, 0, 4, 0, 0, 0, 0, 0, 0, 0, 0, 0,
                                       0xff, 0xff, 0, 0, 1, 0, 0, 0};  // little-endian header, Ethernet
    std::vector<std::uint8_t> frame(42, 0);
    frame[12] = 0x08;
    frame[13] = 0x06;  // ARP
    const std::uint32_t len = static_cast<std::uint32_t>(frame.size());
    for (std::uint32_t v : {1u, 0u, len, len})
        for (int k = 0; k < 4; ++k) bytes.push_back(static_cast<std::uint8_t>(v >> (8 * k)));
    bytes.insert(bytes.end(), frame.begin(), frame.end());
    FILE* f = std::fopen(path.c_str(), "wb");
    std::fwrite(bytes.data(), 1, bytes.size(), f);
    std::fclose(f);
    const std::string e = error_of([&] { rp::replay_pcap(path, rp::parse_udp_endpoint("127.0.0.1:9", false)); });
    EXPECT_NE(e.find(path), std::string::npos) << e;
    EXPECT_NE(e.find("no UDP datagrams"), std::string::npos) << e;
}
