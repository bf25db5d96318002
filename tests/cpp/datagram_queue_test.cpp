// SPDX-License-Identifier: BSD-3-Clause
// The live reader's receive queue (an internal piece): first in, first out through a byte ring of fixed size,
// refusing what does not fit, allocating nothing once warm. Its own executable: it replaces the global allocator.
#include <gtest/gtest.h>

#include <cstdint>
#include <deque>
#include <random>
#include <vector>

#include "io/datagram_queue.hpp"

#include "counting_allocator.hpp"

namespace rp = roadpreview;

namespace {

rp::UdpDatagram datagram(std::int64_t record, std::size_t size) {
    rp::UdpDatagram d;
    d.record = record;
    d.timestamp = 1e9 + 0.001 * static_cast<double>(record);
    d.arrival_s = 0.5 * static_cast<double>(record);
    d.src_port = 7000;
    d.dst_port = static_cast<std::uint16_t>(7502 + record % 2);
    d.payload.resize(size);
    for (std::size_t k = 0; k < size; ++k) d.payload[k] = static_cast<std::uint8_t>(record * 31 + k);
    return d;
}

void expect_same(const rp::UdpDatagram& a, const rp::UdpDatagram& b) {
    EXPECT_EQ(a.record, b.record);
    EXPECT_EQ(a.timestamp, b.timestamp);
    EXPECT_EQ(a.arrival_s, b.arrival_s);
    EXPECT_EQ(a.src_port, b.src_port);
    EXPECT_EQ(a.dst_port, b.dst_port);
    EXPECT_EQ(a.payload, b.payload);
}

}  // namespace

TEST(DatagramQueue, GivesBackWhatWasPushedFirstInFirstOut) {
    rp::DatagramQueue q(1000);
    rp::UdpDatagram out;
    EXPECT_FALSE(q.pop(out));
    for (std::int64_t r : {1, 2, 3}) ASSERT_TRUE(q.push(datagram(r, 100 * static_cast<std::size_t>(r))));
    for (std::int64_t r : {1, 2, 3}) {
        ASSERT_TRUE(q.pop(out));
        expect_same(out, datagram(r, 100 * static_cast<std::size_t>(r)));
    }
    EXPECT_TRUE(q.empty());
    EXPECT_FALSE(q.pop(out));
}

TEST(DatagramQueue, RefusesWhatDoesNotFitAndTakesItOnceRoomIsFreed) {
    rp::DatagramQueue q(1000);
    ASSERT_TRUE(q.push(datagram(1, 400)));
    ASSERT_TRUE(q.push(datagram(2, 400)));
    EXPECT_FALSE(q.push(datagram(3, 400)));  // 200 bytes left at the end, and none before the oldest
    EXPECT_EQ(q.size(), 2u);
    EXPECT_FALSE(q.push(datagram(3, 1001)));
    rp::UdpDatagram out;
    ASSERT_TRUE(q.pop(out));
    expect_same(out, datagram(1, 400));
    ASSERT_TRUE(q.push(datagram(3, 400)));  // wraps to the start, before datagram 2
    EXPECT_FALSE(q.push(datagram(4, 1)));   // the ring is full to the byte
    for (std::int64_t r : {2, 3}) {
        ASSERT_TRUE(q.pop(out));
        expect_same(out, datagram(r, 400));
    }
    ASSERT_TRUE(q.push(datagram(5, 1000)));  // empty: the whole ring, from its start
    EXPECT_FALSE(q.push(datagram(6, 1)));
}

// A reader that keeps up empties the queue after each datagram: the next ones start again at the ring's start (the
// same few kilobytes, hot in the cache), and the whole ring is theirs.
TEST(DatagramQueue, AnEmptiedQueueStartsAgainAtTheRingsStart) {
    rp::DatagramQueue q(1000);
    rp::UdpDatagram out;
    ASSERT_TRUE(q.push(datagram(1, 400)));
    ASSERT_TRUE(q.pop(out));
    for (std::int64_t r : {2, 3}) ASSERT_TRUE(q.push(datagram(r, 400)));
    ASSERT_TRUE(q.push(datagram(4, 200)));  // had 2 gone on where 1 ended, 3 would have wrapped and left no room
    EXPECT_FALSE(q.push(datagram(5, 1)));
    for (std::int64_t r : {2, 3}) {
        ASSERT_TRUE(q.pop(out));
        expect_same(out, datagram(r, 400));
    }
    ASSERT_TRUE(q.pop(out));
    expect_same(out, datagram(4, 200));
}

TEST(DatagramQueue, EmptyPayloadsKeepTheirPlace) {
    rp::DatagramQueue q(3);
    for (std::int64_t r : {1, 2, 3}) ASSERT_TRUE(q.push(datagram(r, 0)));
    EXPECT_FALSE(q.push(datagram(4, 0)));  // each takes a byte of the ring
    rp::UdpDatagram out;
    for (std::int64_t r : {1, 2, 3}) {
        ASSERT_TRUE(q.pop(out));
        expect_same(out, datagram(r, 0));
    }
}

// Random sizes, pushes and pops against a plain deque: the same datagrams come out, in the same order, and the
// queue refuses a datagram only when the ring is more than half full (what a wrap leaves unused at the end is
// less than one datagram).
TEST(DatagramQueue, MatchesAPlainQueueOverRandomTraffic) {
    constexpr std::size_t kBytes = 64 * 1024;
    rp::DatagramQueue q(kBytes);
    std::deque<rp::UdpDatagram> plain;
    std::size_t queued = 0, refused = 0;
    std::mt19937 rng(7);
    std::uniform_int_distribution<std::size_t> size(0, 9000);
    rp::UdpDatagram out;
    for (std::int64_t r = 1; r <= 20000; ++r) {
        if (rng() % 3 != 0) {  // more pushes than pops: the ring fills and wraps
            rp::UdpDatagram d = datagram(r, size(rng));
            if (q.push(d)) {
                queued += d.payload.size();
                plain.push_back(std::move(d));
            } else {
                EXPECT_GT(queued + d.payload.size(), kBytes / 2) << "refused with the ring mostly free";
                ++refused;
            }
        } else if (!plain.empty()) {
            ASSERT_TRUE(q.pop(out));
            expect_same(out, plain.front());
            queued -= plain.front().payload.size();
            plain.pop_front();
        }
        ASSERT_EQ(q.size(), plain.size());
    }
    EXPECT_GT(refused, 100u);
}

TEST(DatagramQueue, AllocatesNothingOnceWarm) {
    rp::DatagramQueue q(256 * 1024);
    const rp::UdpDatagram in = datagram(1, 24896);  // an OS1-128 lidar packet
    rp::UdpDatagram out;
    out.payload.reserve(in.payload.size());
    const long n = allocations_in([&] {
        for (int round = 0; round < 100; ++round) {
            for (int k = 0; k < 8; ++k) q.push(in);  // 10 fit: the ring wraps every round
            while (q.pop(out)) {
            }
        }
    });
    EXPECT_EQ(n, 0);
    EXPECT_EQ(out.payload, in.payload);
}
