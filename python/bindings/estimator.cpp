// SPDX-License-Identifier: BSD-3-Clause
// rp.Estimator: the pipeline, one frame per process() call; the GIL is released while it runs.
#include "common.hpp"

void bind_estimator(py::module_& m) {
    py::class_<rp::Estimator>(m, "Estimator")
        .def(py::init([](const std::string& config_json) { return rp::Estimator(config_from(config_json)); }), py::arg("config_json"))
        .def("process", [](rp::Estimator& est, py::handle points, double speed, double yaw_rate, const std::string& source,
                           std::optional<double> timestamp, const std::string& yaw_rate_source,
                           std::optional<std::array<double, 3>> pose,
                           std::optional<py::array_t<float, py::array::c_style | py::array::forcecast>> range_variances,
                           std::optional<py::array> error_groups, std::optional<py::array> beams) {
            py::object holder;
            const rp::PointsView view = points_from(points, holder);
            rp::FrameMotion motion{timestamp, std::nullopt};
            if (pose) motion.pose = rp::Pose2{(*pose)[0], (*pose)[1], (*pose)[2]};
            const auto one_per_point = [&](const py::array& a, const char* name) {
                if (a.ndim() != 1 || a.shape(0) != view.rows())
                    throw py::value_error(std::string(name) + " must be a 1-D array with one entry per point (" +
                                          std::to_string(view.rows()) + "), got shape " +
                                          py::str(a.attr("shape")).cast<std::string>());
            };
            rp::PointErrors errors;
            if (range_variances) {
                one_per_point(*range_variances, "range_variances");
                errors.range_variances_m2 = range_variances->data();
            }
            using Ids = py::array_t<std::int32_t, py::array::c_style | py::array::forcecast>;
            const auto ids = [&](const py::array& a, const char* name) {
                if (a.dtype().kind() != 'i' && a.dtype().kind() != 'u')
                    throw py::type_error(std::string(name) + " must be an integer array, got dtype " +
                                         py::str(a.dtype()).cast<std::string>());
                one_per_point(a, name);
                return a.cast<Ids>();
            };
            Ids groups, beam_ids;
            if (error_groups) {
                groups = ids(*error_groups, "error_groups");
                errors.error_groups = groups.data();
            }
            if (beams) {
                beam_ids = ids(*beams, "beams");
                errors.beams = beam_ids.data();
            }
            rp::Result r;
            {
                const InUse in_use(&est, "Estimator");
                py::gil_scoped_release release;
                r = est.process(view, speed, yaw_rate, source, motion, errors);
            }
            r.yaw_rate_source = yaw_rate_source;
            return r;
        }, py::arg("points"), py::arg("speed"), py::arg("yaw_rate"), py::arg("source") = "", py::arg("timestamp") = py::none(),
           py::arg("yaw_rate_source") = "", py::arg("pose") = py::none(), py::arg("range_variances") = py::none(),
           py::arg("error_groups") = py::none(), py::arg("beams") = py::none())
        .def("reset", [](rp::Estimator& est) {
            const InUse in_use(&est, "Estimator");
            est.reset();
        }, "Forgets the fused map, the pose and the clock");
}
