// SPDX-License-Identifier: BSD-3-Clause
// rp.native route: the C++ RouteBuilder (docs/method.md §10) fed with results or with a run's output lines;
// segments come out shaped as the numpy reference's (rp.reference.Route) so either can fill a segment table.
// And the ProfileReadout (§10, "Readout"), whose wheels are handed out as copies (the array moves on).
#include <cstdio>

#include "common.hpp"

namespace {

py::object pose_tuple(const std::optional<rp::Pose2>& p) {
    if (!p) return py::none();
    return py::make_tuple(p->x_m, p->y_m, p->yaw_rad);
}

py::dict wheel_dict(const rp::SegmentWheel& w) {
    py::dict d;
    d["roughness"] = w.roughness;
    d["iri"] = w.iri;
    d["backed_fraction"] = w.backed_fraction;
    return d;
}

py::dict segment_dict(const rp::RouteSegment& s) {
    py::dict d;
    d["length_m"] = s.length_m;
    d["start_m"] = s.start_m;
    d["end_m"] = s.end_m;
    d["start"] = pose_tuple(s.start);
    d["end"] = pose_tuple(s.end);
    d["left"] = wheel_dict(s.left);
    d["right"] = wheel_dict(s.right);
    d["vehicle"] = wheel_dict(s.vehicle);
    return d;
}

std::optional<rp::Pose2> pose_from(const std::optional<std::array<double, 3>>& p) {
    if (!p) return std::nullopt;
    return rp::Pose2{(*p)[0], (*p)[1], (*p)[2]};
}

}  // namespace

void bind_route(py::module_& m) {
    py::class_<rp::StitchedProfile>(m, "StitchedProfile", "One wheel along the drive: bin j covers [j·ds, (j+1)·ds)")
        .def_readonly("ds", &rp::StitchedProfile::ds)
        .def_property_readonly("z", [](py::object self) { return view_of(self.cast<const rp::StitchedProfile&>().z, self); },
                               "m, NaN where missing (interior gaps up to profile.max_gap_m filled)")
        .def_property_readonly("count", [](py::object self) {
            return view_of(self.cast<const rp::StitchedProfile&>().count, self);
        }, "points behind each bin over all frames")
        .def_property_readonly("spread", [](py::object self) {
            return view_of(self.cast<const rp::StitchedProfile&>().spread, self);
        }, "m, NaN below two points")
        .def_property_readonly("frames", [](py::object self) {
            return view_of(self.cast<const rp::StitchedProfile&>().frames, self);
        }, "frames that backed each bin")
        .def_property_readonly("blocked", [](py::object self) {
            return view_of(self.cast<const rp::StitchedProfile&>().blocked, self, py::dtype("bool"));
        }, "bool per bin: a frame saw an obstacle there and none saw road (z is NaN, no gap filled across it)");

    py::class_<rp::RouteBuilder>(m, "RouteBuilder", "Frames' profiles stitched along the drive, and its segments")
        .def(py::init([](const std::string& config_json) { return rp::RouteBuilder(config_from(config_json)); }),
             py::arg("config_json"))
        .def("add", [](rp::RouteBuilder& route, const rp::Result& r, std::optional<std::array<double, 3>> pose) {
            route.add(r, pose_from(pose));
        }, py::arg("result"), py::arg("pose") = py::none(), "Adds a frame's result, in drive order; pose: (x, y, yaw)")
        .def("add_line", [](rp::RouteBuilder& route, const std::string& line, std::optional<std::array<double, 3>> pose,
                            const std::string& where) {
            const rp::Result r = rp::route_input_from_json(line, where);
            route.add(r, pose_from(pose));
        }, py::arg("line"), py::arg("pose") = py::none(), py::arg("where") = "output line",
           "Adds a frame from its output line (JSON text, as written by the CLI or stored by batch)")
        .def_property_readonly("frames", &rp::RouteBuilder::frames)
        .def_property_readonly("distance_m", &rp::RouteBuilder::distance_m, "driven by the last frame added")
        .def("check_segment_length", &rp::RouteBuilder::check_segment_length, py::arg("length_m"),
             "ValueError unless length_m is a finite number of at least profile.ds_m")
        .def("stitched", [](const rp::RouteBuilder& route, const std::string& wheel) {
            if (wheel != "left" && wheel != "right") throw py::value_error("wheel must be 'left' or 'right', got " + wheel);
            return wheel == "left" ? route.left() : route.right();
        }, py::arg("wheel"))
        .def("segments", [](const rp::RouteBuilder& route, double length_m) {
            py::list out;
            for (const rp::RouteSegment& s : route.segments(length_m)) out.append(segment_dict(s));
            return out;
        }, py::arg("length_m"),
           "One dict per segment: length_m, start_m, end_m, start/end (x, y, yaw) or None, and per left/right/"
           "vehicle: roughness, iri, backed_fraction");

    py::class_<rp::ReadoutProfile>(m, "ReadoutProfile", "One wheel's readout, from the wheel on")
        .def_property_readonly("s", [](py::object self) {
            return view_of(self.cast<const rp::ReadoutProfile&>().s, self);
        }, "m, arc length along the wheel's current path to each bin centre")
        .def_property_readonly("z", [](py::object self) {
            return view_of(self.cast<const rp::ReadoutProfile&>().z, self);
        }, "m, the height read; NaN where none was")
        .def_property_readonly("count", [](py::object self) {
            return view_of(self.cast<const rp::ReadoutProfile&>().count, self);
        }, "points behind each bin when it was read (0: interpolated)");

    py::class_<rp::ProfileReadout>(m, "ProfileReadout", "Each wheel's profile read a fixed distance ahead, kept along "
                                                        "the drive")
        .def(py::init([](const std::string& config_json, double ahead_m) {
            return rp::ProfileReadout(config_from(config_json), ahead_m);
        }), py::arg("config_json"), py::arg("ahead_m"))
        .def("add", [](rp::ProfileReadout& readout, const rp::Result& r, std::optional<std::array<double, 3>> pose) {
            readout.add(r, pose_from(pose));
        }, py::arg("result"), py::arg("pose") = py::none(), "Adds a frame's result, in drive order; pose: (x, y, yaw)")
        .def("add_line", [](rp::ProfileReadout& readout, const std::string& line,
                            std::optional<std::array<double, 3>> pose, const std::string& where) {
            readout.add(rp::route_input_from_json(line, where), pose_from(pose));
        }, py::arg("line"), py::arg("pose") = py::none(), py::arg("where") = "output line",
           "Adds a frame from its output line (JSON text, as written by the CLI or stored by batch)")
        .def_property_readonly("ahead_m", &rp::ProfileReadout::ahead_m)
        .def_property_readonly("frames", &rp::ProfileReadout::frames)
        .def_property_readonly("distance_m", &rp::ProfileReadout::distance_m, "driven by the last frame added")
        .def_property_readonly("left", [](const rp::ProfileReadout& r) { return r.left(); }, "a copy")
        .def_property_readonly("right", [](const rp::ProfileReadout& r) { return r.right(); }, "a copy")
        .def("__repr__", [](const rp::ProfileReadout& r) {
            char text[160];
            std::snprintf(text, sizeof text, "<roadpreview.ProfileReadout %g m ahead: %lld frame(s), %.2f m driven>",
                          r.ahead_m(), static_cast<long long>(r.frames()), r.distance_m());
            return std::string(text);
        });
}
