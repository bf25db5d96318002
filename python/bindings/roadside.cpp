// SPDX-License-Identifier: BSD-3-Clause
// Bindings of the roadside library (roadpreview.roadside wraps them): scan readers, telegram decoding, the
// stages (labelling, L-shape, assignment) for cross-checks, and the cycle processor (JSON lines out).
#include <cmath>
#include <stdexcept>
#include <string>

#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include "common.hpp"
#include "roadpreview/roadside/processor.hpp"
#include "roadpreview/roadside/sick.hpp"

namespace py = pybind11;
namespace rs = roadpreview::roadside;

namespace {

using FloatArray = py::array_t<float, py::array::c_style | py::array::forcecast>;

py::dict scan_dict(const rs::LaserScan& s) {
    py::dict d;
    d["time_s"] = s.time_s;
    d["scanner"] = s.scanner;
    d["counter"] = s.counter;
    d["start_angle_rad"] = s.start_angle_rad;
    d["step_rad"] = s.step_rad;
    d["ranges_m"] = FloatArray(static_cast<py::ssize_t>(s.ranges_m.size()), s.ranges_m.data());
    d["intensities"] = s.intensities.empty() ? py::object(py::none())
                                             : FloatArray(static_cast<py::ssize_t>(s.intensities.size()), s.intensities.data());
    d["pose"] = s.pose ? py::object(py::make_tuple(s.pose->x_m, s.pose->y_m, s.pose->yaw_rad)) : py::object(py::none());
    d["source"] = s.source;
    return d;
}

py::list scan_list(const std::vector<rs::LaserScan>& scans) {
    py::list out;
    for (const auto& s : scans) out.append(scan_dict(s));
    return out;
}

rs::LaserScan scan_from(double time_s, int scanner, double start_angle_rad, double step_rad, const FloatArray& ranges,
                        const std::string& source) {
    if (ranges.ndim() != 1) throw std::invalid_argument("ranges_m must be one-dimensional");
    rs::LaserScan s;
    s.time_s = time_s;
    s.scanner = scanner;
    s.start_angle_rad = start_angle_rad;
    s.step_rad = step_rad;
    s.ranges_m.assign(ranges.data(), ranges.data() + ranges.size());
    s.source = source;
    return s;
}

// A scan dict of the Python package (roadpreview.roadside.read_scans): pose None or (x, y, yaw).
rs::LaserScan scan_from_dict(const py::dict& d) {
    rs::LaserScan s = scan_from(d["time_s"].cast<double>(), d["scanner"].cast<int>(), d["start_angle_rad"].cast<double>(),
                                d["step_rad"].cast<double>(), d["ranges_m"].cast<FloatArray>(),
                                d.contains("source") ? d["source"].cast<std::string>() : "python scan");
    if (d.contains("pose") && !d["pose"].is_none()) {
        const auto [x, y, yaw] = d["pose"].cast<std::tuple<double, double, double>>();
        s.pose = rs::Pose2{x, y, yaw};
    }
    return s;
}

std::vector<rs::Point2> points_from(const DoubleArray& xy) {
    if (xy.ndim() != 2 || xy.shape(1) != 2) throw std::invalid_argument("points must be an (N, 2) array of x, y");
    std::vector<rs::Point2> pts(static_cast<std::size_t>(xy.shape(0)));
    for (std::size_t i = 0; i < pts.size(); ++i) {
        pts[i] = {xy.data()[2 * i], xy.data()[2 * i + 1], 0};
        if (!std::isfinite(pts[i].x_m) || !std::isfinite(pts[i].y_m))
            throw std::invalid_argument("points must be finite: row " + std::to_string(i) + " is not");
    }
    return pts;
}

py::tuple box_tuple(const rs::Box& b) { return py::make_tuple(b.x_m, b.y_m, b.length_m, b.width_m, b.heading_rad); }

py::dict telegram_dict(const rs::SickScanTelegram& t) {
    py::dict d;
    d["framing"] = t.framing == rs::ColaFraming::A ? "A" : "B";
    d["version"] = t.version, d["device_number"] = t.device_number, d["serial_number"] = t.serial_number;
    d["telegram_counter"] = t.telegram_counter, d["scan_counter"] = t.scan_counter;
    d["time_since_startup_us"] = t.time_since_startup_us, d["time_of_transmission_us"] = t.time_of_transmission_us;
    d["scan_frequency_hz"] = t.scan_frequency_hz(), d["measurement_frequency_hz"] = t.measurement_frequency * 100.0;
    py::list channels;
    for (const auto* list : {&t.channels16, &t.channels8})
        for (const auto& c : *list) {
            py::dict cd;
            cd["name"] = c.name, cd["scale"] = c.scale, cd["offset"] = c.offset;
            cd["start_angle_deg"] = c.start_angle * 1e-4, cd["step_deg"] = c.step * 1e-4;
            cd["data"] = py::array_t<std::uint16_t>(static_cast<py::ssize_t>(c.data.size()), c.data.data());
            channels.append(cd);
        }
    d["channels"] = channels;
    return d;
}

class PyProcessor {
public:
    explicit PyProcessor(const std::string& site_yaml, const std::string& where) : p_(rs::parse_site(site_yaml, where)) {}
    std::vector<std::string> push(const py::dict& scan) {
        const rs::LaserScan s = scan_from_dict(scan);
        const InUse in_use(this, kWhat);
        py::gil_scoped_release release;
        return lines(p_.push(s));
    }
    void learn_world(const py::list& scans) {
        std::vector<rs::LaserScan> all;
        for (const auto& d : scans) all.push_back(scan_from_dict(d.cast<py::dict>()));
        const InUse in_use(this, kWhat);
        py::gil_scoped_release release;
        p_.learn_world(all);
    }
    // Foreground flags of a scan with a pose against the learned world background.
    py::array_t<bool> world_foreground(const py::dict& scan) {
        const rs::LaserScan s = scan_from_dict(scan);
        const InUse in_use(this, kWhat);
        const std::vector<bool> fg = p_.world_foreground(s);
        py::array_t<bool> out(static_cast<py::ssize_t>(fg.size()));
        for (std::size_t i = 0; i < fg.size(); ++i) out.mutable_data()[i] = fg[i];
        return out;
    }
    void add_detections(const std::vector<std::tuple<double, double, double, double, double, std::string, double>>& d) {
        std::vector<rs::CameraDetection> out;
        for (const auto& [t, x, y, w, h, cls, score] : d) out.push_back({t, x, y, w, h, cls, score});
        const InUse in_use(this, kWhat);
        p_.add_detections(out);
    }
    std::vector<std::string> finish() {
        const InUse in_use(this, kWhat);
        return lines(p_.finish());
    }
    std::size_t detections_outside_scans() const {
        const InUse in_use(this, kWhat);
        return p_.detections_outside_scans();
    }
    std::string detections_outside_warning() const {
        const InUse in_use(this, kWhat);
        return p_.detections_outside_warning();
    }
    std::vector<std::string> scanner_names() const {
        std::vector<std::string> out;
        for (const auto& scanner : p_.site().scanners) out.push_back(scanner.name);
        return out;
    }
    // Each site scanner's clock offset (s), in the site file's order: what puts its scans on the site clock.
    std::vector<double> time_offsets_s() const {
        std::vector<double> out;
        for (const auto& scanner : p_.site().scanners) out.push_back(scanner.time_offset_s);
        return out;
    }

private:
    static constexpr const char* kWhat = "roadside Processor";
    static std::vector<std::string> lines(const std::vector<rs::Cycle>& cycles) {
        std::vector<std::string> out;
        for (const auto& c : cycles) out.push_back(rs::cycle_to_json(c));
        return out;
    }
    rs::Processor p_;
};

}  // namespace

void bind_roadside(py::module_& parent) {
    py::module_ m = parent.def_submodule("roadside", "Roadside perception (use roadpreview.roadside)");
    m.def("read_sick_json", [](const std::string& path, bool skip_bad) {
        return scan_list(rs::scans_from_telegrams(rs::read_sick_json(path), skip_bad));
    }, py::arg("path"), py::arg("skip_bad") = false);
    m.def("read_sick_pcap", [](const std::string& path, int port, bool skip_bad) {
        std::string truncated;  // with skip_bad, the telegrams before a break are read and the break warned of
        auto scans = scan_list(rs::scans_from_telegrams(rs::read_sick_pcap(path, port, skip_bad ? &truncated : nullptr),
                                                        skip_bad));
        if (!truncated.empty() && PyErr_WarnEx(PyExc_RuntimeWarning, truncated.c_str(), 1) != 0)
            throw py::error_already_set();
        return scans;
    }, py::arg("path"), py::arg("sensor_port") = 2112, py::arg("skip_bad") = false);
    m.def("read_carmen_log", [](const std::string& path, double rate_hz) {
        bool timestamps_missing = false;
        auto scans = scan_list(rs::read_carmen_log(path, rate_hz, 0.0, &timestamps_missing));
        return py::make_tuple(std::move(scans), timestamps_missing);
    }, py::arg("path"), py::arg("rate_hz"), "(scans, whether every timestamp was 0 and rate_hz timed the scans)");
    m.def("read_scan_csv", [](const std::string& path) { return scan_list(rs::read_scan_csv(path)); });
    m.def("decode_telegram", [](const py::bytes& data) -> py::object {
        const std::string s = data;
        const auto t = rs::decode_sick_telegram(reinterpret_cast<const std::uint8_t*>(s.data()), s.size(), "telegram");
        return t ? py::object(telegram_dict(*t)) : py::object(py::none());
    });
    m.def("label_points", [](const DoubleArray& xy, double cell_m, int dilation_cells) {
        const auto g = rs::label_points(points_from(xy), cell_m, dilation_cells);
        return py::make_tuple(py::array_t<std::int32_t>(static_cast<py::ssize_t>(g.point_label.size()), g.point_label.data()),
                              g.components, py::make_tuple(g.x0_m, g.y0_m, g.cell_m));
    });
    m.def("fit_l_shape", [](const DoubleArray& xy) { return box_tuple(rs::fit_l_shape(points_from(xy))); });
    m.def("assign", [](const std::vector<std::vector<double>>& cost, double gate) { return rs::assign(cost, gate); });
    m.def("image_to_site", [](const std::array<double, 9>& h, double u, double v) -> py::object {
        double x = 0, y = 0;
        return rs::image_to_site(h, u, v, x, y) ? py::object(py::make_tuple(x, y)) : py::object(py::none());
    });
    m.def("fit_homography", &rs::fit_homography);
    m.def("site_to_wgs84", [](const std::string& site_yaml, double x_m, double y_m) {
        const rs::LatLon p = rs::SiteGeodesy(rs::parse_site(site_yaml, "site").origin).to_wgs84(x_m, y_m);
        return py::make_tuple(p.lat_deg, p.lon_deg);
    });
    m.def("wgs84_to_site", [](const std::string& site_yaml, double lat_deg, double lon_deg) {
        double x = 0, y = 0;
        rs::SiteGeodesy(rs::parse_site(site_yaml, "site").origin).to_site(lat_deg, lon_deg, x, y);
        return py::make_tuple(x, y);
    });
    py::class_<PyProcessor>(m, "Processor")
        .def(py::init<const std::string&, const std::string&>(), py::arg("site_yaml"), py::arg("where") = "site")
        .def("push", &PyProcessor::push)
        .def("learn_world", &PyProcessor::learn_world)
        .def("world_foreground", &PyProcessor::world_foreground)
        .def("add_detections", &PyProcessor::add_detections)
        .def("finish", &PyProcessor::finish)
        .def_property_readonly("time_offsets_s", &PyProcessor::time_offsets_s)
        .def_property_readonly("detections_outside_scans", &PyProcessor::detections_outside_scans)
        .def("detections_outside_warning", &PyProcessor::detections_outside_warning)
        .def_property_readonly("scanner_names", &PyProcessor::scanner_names);
}
