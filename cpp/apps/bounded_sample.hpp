// SPDX-License-Identifier: BSD-3-Clause
// A run's per-frame values (pipeline time, IRI, live latency) for its summary line, in bounded memory: every value
// up to `capacity` (exact medians and percentiles for runs up to that many frames), then a uniform random sample of
// all of them (Vitter's algorithm R), so a live run of days does not grow by 8 bytes a frame and value.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <random>
#include <vector>

class BoundedSample {
public:
    explicit BoundedSample(std::size_t capacity = 100000) : capacity_(capacity) {}

    void add(double v) {
        ++count_;
        max_ = std::max(max_, v);
        if (values_.size() < capacity_) {
            values_.push_back(v);
            return;
        }
        const std::uint64_t slot = std::uniform_int_distribution<std::uint64_t>(0, count_ - 1)(rng_);
        if (slot < capacity_) values_[slot] = v;
    }

    bool empty() const { return count_ == 0; }
    std::uint64_t count() const { return count_; }
    double max() const { return max_; }
    /// The value below which a fraction q of them lie (the ⌈q·n⌉-th smallest); median(): the middle one, or the mean
    /// of the two middle ones of an even count (as Python's statistics.median and the batch's summary take it).
    /// NaN before the first value.
    double percentile(double q) const {
        if (empty()) return std::numeric_limits<double>::quiet_NaN();
        const std::vector<double> v = sorted();
        const auto k = static_cast<std::size_t>(std::ceil(q * static_cast<double>(v.size()))) - 1;
        return v[std::min(k, v.size() - 1)];
    }
    double median() const {
        if (empty()) return std::numeric_limits<double>::quiet_NaN();
        const std::vector<double> v = sorted();
        const std::size_t mid = v.size() / 2;
        return v.size() % 2 ? v[mid] : 0.5 * (v[mid - 1] + v[mid]);
    }

private:
    std::vector<double> sorted() const {
        std::vector<double> v = values_;
        std::sort(v.begin(), v.end());
        return v;
    }
    std::size_t capacity_;
    std::vector<double> values_;
    std::uint64_t count_ = 0;
    double max_ = -std::numeric_limits<double>::infinity();
    std::mt19937_64 rng_{20260526};  // fixed: a run's summary is reproducible
};
