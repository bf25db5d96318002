// SPDX-License-Identifier: BSD-3-Clause
// Internal: a frame's independent pieces of work on several threads (oneTBB, Config::threads). With one thread the
// work runs on the caller alone; with more, in an arena of that many threads shared by every caller asking for as
// many (what a worker throws is rethrown on the caller).
#pragma once

#include <algorithm>
#include <map>
#include <memory>
#include <mutex>

#include <tbb/info.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_invoke.h>
#include <tbb/partitioner.h>
#include <tbb/task_arena.h>

namespace roadpreview {

/// The threads a frame may use when `asked` for: at most as many as the process may run at once (its CPU affinity).
inline int usable_threads(int asked) { return std::clamp(asked, 1, std::max(1, tbb::info::default_concurrency())); }

/// The arena of `threads` threads (the caller's included), made on its first use.
inline tbb::task_arena& arena_of(int threads) {
    static std::mutex made;
    static std::map<int, std::unique_ptr<tbb::task_arena>> arenas;
    const std::lock_guard<std::mutex> lock(made);
    std::unique_ptr<tbb::task_arena>& arena = arenas[threads];
    if (!arena) arena = std::make_unique<tbb::task_arena>(threads);
    return *arena;
}

/// body(k, t) for k in [0, n), on up to `threads` threads taking the next k as they finish one; t is the thread's
/// number in [0, threads) (for per-thread buffers).
template <class Body>
void parallel_for(int n, int threads, Body&& body) {
    if (threads <= 1 || n <= 1) {
        for (int k = 0; k < n; ++k) body(k, 0);
        return;
    }
    arena_of(threads).execute([&] {
        tbb::parallel_for(
            0, n, [&](int k) { body(k, tbb::this_task_arena::current_thread_index()); }, tbb::simple_partitioner());
    });
}

/// a() and b(), side by side on two threads when `parallel`, else one after the other.
template <class A, class B>
void run_both(bool parallel, A&& a, B&& b) {
    if (!parallel) {
        a();
        b();
        return;
    }
    arena_of(2).execute([&] { tbb::parallel_invoke(a, b); });
}

}  // namespace roadpreview
