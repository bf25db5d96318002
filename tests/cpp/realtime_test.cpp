// SPDX-License-Identifier: BSD-3-Clause
// The real-time API: process(..., Result& out) allocates nothing per frame once warm, and try_process reports
// errors as a Status with the throwing variant's message. Its own executable: it replaces the global allocator.
#include <gtest/gtest.h>

#include <atomic>
#include <cmath>
#include <cstdlib>
#include <limits>
#include <new>
#include <string>
#include <vector>

#include <roadpreview/roadpreview.hpp>

#include "scenes.hpp"

namespace {

std::atomic<bool> counting{false};
std::atomic<long> allocations{0};
// Breakpoints here (gdb: `break on_counted_allocation`, then `bt`) show where a counted allocation comes from, and
// in which frame (on_frame's argument).
[[gnu::noinline]] void on_frame(int k) { asm volatile("" : : "r"(k)); }
[[gnu::noinline]] void on_counted_allocation() { allocations.fetch_add(1, std::memory_order_relaxed); }

void* allocate(std::size_t size, std::size_t alignment = 0) {
    if (counting.load(std::memory_order_relaxed)) on_counted_allocation();
    if (size == 0) size = 1;
    void* p = nullptr;
    if (alignment > alignof(std::max_align_t)) {
        if (posix_memalign(&p, alignment, size) != 0) p = nullptr;
    } else {
        p = std::malloc(size);
    }
    return p;
}

void* allocate_or_throw(std::size_t size, std::size_t alignment = 0) {
    void* p = allocate(size, alignment);
    if (!p) throw std::bad_alloc();
    return p;
}

}  // namespace

void* operator new(std::size_t size) { return allocate_or_throw(size); }
void* operator new[](std::size_t size) { return allocate_or_throw(size); }
void* operator new(std::size_t size, const std::nothrow_t&) noexcept { return allocate(size); }
void* operator new[](std::size_t size, const std::nothrow_t&) noexcept { return allocate(size); }
void* operator new(std::size_t size, std::align_val_t a) { return allocate_or_throw(size, std::size_t(a)); }
void* operator new[](std::size_t size, std::align_val_t a) { return allocate_or_throw(size, std::size_t(a)); }
void* operator new(std::size_t size, std::align_val_t a, const std::nothrow_t&) noexcept {
    return allocate(size, std::size_t(a));
}
void* operator new[](std::size_t size, std::align_val_t a, const std::nothrow_t&) noexcept {
    return allocate(size, std::size_t(a));
}
void operator delete(void* p) noexcept { std::free(p); }
void operator delete[](void* p) noexcept { std::free(p); }
void operator delete(void* p, std::size_t) noexcept { std::free(p); }
void operator delete[](void* p, std::size_t) noexcept { std::free(p); }
void operator delete(void* p, std::align_val_t) noexcept { std::free(p); }
void operator delete[](void* p, std::align_val_t) noexcept { std::free(p); }
void operator delete(void* p, std::size_t, std::align_val_t) noexcept { std::free(p); }
void operator delete[](void* p, std::size_t, std::align_val_t) noexcept { std::free(p); }

namespace rp = roadpreview;

namespace {

const std::string kData = ROADPREVIEW_TEST_DATA;

// Allocations made by `step` (operator new of any form, from any thread).
template <class F>
long allocations_in(F&& step) {
    allocations = 0;
    counting = true;
    step();
    counting = false;
    return allocations.load();
}

// The three consecutive KITTI frames, driven again and again: frame k is frame k mod 3, 0.5 m further on.
std::vector<rp::Frame> kitti_frames() {
    std::vector<rp::Frame> frames;
    for (const char* name : {"000000.bin", "000001.bin", "000002.bin"})
        frames.push_back(rp::read_frame(kData + "/semantickitti/" + name));
    return frames;
}

rp::Config kitti_config(rp::FusionMethod fusion) {
    rp::Config cfg;
    cfg.sensor_height = 1.73;
    cfg.fusion.method = fusion;
    return cfg;
}

rp::FrameMotion motion_at(int k) {
    rp::FrameMotion m;
    m.timestamp_s = 0.1 * k;
    return m;
}

// Allocations of each of frames [first, last) after `first` warm-up frames, the same Result reused throughout.
std::vector<long> kitti_allocations(const rp::Config& cfg, int first, int last) {
    const std::vector<rp::Frame> frames = kitti_frames();
    rp::Estimator est(cfg);
    rp::Result out;
    std::vector<long> counts;
    for (int k = 0; k < last; ++k) {
        const rp::Frame& f = frames[static_cast<std::size_t>(k) % frames.size()];
        const rp::FrameMotion motion = motion_at(k);
        on_frame(k);
        const long n = allocations_in([&] { est.process(f, 5.0, 0.02, motion, out); });
        if (k >= first) counts.push_back(n);
    }
    return counts;
}

}  // namespace

TEST(Realtime, KittiFramesAllocateNothingOnceWarmWithKalmanFusionAndObstacles) {
    const auto counts = kitti_allocations(kitti_config(rp::FusionMethod::Kalman), 5, 20);
    for (std::size_t k = 0; k < counts.size(); ++k) EXPECT_EQ(counts[k], 0) << "frame " << k + 5;
}
