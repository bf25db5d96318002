// SPDX-License-Identifier: BSD-3-Clause
// Beam self-calibration from Python: rp.calibrate_beams(...) runs the C++ estimator on frames given as numpy
// arrays; the result is the beams file's content (BeamCalibration), which saves itself as beams.yaml.
#include <algorithm>
#include <cstdio>

#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include "roadpreview/roadpreview.hpp"

namespace py = pybind11;
namespace rp = roadpreview;

namespace {

using Points = py::array_t<float, py::array::c_style | py::array::forcecast>;
using Beams = py::array_t<std::int32_t, py::array::c_style | py::array::forcecast>;

rp::PointsView view_of(const Points& p) {
    if (p.ndim() != 2 || p.shape(1) < 3)
        throw std::invalid_argument("points must be an N×C array (C >= 3)");
    return rp::points_view(p.data(), p.shape(0), p.shape(1));
}

// Each frame's beams: as given, or — when every `beams` is None — found by scan order or elevation, `indexing`
// saying how (method.md §8).
std::vector<std::vector<std::int32_t>> frame_beams(const std::vector<rp::PointsView>& views,
                                                   const std::vector<py::object>& beams, int beam_count,
                                                   rp::BeamCalibration& indexing) {
    std::vector<std::vector<std::int32_t>> out(views.size());
    const bool unnumbered = std::all_of(beams.begin(), beams.end(), [](const py::object& b) { return b.is_none(); });
    if (!unnumbered) {
        for (std::size_t k = 0; k < views.size(); ++k) {
            if (beams[k].is_none())
                throw std::invalid_argument("calibrate_beams: frame " + std::to_string(k) +
                                            " has no beam numbers while others have: give them for every frame or none");
            const Beams b = py::cast<Beams>(beams[k]);
            out[k].assign(b.data(), b.data() + b.size());
        }
        return out;
    }
    py::gil_scoped_release release;
    rp::find_beam_centres(views, beam_count, indexing);
    for (std::size_t k = 0; k < views.size(); ++k)
        out[k] = rp::beams_of_points(views[k], indexing, "frame " + std::to_string(k));
    return out;
}

std::vector<rp::PointsView> views_of(const std::vector<Points>& points, const std::vector<py::object>& beams) {
    if (points.size() != beams.size()) throw std::invalid_argument("calibrate_beams: one beams entry per frame");
    std::vector<rp::PointsView> views;
    for (const Points& p : points) views.push_back(view_of(p));
    return views;
}

// Runs the motion calibrator over the frames and their poses.
rp::BeamCalibration calibrate(const std::vector<Points>& points, const std::vector<py::object>& beams,
                              const std::vector<std::array<double, 3>>& poses, int beam_count,
                              const std::string& config_json, const rp::CalibrationOptions& options) {
    const std::vector<rp::PointsView> views = views_of(points, beams);
    if (points.size() != poses.size()) throw std::invalid_argument("calibrate_beams: one pose per frame");
    rp::BeamCalibration indexing;
    const auto index = frame_beams(views, beams, beam_count, indexing);
    py::gil_scoped_release release;
    rp::BeamCalibrator calibrator(rp::config_from_json(config_json, "config"), beam_count, options);
    for (std::size_t k = 0; k < views.size(); ++k)
        calibrator.add_frame(views[k], index[k], rp::Pose2{poses[k][0], poses[k][1], poses[k][2]});
    rp::BeamCalibration out = calibrator.solve();
    rp::adopt_beam_indexing(out, indexing);
    return out;
}

// Runs the surface calibrator over the frames (no motion).
rp::BeamCalibration calibrate_on_surface(const std::vector<Points>& points, const std::vector<py::object>& beams,
                                         int beam_count, const std::string& config_json,
                                         const rp::SurfaceCalibrationOptions& options) {
    const std::vector<rp::PointsView> views = views_of(points, beams);
    rp::BeamCalibration indexing;
    const auto index = frame_beams(views, beams, beam_count, indexing);
    py::gil_scoped_release release;
    rp::SurfaceCalibrator calibrator(rp::config_from_json(config_json, "config"), beam_count, options);
    for (std::size_t k = 0; k < views.size(); ++k) calibrator.add_frame(views[k], index[k]);
    rp::BeamCalibration out = calibrator.solve();
    rp::adopt_beam_indexing(out, indexing);
    return out;
}

template <typename Get>
py::array per_beam(const rp::BeamCalibration& c, Get get) {
    std::vector<double> v;
    for (const rp::BeamOffsets& b : c.beams) v.push_back(get(b));
    return py::array_t<double>(static_cast<py::ssize_t>(v.size()), v.data());
}

}  // namespace

void bind_calibration(py::module_& m) {
    py::register_exception<rp::CalibrationError>(m, "CalibrationError", PyExc_ValueError);
    m.def("short_drive_warning", &rp::short_drive_warning, py::arg("travel_m"));
    py::class_<rp::BeamCalibration>(m, "BeamCalibration", "Per-beam offsets estimated from a drive (a beams file)")
        .def_readwrite("sensor_model", &rp::BeamCalibration::sensor_model)
        .def_readwrite("serial", &rp::BeamCalibration::serial)
        .def_readonly("beam_count", &rp::BeamCalibration::beam_count)
        .def_readonly("frames", &rp::BeamCalibration::frames)
        .def_readonly("travel_m", &rp::BeamCalibration::travel_m)
        .def_readonly("residual_m", &rp::BeamCalibration::residual_m, "robust σ of one point's height after the fit")
        .def("__repr__", [](const rp::BeamCalibration& c) {
            const auto determined =
                std::count_if(c.beams.begin(), c.beams.end(), [](const auto& b) { return b.determined; });
            char text[200];
            std::snprintf(text, sizeof text,
                          "<roadpreview.BeamCalibration %s%s%s: %lld of %d beams determined from %lld frame(s) over "
                          "%.2f m>", c.sensor_model.empty() ? "sensor" : c.sensor_model.c_str(),
                          c.serial.empty() ? "" : " ", c.serial.c_str(), static_cast<long long>(determined),
                          c.beam_count, static_cast<long long>(c.frames), c.travel_m);
            return std::string(text);
        })
        .def_property_readonly("determined", [](const rp::BeamCalibration& c) {
            std::vector<bool> d;
            for (const auto& b : c.beams) d.push_back(b.determined);
            return py::array(py::cast(d)).attr("astype")("bool");
        })
        .def_property_readonly("elevation_offset_deg", [](const rp::BeamCalibration& c) {
            return per_beam(c, [](const rp::BeamOffsets& b) { return b.elevation_offset_deg; });
        })
        .def_property_readonly("elevation_sigma_deg", [](const rp::BeamCalibration& c) {
            return per_beam(c, [](const rp::BeamOffsets& b) { return b.elevation_sigma_deg; });
        })
        .def_property_readonly("range_offset_m", [](const rp::BeamCalibration& c) {
            return per_beam(c, [](const rp::BeamOffsets& b) { return b.range_offset_m; });
        })
        .def_property_readonly("range_sigma_m", [](const rp::BeamCalibration& c) {
            return per_beam(c, [](const rp::BeamOffsets& b) { return b.range_sigma_m; });
        })
        .def_property_readonly("observations", [](const rp::BeamCalibration& c) {
            return per_beam(c, [](const rp::BeamOffsets& b) { return static_cast<double>(b.observations); });
        })
        .def_property_readonly("elevation_deg", [](const rp::BeamCalibration& c) {
            return per_beam(c, [](const rp::BeamOffsets& b) { return b.elevation_deg; });
        }, "index by elevation: each beam's centre (NaN for decoder-numbered beams)")
        .def("apply", [](const rp::BeamCalibration& c, const Points& points, const Beams& beams) {
            if (points.ndim() != 2 || points.shape(1) < 3 || beams.ndim() != 1 || beams.shape(0) != points.shape(0))
                throw std::invalid_argument("apply: need N×C points (C >= 3) and N beam indices");
            std::vector<std::int32_t> index(beams.data(), beams.data() + beams.size());
            for (std::int32_t b : index)
                if (b >= c.beam_count) throw std::invalid_argument("apply: beam " + std::to_string(b) + " of a " +
                                                                   std::to_string(c.beam_count) + "-beam calibration");
            Points out(std::vector<py::ssize_t>{points.shape(0), points.shape(1)});
            std::copy(points.data(), points.data() + points.size(), out.mutable_data());
            rp::apply_beam_calibration(out.mutable_data(), points.shape(0), points.shape(1), index, c);
            return out;
        }, py::arg("points"), py::arg("beams"), "a corrected copy of sensor-frame points (beam −1: left as is)")
        .def("beam_sigmas_deg", &rp::calibrated_beam_sigmas_deg, py::arg("others_deg") = 0.0,
             "each beam's stated elevation σ (deg), for Config.profile.beam_sigmas_deg; others_deg for the beams the "
             "drive could not determine")
        .def("to_yaml", &rp::beam_calibration_to_yaml)
        .def("save", &rp::write_beam_calibration, py::arg("path"), "write the beams file (YAML)");
    m.def("read_beam_calibration", &rp::read_beam_calibration, py::arg("path"));
    m.def("calibrate_beams", [](const std::vector<Points>& points, const std::vector<py::object>& beams,
                                const std::vector<std::array<double, 3>>& poses, int beam_count,
                                const std::string& config_json, double cell_m, double max_sigma_deg,
                                int min_observations) {
        rp::CalibrationOptions o;
        o.cell_m = cell_m;
        o.max_sigma_deg = max_sigma_deg;
        o.min_observations = min_observations;
        return calibrate(points, beams, poses, beam_count, config_json, o);
    });
    m.def("calibrate_beams_on_surface", [](const std::vector<Points>& points, const std::vector<py::object>& beams,
                                           int beam_count, const std::string& config_json, double max_sigma_deg,
                                           int min_frames) {
        rp::SurfaceCalibrationOptions o;
        o.max_sigma_deg = max_sigma_deg;
        o.min_frames = min_frames;
        return calibrate_on_surface(points, beams, beam_count, config_json, o);
    });
}
