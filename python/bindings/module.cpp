// SPDX-License-Identifier: BSD-3-Clause
// The extension module roadpreview._core. Points are read in place when they are float32 with unit column stride
// (N×3, N×4, or a column slice of either); anything else is converted once. Result arrays are read-only numpy
// views of the C++ result's buffers (no copy), kept alive by the result object.
#include "common.hpp"

PYBIND11_MODULE(_core, m) {
    m.doc() = "roadpreview C++ core (use the roadpreview package, not this module directly)";
    m.attr("__version__") = rp::kVersion;
    py::register_exception_translator([](std::exception_ptr p) {
        try {
            if (p) std::rethrow_exception(p);
        } catch (const std::invalid_argument& e) {
            PyErr_SetString(PyExc_ValueError, e.what());
        }
    });
    bind_obstacles(m);
    bind_results(m);
    bind_estimator(m);
    bind_stages(m);
    bind_io(m);
    bind_calibration(m);
    bind_range_sensor(m);
    bind_drive(m);
    bind_route(m);
    bind_roadside(m);
    bind_ouster_packets(m);
    m.def("read_frame", [](const std::string& path, int columns) {
        rp::Frame f = rp::read_frame(path, columns);
        auto owner = std::make_unique<rp::PointMatrix>(std::move(f.points));
        rp::PointMatrix* raw = owner.get();
        py::capsule free_when_done(owner.release(), [](void* p) { delete static_cast<rp::PointMatrix*>(p); });
        return py::array_t<float>({raw->rows(), Eigen::Index(4)}, raw->data(), free_when_done);
    }, py::arg("path"), py::arg("columns") = 0, "N×4 float32 (x, y, z, intensity) of a KITTI .bin or .pcd file");
    m.def("expand_inputs", &rp::expand_inputs);
    m.def("default_config_json", [] { return rp::config_to_json(rp::Config{}); });
    m.def("validate_config", [](const std::string& json) { config_from(json); });
}
