// SPDX-License-Identifier: BSD-3-Clause
// Internal: the live reader's receive queue — datagrams in one byte ring of fixed size, so that a live run's memory
// neither grows nor fragments when the pipeline falls behind the sensor: a datagram that does not fit is refused.
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <vector>

#include "roadpreview/io/pcap.hpp"

namespace roadpreview {

/// A FIFO of datagrams whose payloads share one ring of `bytes` bytes, allocated once. push() copies a datagram in,
/// pop() copies the oldest out into a caller's datagram (reusing its payload's capacity): once the entries' table
/// has grown to the most datagrams queued at once, neither allocates. Not thread-safe: the caller locks.
class DatagramQueue {
public:
    explicit DatagramQueue(std::size_t bytes);

    /// Queues a copy of `d`; false (and the queue unchanged) when its payload does not fit in the free part of the
    /// ring.
    bool push(const UdpDatagram& d);
    /// Copies the oldest datagram into `out` (reusing its payload's capacity) and removes it; false when empty.
    bool pop(UdpDatagram& out);

    bool empty() const { return count_ == 0; }
    std::size_t size() const { return count_; }

private:
    struct Entry {
        std::size_t at = 0, size = 0;  // where in the ring the payload lies
        UdpDatagram meta;              // everything but the payload (left empty)
    };
    std::size_t place(std::size_t size) const;  // where a payload of `size` bytes goes, or capacity_ when full

    std::unique_ptr<std::uint8_t[]> ring_;  // zeroed when made: every page in memory before the first datagram
    std::size_t capacity_;
    std::size_t head_ = 0;  // the oldest payload's start
    std::size_t tail_ = 0;  // one past the newest payload's end
    std::vector<Entry> entries_;  // a circular table of count_ entries from first_
    std::size_t first_ = 0, count_ = 0;
};

}  // namespace roadpreview
