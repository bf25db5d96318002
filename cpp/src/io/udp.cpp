// SPDX-License-Identifier: BSD-3-Clause
#include "udp.hpp"

#include <netdb.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <stdexcept>

namespace roadpreview {

sockaddr_in resolve_ipv4(const std::string& address, int port, const std::string& where) {
    if (address.find("://") != std::string::npos)
        throw std::runtime_error(where + ": give the address as ADDR:PORT, without a scheme");
    if (address.find(':') != std::string::npos)  // "[::1]" or "::1": sensors and replays here speak IPv4
        throw std::runtime_error(where + ": " + address + " is an IPv6 address; give an IPv4 one (e.g. 127.0.0.1)");
    addrinfo hints{};
    hints.ai_family = AF_INET;
    hints.ai_socktype = SOCK_DGRAM;
    hints.ai_flags = AI_PASSIVE | AI_NUMERICSERV;
    addrinfo* found = nullptr;
    const std::string service = std::to_string(port);
    const int status = getaddrinfo(address.empty() ? nullptr : address.c_str(), service.c_str(), &hints, &found);
    if (status != 0 || !found)
        throw std::runtime_error(where + ": cannot resolve the address (" + gai_strerror(status) + ")");
    sockaddr_in a{};
    std::memcpy(&a, found->ai_addr, sizeof a);
    freeaddrinfo(found);
    return a;
}

UdpSocket::UdpSocket(const std::string& where) : fd_(socket(AF_INET, SOCK_DGRAM | SOCK_CLOEXEC, 0)) {
    if (fd_ < 0) throw std::runtime_error(where + ": cannot open a UDP socket: " + std::strerror(errno));
}

UdpSocket::~UdpSocket() {
    if (fd_ >= 0) close(fd_);
}

UdpSocket::UdpSocket(UdpSocket&& other) noexcept : fd_(other.fd_) { other.fd_ = -1; }

std::string udp_url(const std::string& address, int port) {
    return "udp://" + (address.empty() ? std::string("0.0.0.0") : address) + ":" + std::to_string(port);
}

UdpEndpoint parse_udp_endpoint(const std::string& text, bool with_scheme) {
    UdpEndpoint e;
    e.text = text;
    std::string rest = text;
    if (with_scheme) {
        if (!is_udp_url(text)) throw std::invalid_argument(text + ": expected udp://[ADDR][:PORT]");
        rest = text.substr(6);
    }
    const auto bad = [&](const std::string& why) {
        return std::invalid_argument(text + ": " + why + (with_scheme ? " (udp://[ADDR][:PORT])" : " (ADDR:PORT)"));
    };
    const auto colon = rest.rfind(':');
    e.address = rest.substr(0, colon);
    if (colon == std::string::npos) {
        if (!with_scheme) throw bad("no port");
        return e;
    }
    const std::string port = rest.substr(colon + 1);
    std::size_t used = 0;
    long value = 0;
    try {
        value = std::stol(port, &used);
    } catch (const std::exception&) {
        used = 0;
    }
    if (port.empty() || used != port.size() || value < 1 || value > 65535) throw bad("port '" + port + "' is not 1..65535");
    e.port = static_cast<int>(value);
    return e;
}

}  // namespace roadpreview
