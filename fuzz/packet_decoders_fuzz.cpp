// SPDX-License-Identifier: BSD-3-Clause
// libFuzzer target for the packet decoders: the first byte picks an Ouster profile or a Velodyne model, the
// rest is cut into packets of that decoder's size (or, when the second byte is odd, fed as one packet of
// whatever size it has). Decoders may reject a packet with std::invalid_argument; anything else — a crash,
// a sanitizer report, another exception, a non-finite point — is a finding.
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <stdexcept>
#include <string>
#include <vector>

#include <roadpreview/io/ouster.hpp>
#include <roadpreview/io/velodyne.hpp>

namespace rp = roadpreview;

namespace {

rp::OusterMetadata metadata(const char* profile) {
    // 16 beams, 4 columns per packet, 512 columns: small packets, so random inputs span several frames.
    std::string angles = "[";
    for (int i = 0; i < 16; ++i) angles += std::to_string(15 - 2 * i) + (i < 15 ? "," : "]");
    const std::string json = std::string("{\"lidar_mode\": \"512x10\", \"prod_sn\": \"122201000998\", ") +
                             "\"beam_altitude_angles\": " + angles + ", \"beam_azimuth_angles\": " + angles +
                             ", \"data_format\": {\"pixels_per_column\": 16, \"columns_per_packet\": 4, "
                             "\"columns_per_frame\": 512, \"pixel_shift_by_row\": " + angles +
                             ", \"udp_profile_lidar\": \"" + profile + "\"}}";
    return rp::parse_ouster_metadata(json, "fuzz.json");
}

void check(const rp::Frame& f) {
    for (Eigen::Index i = 0; i < f.points.size(); ++i)
        if (!std::isfinite(f.points.data()[i])) std::abort();
    if (f.point_times.size() != static_cast<std::size_t>(f.points.rows())) std::abort();
}

template <typename Add>
void feed(const std::uint8_t* data, std::size_t size, std::size_t packet, bool raw, Add add) {
    if (raw) {
        add(data, size);
        return;
    }
    for (std::size_t at = 0; at + packet <= size; at += packet) add(data + at, packet);
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    if (size < 2) return 0;
    static const char* kProfiles[] = {"LEGACY", "RNG19_RFL8_SIG16_NIR16", "RNG19_RFL8_SIG16_NIR16_DUAL",
                                      "RNG15_RFL8_NIR8", "FUSA_RNG15_RFL8_NIR8_DUAL"};
    const int pick = data[0] % 8;
    const bool raw = data[1] & 1;
    data += 2;
    size -= 2;
    if (pick < 5) {
        static std::vector<rp::OusterMetadata> metas = [] {
            std::vector<rp::OusterMetadata> m;
            for (const char* p : kProfiles) m.push_back(metadata(p));
            return m;
        }();
        rp::OusterDecoder d(metas[static_cast<std::size_t>(pick)]);
        feed(data, size, metas[static_cast<std::size_t>(pick)].lidar_packet_bytes(), raw,
             [&](const std::uint8_t* p, std::size_t n) {
                 try {
                     if (auto f = d.add_packet(p, n, 0.0)) check(*f);
                 } catch (const std::invalid_argument&) {
                 }
             });
        if (auto f = d.finish()) check(*f);
        if (size >= rp::kOusterImuPacketBytes) rp::decode_ouster_imu(data, rp::kOusterImuPacketBytes, 0.0, metas[0].imu_to_sensor);
        return 0;
    }
    const rp::VelodyneModel models[] = {rp::VelodyneModel::Vlp16, rp::VelodyneModel::Vlp32c, rp::VelodyneModel::Hdl32e};
    const rp::VelodyneModel model = models[pick - 5];
    rp::VelodyneDecoder d(model, rp::default_velodyne_calibration(model), 90.0);
    std::vector<rp::Frame> done;
    feed(data, size, rp::kVelodynePacketBytes, raw, [&](const std::uint8_t* p, std::size_t n) {
        try {
            d.add_packet(p, n, 0.0, done);
        } catch (const std::invalid_argument&) {
        }
    });
    for (const auto& f : done) check(f);
    if (auto f = d.finish()) check(*f);
    return 0;
}
