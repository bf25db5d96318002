// SPDX-License-Identifier: BSD-3-Clause
// POSIX UDP sockets shared by the live reader and the replay: address resolution, a socket closed on scope exit.
#pragma once

#include <netinet/in.h>

#include <string>

#include "roadpreview/io/live.hpp"

namespace roadpreview {

/// An IPv4 socket address for `address` (empty: any) and `port`; throws std::runtime_error naming `where`.
sockaddr_in resolve_ipv4(const std::string& address, int port, const std::string& where);

/// A UDP socket, closed when it goes out of scope.
class UdpSocket {
public:
    /// Throws std::runtime_error naming `where`.
    explicit UdpSocket(const std::string& where);
    ~UdpSocket();
    UdpSocket(UdpSocket&& other) noexcept;
    UdpSocket(const UdpSocket&) = delete;
    UdpSocket& operator=(const UdpSocket&) = delete;
    UdpSocket& operator=(UdpSocket&&) = delete;
    int fd() const { return fd_; }

private:
    int fd_ = -1;
};

/// "udp://ADDR:PORT" of an endpoint with the port filled in.
std::string udp_url(const std::string& address, int port);

}  // namespace roadpreview
