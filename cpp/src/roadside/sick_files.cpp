// SPDX-License-Identifier: BSD-3-Clause
// SICK telegrams from files: sick_scan_xd's JSON dumps (nlohmann::json) and pcap/pcapng captures (libtins reads
// the records and reassembles the TCP streams; the telegrams are framed from the sensor's stream).
#include <tins/exceptions.h>
#include <pcap/pcap.h>
#include <tins/sniffer.h>
#include <tins/tcp_ip/stream_follower.h>

#include <cmath>
#include <fstream>
#include <nlohmann/json.hpp>
#include <stdexcept>

#include "roadpreview/roadside/sick.hpp"

#include "core/input_file.hpp"
#include "core/text.hpp"

namespace roadpreview::roadside {
namespace {

int hex_digit(char c) {
    if (c >= '0' && c <= '9') return c - '0';
    if (c >= 'a' && c <= 'f') return c - 'a' + 10;
    if (c >= 'A' && c <= 'F') return c - 'A' + 10;
    return -1;
}

// "02:02:0a" → bytes.
std::vector<std::uint8_t> colon_hex(const std::string& text, const std::string& where) {
    std::vector<std::uint8_t> bytes;
    bytes.reserve(text.size() / 3 + 1);
    for (std::size_t i = 0; i < text.size(); i += 3) {
        const int hi = hex_digit(text[i]);
        const int lo = i + 1 < text.size() ? hex_digit(text[i + 1]) : -1;
        if (hi < 0 || lo < 0 || (i + 2 < text.size() && text[i + 2] != ':'))
            throw std::runtime_error(where + ": tcp.payload is not colon-separated hex");
        bytes.push_back(static_cast<std::uint8_t>(hi * 16 + lo));
    }
    return bytes;
}

}  // namespace

std::vector<TimedTelegram> read_sick_json(const std::string& path) {
    require_input_file<std::runtime_error>(path, "telegrams");
    std::ifstream in(path);
    if (!in) throw std::runtime_error(path + ": cannot open");
    nlohmann::json doc;
    try {
        doc = nlohmann::json::parse(in);
    } catch (const nlohmann::json::exception& e) {
        throw std::runtime_error(path + ": not JSON (" + e.what() + ")");
    }
    if (!doc.is_array()) throw std::runtime_error(path + ": expected a JSON array of telegram entries");
    std::vector<TimedTelegram> out;
    for (std::size_t i = 0; i < doc.size(); ++i) {
        const std::string where = path + "#" + std::to_string(i);
        try {
            const auto& tcp = doc[i].at("_source").at("layers").at("tcp");
            TimedTelegram t;
            t.where = where;
            t.bytes = colon_hex(tcp.at("tcp.payload").get<std::string>(), where);
            const auto time_s = parse_number(tcp.at("Timestamps").at("tcp.time_relative").get<std::string>());
            if (!time_s || !std::isfinite(*time_s))
                throw std::runtime_error(where + ": tcp.time_relative is not a finite number");
            t.time_s = *time_s;
            out.push_back(std::move(t));
        } catch (const nlohmann::json::exception& e) {
            throw std::runtime_error(where + ": entry lacks tcp.payload or tcp.time_relative (" + e.what() + ")");
        }
    }
    return out;
}

std::vector<TimedTelegram> read_sick_pcap(const std::string& path, int sensor_port, std::string* truncated) {
    std::unique_ptr<Tins::FileSniffer> sniffer;
    try {
        sniffer = std::make_unique<Tins::FileSniffer>(path);
    } catch (const std::exception& e) {
        throw std::runtime_error(path + ": cannot read the capture (" + e.what() + ")");
    }
    std::vector<TimedTelegram> out;
    SickStreamFramer framer;
    std::vector<std::uint8_t> frame;
    auto on_sensor_data = [&](Tins::TCPIP::Stream& stream, Tins::TCPIP::Stream::payload_type& payload) {
        framer.feed(payload.data(), payload.size());
        payload.clear();
        while (framer.next(frame)) {
            const double t = std::chrono::duration<double>(stream.last_seen()).count();
            out.push_back({t, frame, path + "#telegram" + std::to_string(out.size())});
        }
    };
    Tins::TCPIP::StreamFollower follower;
    follower.follow_partial_streams(true);
    follower.new_stream_callback([&](Tins::TCPIP::Stream& stream) {
        stream.auto_cleanup_payloads(false);
        if (stream.server_port() == sensor_port) {
            stream.server_data_callback([&](Tins::TCPIP::Stream& s) { on_sensor_data(s, s.server_payload()); });
            stream.ignore_client_data();
        } else if (stream.client_port() == sensor_port) {
            stream.client_data_callback([&](Tins::TCPIP::Stream& s) { on_sensor_data(s, s.client_payload()); });
            stream.ignore_server_data();
        } else {
            stream.ignore_client_data();
            stream.ignore_server_data();
        }
    });
    pcap_geterr(sniffer->get_pcap_handle())[0] = '\0';  // what libpcap says after the loop is of the loop's reads
    sniffer->sniff_loop([&](Tins::Packet& packet) {
        try {
            follower.process_packet(packet);
        } catch (const Tins::exception_base&) {
            // a malformed TCP segment: the stream's later bytes resynchronise in the framer
        }
        return true;
    });
    // libtins ends its loop on a record libpcap cannot read as on the file's end; libpcap keeps the error.
    if (const std::string error = pcap_geterr(sniffer->get_pcap_handle()); !error.empty()) {
        const std::string why = path + ": the capture breaks off after " + std::to_string(out.size()) +
                                " telegrams, truncated or corrupt (libpcap: " + error + ")";
        if (!truncated) throw std::runtime_error(why + "; --skip-bad reads the telegrams before it");
        *truncated = why;
    }
    return out;
}

}  // namespace roadpreview::roadside
