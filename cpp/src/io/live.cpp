// SPDX-License-Identifier: BSD-3-Clause
// Live UDP input: one receive thread polls the sensor's sockets and fills a queue of fixed size (datagrams that do
// not fit are dropped and counted: the sensor never waits); the reader takes datagrams from the queue and feeds
// them to the Ouster or Velodyne decoder like a pcap's.
#include "roadpreview/io/live.hpp"

#include <poll.h>
#include <sys/uio.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <chrono>
#include <condition_variable>
#include <cstring>
#include <limits>
#include <mutex>
#include <sstream>
#include <stdexcept>
#include <thread>
#include <vector>

#include "roadpreview/io/ouster.hpp"
#include "io/datagram_queue.hpp"
#include "pcap_source.hpp"
#include "udp.hpp"

namespace roadpreview {
namespace {

constexpr int kVelodyneDataPort = 2368;
constexpr std::size_t kMaxDatagramBytes = 65536;
// Datagrams read from one socket before they are queued: the receive thread holds (and keeps payload buffers for)
// at most a few batches, however large a backlog the kernel holds after the thread was kept from running.
constexpr std::size_t kMaxBatch = 64;

double wall_now_s() {
    return std::chrono::duration<double>(std::chrono::system_clock::now().time_since_epoch()).count();
}

// A socket bound to the endpoint's address and `port`, with a large receive buffer (forced when permitted:
// a burst of a 128-beam sensor overflows the default 208 kB in milliseconds).
UdpSocket bind_socket(const std::string& address, int port, int buffer_bytes) {
    const std::string where = udp_url(address, port);
    UdpSocket s(where);
    if (setsockopt(s.fd(), SOL_SOCKET, SO_RCVBUFFORCE, &buffer_bytes, sizeof buffer_bytes) != 0)
        setsockopt(s.fd(), SOL_SOCKET, SO_RCVBUF, &buffer_bytes, sizeof buffer_bytes);
    const int on = 1;
    setsockopt(s.fd(), SOL_SOCKET, SO_TIMESTAMPNS, &on, sizeof on);
    const sockaddr_in a = resolve_ipv4(address, port, where);
    if (bind(s.fd(), reinterpret_cast<const sockaddr*>(&a), sizeof a) != 0) {
        const int e = errno;
        throw std::runtime_error(where + ": cannot listen: " +
                                 (e == EADDRINUSE ? "the port is already in use" : std::string(std::strerror(e))));
    }
    return s;
}

class UdpInput : public DatagramInput {
public:
    UdpInput(const std::string& address, std::vector<int> ports, const LiveOptions& o)
        : name_(udp_url(address, ports.front())), options_(o), opened_s_(steady_now_s()), queue_(o.queue_bytes) {
        for (int port : ports) {
            sockets_.push_back(bind_socket(address, port, o.receive_buffer_bytes));
            ports_.push_back(port);
        }
        thread_ = std::thread([this] { receive(); });
    }

    ~UdpInput() override {
        stop_ = true;
        thread_.join();
    }

    bool next(UdpDatagram& out) override {
        std::unique_lock<std::mutex> lock(mutex_);
        for (;;) {
            const double now = steady_now_s();
            // The duration (or a stop) ends the stream even when a backlog waits (a pipeline slower than the sensor).
            if (options_.duration_s > 0.0 && now - opened_s_ >= options_.duration_s) return false;
            if (options_.stop && options_.stop->load()) return false;
            if (!queue_.empty()) break;
            if (failure_.size()) throw std::runtime_error(name_ + ": " + failure_);
            // Silence is the first port's (the lidar's): an IMU that goes on alone would keep the run waiting forever.
            const double silent_s = now - (data_received_ ? last_data_arrival_s_ : opened_s_);
            if (silent_s >= options_.timeout_s) {
                if (data_received_) return false;  // the sensor went quiet: the end of the stream
                std::ostringstream msg;
                msg << name_ << ": no datagrams" << (received_ ? " on this port" : "") << " within "
                    << options_.timeout_s << " s (";
                if (received_) msg << received_ << " on the others: ";
                msg << "is the sensor sending to this address and port?)";
                throw std::runtime_error(msg.str());
            }
            if (options_.busy_wait)
                poll_queue(lock);
            else
                arrived_.wait_for(lock, std::chrono::milliseconds(20));
        }
        return queue_.pop(out);
    }

    const std::string& name() const override { return name_; }
    const char* kind() const override { return "udp"; }
    const char* unit() const override { return "datagram"; }
    std::int64_t units_read() const override {
        std::lock_guard<std::mutex> lock(mutex_);
        return received_;
    }
    void describe(SourceInfo& info) const override {
        std::lock_guard<std::mutex> lock(mutex_);
        info.datagrams_received = received_;
        info.datagrams_dropped = dropped_;
    }

private:
    // Busy waiting: the lock released, the count of pushes watched for as long as a sleep would last (the end
    // conditions are checked as often either way); each look yields the core to any thread ready to run on it.
    void poll_queue(std::unique_lock<std::mutex>& lock) {
        const std::uint64_t seen = pushes_.load(std::memory_order_acquire);
        lock.unlock();
        const double until_s = steady_now_s() + 0.02;
        while (pushes_.load(std::memory_order_acquire) == seen && steady_now_s() < until_s) std::this_thread::yield();
        lock.lock();
    }

    // The receive thread: waits on every socket at once, reads what arrived, checks for the end every 50 ms.
    // Datagrams of several sockets (lidar, IMU) are queued in the order the kernel received them: each socket is
    // read until empty or for a batch, so everything it received up to then (when emptied) or up to its last
    // datagram read is known; what all sockets have known up to the earliest of those times can go, sorted.
    void receive() {
        std::vector<pollfd> fds;
        for (const UdpSocket& s : sockets_) fds.push_back({s.fd(), POLLIN, 0});
        std::vector<UdpDatagram> pending;
        while (!stop_) {
            const int ready = poll(fds.data(), fds.size(), pending.empty() ? 50 : 0);
            if (ready < 0 && errno != EINTR) return fail(std::string("poll: ") + std::strerror(errno));
            if (ready <= 0 && pending.empty()) continue;
            double known_until_s = std::numeric_limits<double>::infinity();
            for (std::size_t k = 0; k < fds.size(); ++k) {
                const double known_s = read_batch(fds[k].fd, ports_[k], pending);
                if (fds.size() > 1) known_until_s = std::min(known_until_s, known_s);
            }
            push_until(pending, known_until_s);
        }
    }

    // Reads up to kMaxBatch datagrams the socket holds, with the kernel's receive time of each (SO_TIMESTAMPNS).
    // Returns the time up to which the socket's datagrams have all been read: the time of the read that found it
    // empty, else the receive time of the last one read (a socket gives its datagrams in the order they arrived).
    double read_batch(int fd, int port, std::vector<UdpDatagram>& batch) {
        alignas(cmsghdr) char control[CMSG_SPACE(sizeof(timespec))];
        for (std::size_t count = 0; count < kMaxBatch; ++count) {
            buffer_.resize(kMaxDatagramBytes);
            iovec io{buffer_.data(), buffer_.size()};
            msghdr m{};
            m.msg_iov = &io;
            m.msg_iovlen = 1;
            m.msg_control = control;
            m.msg_controllen = sizeof control;
            // Taken before the read: a datagram that arrives after the socket was found empty is stamped after it.
            // (Taken after, a datagram arriving in between — a preempted thread, a loaded machine — was older than
            // the time returned yet unread, and another socket's newer datagram went first: an IMU sample moved to
            // the next frame.)
            const double asked_s = wall_now_s();
            const ssize_t n = recvmsg(fd, &m, MSG_DONTWAIT);
            if (n < 0) {
                if (errno != EAGAIN && errno != EWOULDBLOCK && errno != EINTR)
                    fail(std::string("receive: ") + std::strerror(errno));
                return asked_s;
            }
            UdpDatagram d = spare();
            const double wall_s = wall_now_s(), steady_s = steady_now_s();
            d.timestamp = wall_s;
            for (cmsghdr* c = CMSG_FIRSTHDR(&m); c; c = CMSG_NXTHDR(&m, c)) {
                if (c->cmsg_level != SOL_SOCKET || c->cmsg_type != SCM_TIMESTAMPNS) continue;
                timespec ts;
                std::memcpy(&ts, CMSG_DATA(c), sizeof ts);
                d.timestamp = static_cast<double>(ts.tv_sec) + 1e-9 * static_cast<double>(ts.tv_nsec);
            }
            d.arrival_s = steady_s - std::max(0.0, wall_s - d.timestamp);  // the kernel's time, on the steady clock
            d.dst_port = static_cast<std::uint16_t>(port);
            d.payload.assign(buffer_.data(), buffer_.data() + n);
            batch.push_back(std::move(d));
        }
        return batch.back().timestamp;
    }

    // A datagram whose payload buffer was used before (the receive thread allocates nothing once warmed up).
    UdpDatagram spare() {
        if (spare_.empty()) return {};
        UdpDatagram d = std::move(spare_.back());
        spare_.pop_back();
        return d;
    }

    // Queues the pending datagrams received up to `until_s`, in the order of their receive times.
    void push_until(std::vector<UdpDatagram>& pending, double until_s) {
        const auto by_time = [](const UdpDatagram& a, const UdpDatagram& b) { return a.timestamp < b.timestamp; };
        std::stable_sort(pending.begin(), pending.end(), by_time);
        const auto end = std::find_if(pending.begin(), pending.end(),
                                      [&](const UdpDatagram& d) { return d.timestamp > until_s; });
        if (end == pending.begin()) return;
        {
            std::lock_guard<std::mutex> lock(mutex_);
            for (auto it = pending.begin(); it != end; ++it) {
                UdpDatagram& d = *it;
                d.record = ++received_;
                if (d.dst_port == ports_.front())
                    ++data_received_, last_data_arrival_s_ = std::max(last_data_arrival_s_, d.arrival_s);
                dropped_ += !queue_.push(d);
            }
        }
        for (auto it = pending.begin(); it != end; ++it) spare_.push_back(std::move(*it));
        pending.erase(pending.begin(), end);
        pushes_.fetch_add(1, std::memory_order_release);
        arrived_.notify_one();
    }

    void fail(const std::string& what) {
        std::lock_guard<std::mutex> lock(mutex_);
        failure_ = what;
        stop_ = true;
    }

    std::string name_;
    LiveOptions options_;
    double opened_s_;
    std::vector<UdpSocket> sockets_;
    std::vector<int> ports_;
    std::thread thread_;
    std::atomic<bool> stop_{false};
    std::vector<std::uint8_t> buffer_;  // the receive thread's
    // The receive thread's: datagrams queued, their buffers kept for reuse (at most a few batches' worth)
    std::vector<UdpDatagram> spare_;

    mutable std::mutex mutex_;  // guards what follows
    std::condition_variable arrived_;
    std::atomic<std::uint64_t> pushes_{0};  // batches queued: what a busy-waiting reader watches, without the lock
    DatagramQueue queue_;
    std::int64_t received_ = 0, dropped_ = 0;
    std::int64_t data_received_ = 0;  // on the first port, the lidar's
    double last_data_arrival_s_ = 0.0;
    std::string failure_;
};

void check_options(const std::string& url, const LiveOptions& o) {
    if (!(o.timeout_s > 0.0)) throw std::invalid_argument(url + ": the timeout must be > 0 s");
    if (!(o.duration_s >= 0.0)) throw std::invalid_argument(url + ": the duration must be >= 0 s");
    if (o.queue_bytes < kMaxDatagramBytes) throw std::invalid_argument(url + ": the queue must hold >= 64 kB");
}

}  // namespace

double steady_now_s() {
    return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

bool is_udp_url(const std::string& input) { return input.rfind("udp://", 0) == 0; }

std::unique_ptr<FrameSource> open_live(const std::string& url, const LiveOptions& options) {
    check_options(url, options);
    const UdpEndpoint at = parse_udp_endpoint(url);
    SourceOptions source = options.source;
    if (source.meta.empty()) {  // Velodyne: its data port
        source.lidar_port = at.port ? at.port : kVelodyneDataPort;
        auto input = std::make_unique<UdpInput>(at.address, std::vector<int>{source.lidar_port}, options);
        return open_velodyne_packets(std::move(input), source);
    }
    const OusterMetadata meta = read_ouster_metadata(source.meta);
    source.lidar_port = at.port ? at.port : meta.udp_port_lidar;
    if (!source.lidar_port)
        throw std::invalid_argument(url + ": give the lidar port: " + source.meta + " names none");
    // The IMU port keeps its distance from the lidar port; a metadata file without ports: Ouster's default, next.
    std::vector<int> ports{source.lidar_port};
    source.imu_port = meta.udp_port_imu && meta.udp_port_lidar
                          ? meta.udp_port_imu + source.lidar_port - meta.udp_port_lidar
                          : (meta.udp_port_imu ? meta.udp_port_imu : source.lidar_port + 1);
    if (source.imu_port > 0 && source.imu_port < 65536 && source.imu_port != source.lidar_port)
        ports.push_back(source.imu_port);
    else
        source.imu_port = 0;
    auto input = std::make_unique<UdpInput>(at.address, ports, options);
    return open_ouster_packets(std::move(input), source.meta, source);
}

}  // namespace roadpreview
