// Benchmark of what a live frame waits for in the decoder: the time of the Ouster lidar packet that completes a
// frame (its own columns, then the frame built: the part of the decode that follows the frame's last datagram),
// next to the time of all its packets (the whole decode, spread over the rotation as the packets arrive).
//
// Every bundled Ouster recording's lidar packets are read into memory, then fed --loops times to a new decoder,
// single-threaded. With --roi-columns the decoder keeps only the columns that can see the default region of
// interest ahead (the sensor 1.97 m up, as on the OS1-128 recording), as `roadpreview run --roi-columns` does.
// Frames that no packet completes (a recording that ends before the rotation does) are not counted. A decoder's
// first frame is shown apart: its output lands in fresh pages (570–630 page faults for a 128-beam frame,
// measured), where a stream's later frames reuse the memory the frames before them freed (none).
// Prints a Markdown table on stdout: per recording, the completing packet's median / p90 ms of first and of later
// frames, and all packets' ms per frame counted (packets of frames not completed included).
//
// Built with the C++ tests: build/ctest/tests/frame_tail_bench [--loops N] [--roi-columns] [OUSTER_DIR]
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <string>
#include <vector>

#include <roadpreview/roadpreview.hpp>

namespace rp = roadpreview;
namespace fs = std::filesystem;

namespace {

struct Recording {
    fs::path pcap, meta;
};

// Each pcap with its metadata: the JSON of the same name, or the one the recording is known to need.
std::vector<Recording> recordings(const fs::path& dir) {
    std::vector<Recording> out;
    for (const auto& e : fs::directory_iterator(dir)) {
        if (e.path().extension() != ".pcap") continue;
        const std::string stem = e.path().stem().string();
        fs::path meta = dir / (stem + ".json");
        if (stem.rfind("OS-1-64_", 0) == 0) meta = dir / "OS-1-64_sensor_config_reduced.json";
        if (stem.rfind("OS-1-128_v2.3.0", 0) == 0) meta = dir / "OS-1-128_v2.3.0_1024x10.json";
        if (fs::exists(meta)) out.push_back({e.path(), meta});
    }
    std::sort(out.begin(), out.end(), [](const Recording& a, const Recording& b) { return a.pcap < b.pcap; });
    return out;
}

std::string fmt(double ms) {
    char text[32];
    std::snprintf(text, sizeof text, "%.3f", ms);
    return text;
}

double percentile(std::vector<double> v, double q) {
    std::sort(v.begin(), v.end());
    return v[std::min(v.size() - 1, static_cast<std::size_t>(q * static_cast<double>(v.size())))];
}

void measure(const Recording& r, int loops, bool roi_columns) {
    const rp::OusterMetadata meta = rp::read_ouster_metadata(r.meta.string());
    std::vector<rp::UdpDatagram> packets;
    rp::PcapReader reader(r.pcap.string());
    for (rp::UdpDatagram d; reader.next(d);)
        if (d.payload.size() == meta.lidar_packet_bytes()) packets.push_back(d);
    std::vector<double> first, later;  // completing packets of each decoder's first frame, of the frames after it
    double all_ms = 0.0;
    long long points = 0;
    for (int loop = 0; loop < loops; ++loop) {
        rp::OusterDecoder decoder(meta);  // a fresh one: the recording's frame ids again would be late packets
        if (roi_columns) {
            rp::Config cfg;
            cfg.sensor_height = 1.97;
            decoder.keep_columns_reaching({rp::sensor_roi(cfg, 1.0)});
        }
        bool first_frame = true;
        for (const rp::UdpDatagram& p : packets) {
            const auto start = std::chrono::steady_clock::now();
            const auto frame = decoder.add_packet(p.payload.data(), p.payload.size(), p.timestamp);
            const double ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
            all_ms += ms;
            if (!frame) continue;
            (first_frame ? first : later).push_back(ms);
            first_frame = false;
            points += frame->points.rows();
        }
    }
    const double frames = static_cast<double>(first.size() + later.size());
    if (frames == 0) return;
    const auto cell = [](const std::vector<double>& ms) {
        return ms.empty() ? std::string("–") : fmt(percentile(ms, 0.5)) + " / " + fmt(percentile(ms, 0.9));
    };
    std::printf("| %s | %d × %d | %.0f | %s | %zu | %s | %.3f |\n", r.pcap.filename().c_str(), meta.pixels_per_column,
                meta.columns_per_frame, static_cast<double>(points) / frames, cell(first).c_str(), later.size(),
                cell(later).c_str(), all_ms / frames);
}

}  // namespace

int main(int argc, char** argv) {
    int loops = 30;
    bool roi_columns = false;
    fs::path dir = fs::path(ROADPREVIEW_TEST_DATA) / "ouster";
    for (int i = 1; i < argc; ++i) {
        if (!std::strcmp(argv[i], "--loops") && i + 1 < argc)
            loops = std::max(1, std::atoi(argv[++i]));
        else if (!std::strcmp(argv[i], "--roi-columns"))
            roi_columns = true;
        else
            dir = argv[i];
    }
    std::printf("| recording | pixels × columns | points per frame | first frame: completing packet median / p90 ms "
                "| later frames | later frames: median / p90 ms | all packets ms per frame |\n"
                "|---|---|---|---|---|---|---|\n");
    try {
        for (const Recording& r : recordings(dir)) measure(r, loops, roi_columns);
    } catch (const std::exception& e) {
        std::fprintf(stderr, "frame_tail_bench: %s\n", e.what());
        return 1;
    }
    return 0;
}
