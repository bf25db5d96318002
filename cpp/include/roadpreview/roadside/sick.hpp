// SPDX-License-Identifier: BSD-3-Clause
// SICK LMS1xx / LMS5xx / TiM `LMDscandata` telegrams in both SOPAS framings: CoLa-A (ASCII, STX … ETX, fields
// as hex or signed decimal tokens) and CoLa-B (binary, 4 × 0x02, big-endian length, payload, XOR checksum).
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "roadpreview/roadside/scan.hpp"

namespace roadpreview::roadside {

enum class ColaFraming { A, B };

struct SickChannel {
    std::string name;                ///< "DIST1", "RSSI1", …
    float scale = 1.0f, offset = 0.0f;
    std::int32_t start_angle = 0;    ///< 1/10000 °, the sensor's convention (90° straight ahead)
    std::uint16_t step = 0;          ///< 1/10000 °
    std::vector<std::uint16_t> data; ///< raw values (8-bit channels widened)
};

struct SickEncoder {
    std::uint32_t position = 0;
    std::uint16_t speed = 0;
};

struct SickPosition {
    float x = 0, y = 0, z = 0, rot_x = 0, rot_y = 0, rot_z = 0;
    std::uint8_t rotation_type = 0;
};

struct SickTime {
    std::uint16_t year = 0;
    std::uint8_t month = 0, day = 0, hour = 0, minute = 0, second = 0;
    std::uint32_t microsecond = 0;
};

struct SickEvent {
    std::string type;
    std::uint32_t encoder_position = 0, time_us = 0;
    std::int32_t angle = 0;
};

/// Every field an LMDscandata telegram carries.
struct SickScanTelegram {
    ColaFraming framing = ColaFraming::B;
    std::uint16_t version = 0, device_number = 0;
    std::uint32_t serial_number = 0;
    std::array<std::uint8_t, 2> device_status{};
    std::uint16_t telegram_counter = 0, scan_counter = 0;
    std::uint32_t time_since_startup_us = 0, time_of_transmission_us = 0;
    std::array<std::uint8_t, 2> input_status{}, output_status{};
    std::uint16_t reserved = 0;
    std::uint32_t scan_frequency = 0;         ///< 1/100 Hz
    std::uint32_t measurement_frequency = 0;  ///< 100 Hz
    std::vector<SickEncoder> encoders;
    std::vector<SickChannel> channels16, channels8;
    std::optional<SickPosition> position;
    std::optional<std::string> name, comment;
    std::optional<SickTime> time;
    std::optional<SickEvent> event;

    double scan_frequency_hz() const { return scan_frequency / 100.0; }
    const SickChannel* channel(const std::string& channel_name) const;  ///< nullptr when absent
};

/// Decodes one framed telegram (framing included; CoLa-A or CoLa-B recognised by its first bytes). Returns
/// nothing for a well-formed telegram that is not `sSN LMDscandata` (a command reply). Throws
/// std::runtime_error for a bad frame, a checksum error, a truncated or inconsistent telegram, with `where`.
std::optional<SickScanTelegram> decode_sick_telegram(const std::uint8_t* data, std::size_t size,
                                                     const std::string& where);

/// The scan of a telegram in the scanner frame: DIST1 (mm × scale + offset) → m, 0 → no return, the angles
/// turned from SICK's 90°-ahead convention, RSSI1 as intensities. `time_s` is left for the caller.
LaserScan to_laser_scan(const SickScanTelegram& telegram, const std::string& source);

/// Cuts a byte stream (a reassembled TCP stream) into framed telegrams; resynchronises on the next frame start
/// after garbage, counting the bytes skipped. A CoLa-B frame declaring more than `max_length` bytes is garbage.
class SickStreamFramer {
public:
    explicit SickStreamFramer(std::size_t max_length = 1u << 20) : max_length_(max_length) {}
    void feed(const std::uint8_t* data, std::size_t size);
    /// The next complete framed telegram, or false until more bytes arrive.
    bool next(std::vector<std::uint8_t>& frame);
    std::size_t skipped_bytes() const { return skipped_; }
    std::size_t pending_bytes() const { return buffer_.size() - start_; }

private:
    std::vector<std::uint8_t> buffer_;
    std::size_t start_ = 0, skipped_ = 0, max_length_;
};

/// One telegram of a capture: capture time (s) and its bytes.
struct TimedTelegram {
    double time_s = 0.0;
    std::vector<std::uint8_t> bytes;
    std::string where;
};

/// The telegrams of a sick_scan_xd `.pcapng.json` dump (array of entries with `tcp.payload` hex and
/// `tcp.time_relative`). Throws std::runtime_error naming the file and entry on bad JSON or hex.
std::vector<TimedTelegram> read_sick_json(const std::string& path);

/// The sensor→client TCP streams of a pcap/pcapng capture (libpcap + libtins), reassembled and framed into
/// telegrams; the time is that of the segment that completed each telegram. A capture that breaks off inside a
/// record throws std::runtime_error naming the file, unless `truncated` is given: then it receives why, and the
/// telegrams before the break are returned.
std::vector<TimedTelegram> read_sick_pcap(const std::string& path, int sensor_port = 2112,
                                          std::string* truncated = nullptr);

/// Counts of a decode, for `roadside info` and the tests.
struct SickDecodeCounts {
    std::int64_t telegrams = 0, scans = 0, other = 0, bad = 0;
    std::int64_t repeated = 0;  ///< scan telegrams that repeat the scan before (dropped, not in `scans`)
};

/// The LaserScans of a list of telegrams. Scan time: capture time minus the sensor's own latency (time of
/// transmission − time since start-up). Bad telegrams are counted and, with `skip_bad`, skipped, else thrown. A
/// scan telegram of the same device, scan counter and start time as the scan before is that scan received again
/// (an LMS111 capture holds three, 3 ms after their first copy): it is dropped and counted as `repeated`.
std::vector<LaserScan> scans_from_telegrams(const std::vector<TimedTelegram>& telegrams, bool skip_bad,
                                            SickDecodeCounts* counts = nullptr);

}  // namespace roadpreview::roadside
