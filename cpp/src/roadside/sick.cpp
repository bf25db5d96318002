// SPDX-License-Identifier: BSD-3-Clause
// LMDscandata in CoLa-A and CoLa-B: one field walk over two field readers (binary big-endian or ASCII tokens),
// so the two framings cannot drift apart.
#include "roadpreview/roadside/sick.hpp"

#include <cmath>
#include <algorithm>
#include <array>
#include <cstring>
#include <optional>
#include <stdexcept>

namespace roadpreview::roadside {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kDegPerUnit = 1e-4;  // SICK angles are in 1/10000 °

[[noreturn]] void fail(const std::string& where, const std::string& what) {
    throw std::runtime_error(where + ": " + what);
}

// Fields of a telegram body after the command name, in either encoding.
class Fields {
public:
    virtual ~Fields() = default;
    virtual std::uint32_t unsigned_int(int bytes, const char* what) = 0;
    virtual std::int32_t signed_int(const char* what) = 0;
    virtual std::string text(std::size_t bytes, const char* what) = 0;
    virtual std::size_t remaining_values(int bytes_each) const = 0;  // upper bound, to check a count
    virtual bool at_end() const = 0;

    std::uint8_t u8(const char* what) { return static_cast<std::uint8_t>(unsigned_int(1, what)); }
    std::uint16_t u16(const char* what) { return static_cast<std::uint16_t>(unsigned_int(2, what)); }
    std::uint32_t u32(const char* what) { return unsigned_int(4, what); }
    float real(const char* what) { return from_bits<float>(unsigned_int(4, what)); }  // IEEE 754 bits in both encodings

    template <typename T>
    static T from_bits(std::uint32_t u) {
        T v;
        std::memcpy(&v, &u, 4);
        return v;
    }
};

class BinaryFields final : public Fields {
public:
    BinaryFields(const std::uint8_t* p, std::size_t n, std::string where) : p_(p), n_(n), where_(std::move(where)) {}

    std::uint32_t unsigned_int(int bytes, const char* what) override {
        need(static_cast<std::size_t>(bytes), what);
        std::uint32_t v = 0;
        for (int i = 0; i < bytes; ++i) v = (v << 8) | p_[pos_++];
        return v;
    }
    std::int32_t signed_int(const char* what) override { return from_bits<std::int32_t>(unsigned_int(4, what)); }
    std::string text(std::size_t bytes, const char* what) override {
        need(bytes, what);
        std::string s(reinterpret_cast<const char*>(p_ + pos_), bytes);
        pos_ += bytes;
        return s;
    }
    std::size_t remaining_values(int bytes_each) const override { return (n_ - pos_) / bytes_each; }
    bool at_end() const override { return pos_ == n_; }

private:
    void need(std::size_t bytes, const char* what) const {
        if (n_ - pos_ < bytes) fail(where_, std::string("truncated telegram: no room for ") + what);
    }
    const std::uint8_t* p_;
    std::size_t n_, pos_ = 0;
    std::string where_;
};

class AsciiFields final : public Fields {
public:
    AsciiFields(const std::string& body, std::string where) : where_(std::move(where)) {
        std::size_t start = 0;
        while (start < body.size()) {
            const std::size_t end = body.find(' ', start);
            const std::size_t stop = end == std::string::npos ? body.size() : end;
            if (stop > start) tokens_.push_back(body.substr(start, stop - start));
            start = stop + 1;
        }
    }

    // Hex by default; "+123" / "-123" are decimal (SOPAS allows both).
    std::uint32_t unsigned_int(int bytes, const char* what) override {
        const std::int64_t v = number(what);
        const std::int64_t max = bytes == 4 ? 0xFFFFFFFFLL : (1LL << (8 * bytes)) - 1;
        if (v < 0 || v > max) fail(where_, std::string("value out of range for ") + what);
        return static_cast<std::uint32_t>(v);
    }
    std::int32_t signed_int(const char* what) override {
        const std::int64_t v = number(what);
        if (v > 0xFFFFFFFFLL || v < INT32_MIN) fail(where_, std::string("value out of range for ") + what);
        return from_bits<std::int32_t>(static_cast<std::uint32_t>(v));  // hex tokens are two's complement
    }
    std::string text(std::size_t, const char* what) override { return token(what); }
    std::size_t remaining_values(int) const override { return tokens_.size() - pos_; }
    bool at_end() const override { return pos_ == tokens_.size(); }

private:
    const std::string& token(const char* what) {
        if (pos_ >= tokens_.size()) fail(where_, std::string("truncated telegram: no field for ") + what);
        return tokens_[pos_++];
    }
    std::int64_t number(const char* what) {
        const std::string& t = token(what);
        const bool decimal = t[0] == '+' || t[0] == '-';
        if (t.size() > 11) fail(where_, std::string("malformed number '") + t + "' for " + what);
        char* end = nullptr;
        const long long v = std::strtoll(t.c_str(), &end, decimal ? 10 : 16);
        if (*end != '\0' || end == t.c_str()) fail(where_, std::string("malformed number '") + t + "' for " + what);
        return v;
    }
    std::vector<std::string> tokens_;
    std::size_t pos_ = 0;
    std::string where_;
};

std::size_t checked_count(Fields& f, std::size_t count, int bytes_each, const char* what, const std::string& where) {
    if (count > f.remaining_values(bytes_each))
        fail(where, std::string("truncated telegram: ") + what + " declares " + std::to_string(count) +
                        " values, fewer remain");
    return count;
}

SickChannel read_channel(Fields& f, int value_bytes, const std::string& where) {
    SickChannel c;
    c.name = f.text(5, "channel name");
    c.scale = f.real("channel scale");
    c.offset = f.real("channel offset");
    c.start_angle = f.signed_int("start angle");
    c.step = f.u16("angular step");
    const std::size_t n = checked_count(f, f.u16("number of data"), value_bytes, "a channel", where);
    c.data.resize(n);
    for (auto& v : c.data) v = static_cast<std::uint16_t>(f.unsigned_int(value_bytes, "channel data"));
    if (!std::isfinite(c.scale) || !std::isfinite(c.offset) || c.scale == 0.0f)
        fail(where, "channel " + c.name + " has a non-finite or zero scale or offset");
    return c;
}

std::vector<SickChannel> read_channels(Fields& f, int value_bytes, const std::string& where) {
    const std::size_t n = checked_count(f, f.u16("number of channels"), 1, "the channel count", where);
    std::vector<SickChannel> channels;
    for (std::size_t i = 0; i < n; ++i) channels.push_back(read_channel(f, value_bytes, where));
    return channels;
}

std::optional<std::string> read_optional_text(Fields& f, const char* what) {
    if (!f.u16(what)) return std::nullopt;
    const std::size_t length = f.u8("text length");
    return f.text(length, what);
}

void read_tail(Fields& f, SickScanTelegram& t) {
    if (f.at_end()) return;  // some firmware ends after the channels
    if (f.u16("position flag")) {
        SickPosition p;
        p.x = f.real("x"), p.y = f.real("y"), p.z = f.real("z");
        p.rot_x = f.real("rot x"), p.rot_y = f.real("rot y"), p.rot_z = f.real("rot z");
        p.rotation_type = f.u8("rotation type");
        t.position = p;
    }
    t.name = read_optional_text(f, "name flag");
    t.comment = read_optional_text(f, "comment flag");
    if (f.u16("time flag")) {
        SickTime s;
        s.year = f.u16("year"), s.month = f.u8("month"), s.day = f.u8("day");
        s.hour = f.u8("hour"), s.minute = f.u8("minute"), s.second = f.u8("second");
        s.microsecond = f.u32("microsecond");
        t.time = s;
    }
    if (!f.at_end() && f.u16("event flag")) {
        SickEvent e;
        e.type = f.text(4, "event type");
        e.encoder_position = f.u32("event encoder position");
        e.time_us = f.u32("event time");
        e.angle = f.signed_int("event angle");
        t.event = e;
    }
}

SickScanTelegram read_scandata(Fields& f, ColaFraming framing, const std::string& where) {
    SickScanTelegram t;
    t.framing = framing;
    t.version = f.u16("version");
    t.device_number = f.u16("device number");
    t.serial_number = f.u32("serial number");
    t.device_status = {f.u8("device status"), f.u8("device status")};
    t.telegram_counter = f.u16("telegram counter");
    t.scan_counter = f.u16("scan counter");
    t.time_since_startup_us = f.u32("time since start-up");
    t.time_of_transmission_us = f.u32("time of transmission");
    t.input_status = {f.u8("input status"), f.u8("input status")};
    t.output_status = {f.u8("output status"), f.u8("output status")};
    t.reserved = f.u16("reserved");
    t.scan_frequency = f.u32("scan frequency");
    t.measurement_frequency = f.u32("measurement frequency");
    const std::size_t encoders = checked_count(f, f.u16("number of encoders"), 6, "the encoder list", where);
    for (std::size_t i = 0; i < encoders; ++i) t.encoders.push_back({f.u32("encoder position"), f.u16("encoder speed")});
    t.channels16 = read_channels(f, 2, where);
    t.channels8 = read_channels(f, 1, where);
    read_tail(f, t);
    return t;
}

// A scan telegram: the streamed event "sSN LMDscandata " or the answer to a poll ("sRN LMDscandata"), "sRA
// LMDscandata ", whose fields are the same (SICK's telegram listing); both 16 characters.
constexpr std::size_t kScanCommandLength = 16;
bool is_scan_command(const void* text, std::size_t length) {
    return length >= kScanCommandLength && (std::memcmp(text, "sSN LMDscandata ", kScanCommandLength) == 0 ||
                                            std::memcmp(text, "sRA LMDscandata ", kScanCommandLength) == 0);
}

std::optional<SickScanTelegram> decode_cola_b(const std::uint8_t* data, std::size_t size, const std::string& where) {
    if (size < 9) fail(where, "truncated CoLa-B frame (" + std::to_string(size) + " bytes)");
    const std::uint32_t length = (std::uint32_t{data[4]} << 24) | (std::uint32_t{data[5]} << 16) |
                                 (std::uint32_t{data[6]} << 8) | data[7];
    if (length != size - 9)
        fail(where, "CoLa-B length field says " + std::to_string(length) + " bytes, the frame holds " +
                        std::to_string(size - 9));
    std::uint8_t checksum = 0;
    for (std::size_t i = 8; i < size - 1; ++i) checksum ^= data[i];
    if (checksum != data[size - 1]) fail(where, "CoLa-B checksum error");
    const std::uint8_t* payload = data + 8;
    if (!is_scan_command(payload, length)) return std::nullopt;
    BinaryFields f(payload + kScanCommandLength, length - kScanCommandLength, where);
    SickScanTelegram t = read_scandata(f, ColaFraming::B, where);
    if (!f.at_end()) fail(where, "CoLa-B telegram has bytes left over after its last field");
    return t;
}

std::optional<SickScanTelegram> decode_cola_a(const std::uint8_t* data, std::size_t size, const std::string& where) {
    if (size < 2 || data[size - 1] != 0x03) fail(where, "CoLa-A frame does not end with ETX");
    const std::string body(reinterpret_cast<const char*>(data + 1), size - 2);
    if (!is_scan_command(body.data(), body.size())) return std::nullopt;
    AsciiFields f(body.substr(kScanCommandLength), where);
    SickScanTelegram t = read_scandata(f, ColaFraming::A, where);
    if (!f.at_end()) fail(where, "CoLa-A telegram has fields left over after its last field");
    return t;
}

}  // namespace

const SickChannel* SickScanTelegram::channel(const std::string& channel_name) const {
    for (const auto* list : {&channels16, &channels8})
        for (const auto& c : *list)
            if (c.name == channel_name) return &c;
    return nullptr;
}

std::optional<SickScanTelegram> decode_sick_telegram(const std::uint8_t* data, std::size_t size,
                                                     const std::string& where) {
    if (size >= 4 && data[0] == 2 && data[1] == 2 && data[2] == 2 && data[3] == 2) return decode_cola_b(data, size, where);
    if (size >= 1 && data[0] == 2) return decode_cola_a(data, size, where);
    fail(where, "not a SOPAS telegram (no STX)");
}

LaserScan to_laser_scan(const SickScanTelegram& t, const std::string& source) {
    const SickChannel* dist = t.channel("DIST1");
    if (!dist) fail(source, "scan telegram has no DIST1 channel");
    if (dist->step == 0 || dist->data.empty()) fail(source, "DIST1 channel has no beams or a zero angular step");
    LaserScan s;
    s.counter = t.scan_counter;
    s.source = source;
    s.start_angle_rad = (dist->start_angle * kDegPerUnit - 90.0) * kPi / 180.0;
    s.step_rad = dist->step * kDegPerUnit * kPi / 180.0;
    s.ranges_m.resize(dist->data.size());
    for (std::size_t i = 0; i < dist->data.size(); ++i)
        s.ranges_m[i] = dist->data[i] == 0 ? NAN : (dist->data[i] * dist->scale + dist->offset) * 1e-3f;
    if (const SickChannel* rssi = t.channel("RSSI1")) {
        if (rssi->data.size() != dist->data.size())
            fail(source, "RSSI1 has " + std::to_string(rssi->data.size()) + " values, DIST1 " +
                             std::to_string(dist->data.size()));
        s.intensities.resize(rssi->data.size());
        for (std::size_t i = 0; i < rssi->data.size(); ++i) s.intensities[i] = rssi->data[i] * rssi->scale + rssi->offset;
    }
    return s;
}

void SickStreamFramer::feed(const std::uint8_t* data, std::size_t size) {
    if (start_ > 0 && start_ == buffer_.size()) buffer_.clear(), start_ = 0;
    if (start_ > (1u << 16)) buffer_.erase(buffer_.begin(), buffer_.begin() + static_cast<std::ptrdiff_t>(start_)), start_ = 0;
    buffer_.insert(buffer_.end(), data, data + size);
}

bool SickStreamFramer::next(std::vector<std::uint8_t>& frame) {
    while (start_ < buffer_.size()) {
        const std::uint8_t* p = buffer_.data() + start_;
        const std::size_t n = buffer_.size() - start_;
        if (p[0] != 0x02) {
            ++start_, ++skipped_;
            continue;
        }
        if (n < 8) return false;
        if (p[1] == 2 && p[2] == 2 && p[3] == 2) {  // CoLa-B
            const std::size_t length = (std::size_t{p[4]} << 24) | (std::size_t{p[5]} << 16) | (std::size_t{p[6]} << 8) | p[7];
            if (length > max_length_) {
                ++start_, ++skipped_;
                continue;
            }
            if (n < length + 9) return false;
            frame.assign(p, p + length + 9);
            start_ += length + 9;
            return true;
        }
        const void* etx = std::memchr(p, 0x03, std::min(n, max_length_));  // CoLa-A
        if (!etx) {
            if (n < max_length_) return false;
            ++start_, ++skipped_;
            continue;
        }
        const std::size_t length = static_cast<const std::uint8_t*>(etx) - p + 1;
        frame.assign(p, p + length);
        start_ += length;
        return true;
    }
    return false;
}

std::vector<LaserScan> scans_from_telegrams(const std::vector<TimedTelegram>& telegrams, bool skip_bad,
                                            SickDecodeCounts* counts) {
    SickDecodeCounts c;
    std::vector<LaserScan> scans;
    std::optional<std::array<std::uint32_t, 3>> last;  // the last scan's serial number, counter and start time
    for (const auto& tt : telegrams) {
        ++c.telegrams;
        try {
            const auto t = decode_sick_telegram(tt.bytes.data(), tt.bytes.size(), tt.where);
            if (!t) {
                ++c.other;
                continue;
            }
            const std::array<std::uint32_t, 3> scan{t->serial_number, t->scan_counter, t->time_since_startup_us};
            if (last == scan) {
                ++c.repeated;
                continue;
            }
            last = scan;
            LaserScan s = to_laser_scan(*t, tt.where);
            // The sensor stamps the scan's start and its transmission on one clock: their difference is the
            // latency between acquisition and the capture's timestamp.
            const double latency_s = (static_cast<std::int64_t>(t->time_of_transmission_us) -
                                      static_cast<std::int64_t>(t->time_since_startup_us)) * 1e-6;
            s.time_s = tt.time_s - (latency_s >= 0.0 && latency_s < 1.0 ? latency_s : 0.0);
            scans.push_back(std::move(s));
            ++c.scans;
        } catch (const std::runtime_error&) {
            ++c.bad;
            if (!skip_bad) throw;
        }
    }
    if (counts) *counts = c;
    return scans;
}

}  // namespace roadpreview::roadside
