// SPDX-License-Identifier: BSD-3-Clause
#include "io/datagram_queue.hpp"

#include <algorithm>
#include <cstring>
#include <stdexcept>
#include <utility>

namespace roadpreview {

namespace {
constexpr std::size_t kFirstEntries = 1024;
}  // namespace

// The ring is zeroed here, so that all its memory is in use from the start: no page is first touched (a page
// fault, the kernel clearing it) while datagrams arrive, and a backlog later does not raise the process's memory.
DatagramQueue::DatagramQueue(std::size_t bytes) : ring_(new std::uint8_t[bytes]()), capacity_(bytes) {
    if (bytes == 0) throw std::invalid_argument("a datagram queue needs room for at least one byte");
    entries_.resize(kFirstEntries);
}

// The payloads lie in [head_, tail_) when tail_ > head_, else in [head_, the last one's end) and [0, tail_) (the
// ring wrapped: a payload never straddles its end). Every payload takes at least one byte, so head_ == tail_ with
// entries queued means full. An empty queue starts again at the ring's start: a reader that keeps up passes each
// datagram through the same few kilobytes, which stay in the cache.
std::size_t DatagramQueue::place(std::size_t size) const {
    if (count_ == 0) return size <= capacity_ ? 0 : capacity_;
    if (tail_ > head_) {
        if (capacity_ - tail_ >= size) return tail_;
        return size <= head_ ? 0 : capacity_;  // wrap to the start, before the oldest payload
    }
    return head_ - tail_ >= size ? tail_ : capacity_;
}

bool DatagramQueue::push(const UdpDatagram& d) {
    const std::size_t size = std::max<std::size_t>(d.payload.size(), 1);
    const std::size_t at = place(size);
    if (at == capacity_) return false;
    if (count_ == entries_.size()) {  // the table is full: grow it, oldest first
        std::vector<Entry> grown(2 * entries_.size());
        for (std::size_t k = 0; k < count_; ++k) grown[k] = std::move(entries_[(first_ + k) % entries_.size()]);
        entries_ = std::move(grown);
        first_ = 0;
    }
    if (!d.payload.empty()) std::memcpy(ring_.get() + at, d.payload.data(), d.payload.size());
    Entry& e = entries_[(first_ + count_) % entries_.size()];
    e.at = at;
    e.size = d.payload.size();
    e.meta.timestamp = d.timestamp;
    e.meta.src_port = d.src_port;
    e.meta.dst_port = d.dst_port;
    e.meta.record = d.record;
    e.meta.arrival_s = d.arrival_s;
    if (count_ == 0) head_ = at;
    tail_ = at + size;
    ++count_;
    return true;
}

bool DatagramQueue::pop(UdpDatagram& out) {
    if (count_ == 0) return false;
    const Entry& e = entries_[first_];
    out.timestamp = e.meta.timestamp;
    out.src_port = e.meta.src_port;
    out.dst_port = e.meta.dst_port;
    out.record = e.meta.record;
    out.arrival_s = e.meta.arrival_s;
    out.payload.assign(ring_.get() + e.at, ring_.get() + e.at + e.size);
    first_ = (first_ + 1) % entries_.size();
    head_ = --count_ == 0 ? tail_ : entries_[first_].at;
    return true;
}

}  // namespace roadpreview
