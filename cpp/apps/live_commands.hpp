// SPDX-License-Identifier: BSD-3-Clause
// Live input in the CLI: `roadpreview replay CAPTURE --to ADDR:PORT`, and what `run udp://...` adds to a run
// (its options, the latency of every frame, the live summary).
#pragma once

#include <cstdint>
#include <functional>
#include <vector>

#include <CLI/CLI.hpp>

#include "bounded_sample.hpp"
#include "roadpreview/roadpreview.hpp"

/// Adds the `replay` subcommand; returns the action to run when it was parsed (exit status).
std::function<int()> add_replay_command(CLI::App& app);

/// `run`'s options for a udp:// input.
struct LiveRunOptions {
    double duration_s = 0.0;
    double timeout_s = 5.0;
    bool busy_wait = false;
};
void add_live_options(CLI::App* run, LiveRunOptions& o);

/// Per-frame latency (the arrival of the datagram that completed the frame → its output line written), the
/// parts of it outside the pipeline, and the packet counts of a live run, for the summary.
class LiveStats {
public:
    /// Call once the frame's output line is written; `result_s`: steady-clock time its result was ready.
    void add(const roadpreview::Frame& f, double result_s);
    void print(const roadpreview::SourceInfo& info) const;
    static std::string describe(const roadpreview::FrameDiagnostics& d);  ///< ", 3 packets lost, ..." or empty

private:
    BoundedSample latency_ms_;
    BoundedSample completing_ms_;  // the datagram's arrival → the frame complete (queue, decode, frame built)
    BoundedSample output_ms_;      // the result ready → its output line written
    std::int64_t frames_ = 0, affected_ = 0, lost_ = 0, late_ = 0, duplicate_ = 0, skipped_ = 0, missing_columns_ = 0;
};
