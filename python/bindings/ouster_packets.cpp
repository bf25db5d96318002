// SPDX-License-Identifier: BSD-3-Clause
// Ouster packets from anywhere but a pcap (ROS bags: roadpreview.io_bags): the library's OusterDecoder fed
// packet by packet from Python. Frames come out as the pcap reader's frames do (rp.io.Frame).
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <utility>

#include "roadpreview/roadpreview.hpp"

namespace py = pybind11;
namespace rp = roadpreview;

namespace {

// The decoder plus the name its frames carry as their source.
struct OusterPacketDecoder {
    rp::OusterDecoder decoder;
    std::string source;

    std::optional<rp::Frame> named(std::optional<rp::Frame> f) const {
        if (f) f->source = source;
        return f;
    }
};

std::string_view bytes_of(const py::bytes& b) { return static_cast<std::string_view>(b); }

}  // namespace

void bind_ouster_packets(py::module_& m) {
    py::class_<OusterPacketDecoder>(m, "OusterPacketDecoder",
                                    "Ouster lidar and IMU packets (bytes) → frames, with the sensor's metadata JSON")
        .def(py::init([](const std::string& metadata_json, const std::string& source) {
                 rp::OusterMetadata meta = rp::parse_ouster_metadata(metadata_json, source);
                 return OusterPacketDecoder{rp::OusterDecoder(std::move(meta)), source};
             }),
             py::arg("metadata_json"), py::arg("source"))
        .def("add_packet", [](OusterPacketDecoder& d, const py::bytes& packet, double capture_time) {
            const std::string_view b = bytes_of(packet);
            const auto* data = reinterpret_cast<const std::uint8_t*>(b.data());
            return d.named(d.decoder.add_packet(data, b.size(), capture_time));
        }, py::arg("packet"), py::arg("capture_time"),
           "Adds a lidar packet; returns the previous frame when this one starts a new frame")
        .def("add_imu", [](OusterPacketDecoder& d, const py::bytes& packet, double capture_time) {
            const std::string_view b = bytes_of(packet);
            const auto* data = reinterpret_cast<const std::uint8_t*>(b.data());
            d.decoder.add_imu(rp::decode_ouster_imu(data, b.size(), capture_time, d.decoder.metadata().imu_to_sensor));
        }, py::arg("packet"), py::arg("capture_time"))
        .def("finish", [](OusterPacketDecoder& d) { return d.named(d.decoder.finish()); },
             "The frame being assembled, if any")
        .def_property_readonly("info", [](const OusterPacketDecoder& d) {
            const rp::OusterMetadata& meta = d.decoder.metadata();
            py::dict info;
            info["format"] = "ouster bag";
            info["sensor_model"] = meta.prod_line;
            info["profile"] = std::string(rp::to_string(meta.profile));
            info["serial"] = meta.prod_sn;
            info["beams"] = meta.pixels_per_column;
            info["frame_rate_hz"] = meta.frame_rate_hz;
            info["lidar_packet_bytes"] = meta.lidar_packet_bytes();
            return info;
        });
}
