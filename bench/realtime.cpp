// SPDX-License-Identifier: BSD-3-Clause
// Benchmark of the real-time API on the bundled KITTI frames: per-frame time of process() returning a new Result
// against process(..., out) reusing one, and the heap allocations of each per frame (a counting operator new),
// for the default pipeline (zone ground, obstacles on) with fusion none, EMA and Kalman.
//   realtime_bench [--frames N] [--warmup W] [--fusion none|ema|kalman] [--threads T]     (bench/README.md)
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <string>
#include <vector>

#include <roadpreview/roadpreview.hpp>

#include "../tests/cpp/counting_allocator.hpp"

namespace rp = roadpreview;

namespace {

struct Measured {
    double median_ms, p90_ms;
    long median_allocations, max_allocations;
};

double quantile(std::vector<double> v, double q) {
    std::sort(v.begin(), v.end());
    return v[static_cast<std::size_t>(q * static_cast<double>(v.size() - 1) + 0.5)];
}

struct Sample {
    std::vector<double> ms;
    std::vector<long> allocations;

    Measured summary() const {
        const std::vector<double> a(allocations.begin(), allocations.end());
        return {quantile(ms, 0.5), quantile(ms, 0.9), static_cast<long>(quantile(a, 0.5)),
                *std::max_element(allocations.begin(), allocations.end())};
    }
};

// One call of `process` on frame k of the recording (k mod 3, 0.1 s apart), timed and its allocations counted.
template <class Process>
void run_frame(const std::vector<rp::Frame>& kitti, int k, bool keep, Process&& process, Sample& into) {
    const rp::Frame& f = kitti[static_cast<std::size_t>(k) % kitti.size()];
    rp::FrameMotion motion;
    motion.timestamp_s = 0.1 * k;
    on_frame(k);
    const auto start = std::chrono::steady_clock::now();
    const long n = allocations_in([&] { process(f, motion); });
    const double elapsed = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
    if (!keep) return;
    into.ms.push_back(elapsed);
    into.allocations.push_back(n);
}

double load_average() {
    std::ifstream in("/proc/loadavg");
    double load = 0.0;
    in >> load;
    return load;
}

}  // namespace

int main(int argc, char** argv) {
    int frames = 60, warmup = 5, threads = 1;
    std::string only;  // one fusion method (a profiler's run), else all three
    for (int i = 1; i + 1 < argc; i += 2) {
        if (!std::strcmp(argv[i], "--frames")) frames = std::max(1, std::atoi(argv[i + 1]));
        else if (!std::strcmp(argv[i], "--warmup")) warmup = std::max(0, std::atoi(argv[i + 1]));
        else if (!std::strcmp(argv[i], "--fusion")) only = argv[i + 1];
        else if (!std::strcmp(argv[i], "--threads")) threads = std::max(1, std::atoi(argv[i + 1]));
    }
    if (!only.empty() && only != "none" && only != "ema" && only != "kalman") {
        std::fprintf(stderr, "realtime_bench: --fusion must be none, ema or kalman, got \"%s\"\n", only.c_str());
        return 2;
    }
    std::vector<rp::Frame> kitti;
    for (const char* name : {"000000.bin", "000001.bin", "000002.bin"})
        kitti.push_back(rp::read_frame(std::string(ROADPREVIEW_TEST_DATA) + "/semantickitti/" + name));
    std::printf("KITTI frames 000000-000002 cycled, %d measured after %d warm-up, %d thread(s), load average %.2f\n\n",
                frames, warmup, threads, load_average());
    std::printf("| fusion | call | median ms | p90 ms | allocations per frame (median) | max |\n");
    std::printf("|---|---|---|---|---|---|\n");
    const std::pair<rp::FusionMethod, const char*> methods[] = {
        {rp::FusionMethod::None, "none"}, {rp::FusionMethod::Ema, "ema"}, {rp::FusionMethod::Kalman, "kalman"}};
    for (const auto& [method, name] : methods) {
        if (!only.empty() && only != name) continue;
        rp::Config cfg;
        cfg.sensor_height = 1.73;
        cfg.fusion.method = method;
        cfg.threads = threads;
        rp::Estimator fresh(cfg), reusing(cfg);
        rp::Result out;
        Sample returning, reused;  // the two calls take turns frame by frame: both see the same load
        for (int k = 0; k < warmup + frames; ++k) {
            run_frame(kitti, k, k >= warmup, [&](const rp::Frame& f, const rp::FrameMotion& m) {
                const rp::Result r = fresh.process(f, 5.0, 0.02, m);
                if (r.frame < 0) std::abort();  // keeps the result alive
            }, returning);
            run_frame(kitti, k, k >= warmup, [&](const rp::Frame& f, const rp::FrameMotion& m) {
                reusing.process(f, 5.0, 0.02, m, out);
            }, reused);
        }
        const Measured a = returning.summary(), b = reused.summary();
        std::printf("| %s | process() → Result | %.2f | %.2f | %ld | %ld |\n", name, a.median_ms, a.p90_ms,
                    a.median_allocations, a.max_allocations);
        std::printf("| %s | process(..., out) | %.2f | %.2f | %ld | %ld |\n", name, b.median_ms, b.p90_ms,
                    b.median_allocations, b.max_allocations);
    }
    std::printf("\nload average after: %.2f\n", load_average());
    return 0;
}
