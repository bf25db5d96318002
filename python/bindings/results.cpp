// SPDX-License-Identifier: BSD-3-Clause
// The pipeline's result in Python: read-only numpy views of the C++ result's buffers (no copy), kept alive by the
// result object; obstacle records as views of their fields.
#include <cstdio>

#include "common.hpp"

namespace {

// Read-only strided numpy view of one field of every record, (K,) or (K, 3) (no copy).
template <typename Record, typename Get>
py::array field_view(const RecordsRef<Record>& ref, Get get) {
    using Field = std::decay_t<decltype(get(std::declval<const Record&>()))>;
    const auto k = static_cast<py::ssize_t>(ref.items->size());
    const void* first = ref.items->empty() ? nullptr : &get(ref.items->front());
    py::array a;
    if constexpr (std::is_arithmetic_v<Field>) {
        a = py::array(py::dtype::of<Field>(), {k}, {py::ssize_t(sizeof(Record))}, first, ref.owner);
    } else {  // std::array<double, 3>
        using Scalar = typename Field::value_type;
        a = py::array(py::dtype::of<Scalar>(), {k, static_cast<py::ssize_t>(std::tuple_size_v<Field>)},
                      {py::ssize_t(sizeof(Record)), py::ssize_t(sizeof(Scalar))}, first, ref.owner);
    }
    a.attr("setflags")(false);
    return a;
}

template <typename Record, typename Get>
void add_field(py::class_<RecordsRef<Record>>& cls, const char* name, Get get, const char* doc) {
    cls.def_property_readonly(name, [get](const RecordsRef<Record>& ref) { return field_view(ref, get); }, doc);
}

template <typename Record>
py::class_<RecordsRef<Record>> bind_records(py::module_& m, const char* name, const char* doc) {
    py::class_<RecordsRef<Record>> cls(m, name, doc);
    cls.def("__len__", [](const RecordsRef<Record>& r) { return r.items->size(); })
        .def("__repr__", [prefix = "<roadpreview." + std::string(name) + ": "](const RecordsRef<Record>& r) {
            return prefix + std::to_string(r.items->size()) + ">";
        });
    return cls;
}
template <typename Record>
py::object records_or_none(const std::optional<std::vector<Record>>& items, py::object owner) {
    return items ? py::cast(RecordsRef<Record>{&*items, std::move(owner)}) : py::object(py::none());
}

py::object optional_value(const std::optional<double>& v) { return optional_number(v.has_value(), v.value_or(0.0)); }

// A reason's text (the C++ result holds an enum), None for none ("").
py::object text_or_none(const char* text) { return *text ? py::object(py::str(text)) : py::object(py::none()); }

// Short one-line descriptions for the interactive prompt: what a user checks first.
std::string printed(const char* format, double v) {
    char buf[64];
    std::snprintf(buf, sizeof buf, format, v);
    return buf;
}

std::string iri_text(const rp::Iri& i) {
    if (!i.value) return std::string("None (") + rp::to_string(i.reason) + ")";
    const std::string noise = i.noise ? " (noise alone " + printed("%.2f", *i.noise) + ")" : "";
    return printed("%.2f", *i.value) + " m/km over " + printed("%.1f", i.length_m) + " m" + noise;
}

std::string iri_repr(const rp::Iri& i) { return "<roadpreview.Iri " + iri_text(i) + ">"; }

std::string roughness_repr(const rp::Roughness& r) {
    if (!r.iso_class)
        return std::string("<roadpreview.Roughness no class: ") + rp::to_string(r.reason) + "; IRI " + iri_text(r.iri) + ">";
    return "<roadpreview.Roughness class " + std::string(1, *r.iso_class) + ", G_d(n0) " + printed("%.3g", r.gd_n0) +
           " m³, confidence " + printed("%.2f", r.confidence) + ", band " + printed("%.2f", r.band_lo) + "–" +
           printed("%.2f", r.band_hi) + " cycles/m; IRI " + iri_text(r.iri) + ">";
}

std::string result_repr(const rp::Result& r) {
    const auto cls = [](const rp::Roughness& x) {
        return x.iso_class ? std::string(1, *x.iso_class) : std::string("-");
    };
    std::string out = "<roadpreview.Result frame " + std::to_string(r.frame);
    if (!r.source.empty()) out += " of " + r.source;
    out += ": " + std::to_string(r.points.input) + " points, " + std::to_string(r.points.ground) + " ground, " +
           rp::to_string(r.path.status);
    if (r.status != rp::FrameStatus::Ok) return out + "; no profiles: " + rp::to_string(r.status) + ">";
    return out + "; class left " + cls(r.left.roughness) + ", right " + cls(r.right.roughness) + ", vehicle " +
           cls(r.vehicle) + "; " + printed("%.2f", r.timing_ms.total) + " ms>";
}

}  // namespace

void bind_obstacles(py::module_& m) {
    auto clusters = bind_records<rp::Cluster>(
        m, "Obstacles", "Every cluster of the frame, one row per id (nearest first); arrays are read-only views");
    using C = rp::Cluster;
    add_field(clusters, "id", [](const C& c) -> const auto& { return c.id; }, "cluster id");
    add_field(clusters, "count", [](const C& c) -> const auto& { return c.count; }, "points per cluster");
    add_field(clusters, "centroid", [](const C& c) -> const auto& { return c.centroid; }, "(K, 3) mean point, m");
    add_field(clusters, "aabb_min", [](const C& c) -> const auto& { return c.aabb_min; }, "(K, 3) axis-aligned lower bounds, m");
    add_field(clusters, "aabb_max", [](const C& c) -> const auto& { return c.aabb_max; }, "(K, 3) axis-aligned upper bounds, m");
    add_field(clusters, "obb_center", [](const C& c) -> const auto& { return c.obb.center; }, "(K, 3) oriented box centre, m");
    add_field(clusters, "obb_size", [](const C& c) -> const auto& { return c.obb.size; },
              "(K, 3) oriented box length (along yaw), width, height, m");
    add_field(clusters, "obb_yaw", [](const C& c) -> const auto& { return c.obb.yaw; }, "oriented box yaw, rad in (−π/2, π/2]");
    add_field(clusters, "ground_offset", [](const C& c) -> const auto& { return c.ground_offset; },
              "local ground level above the frame's ground plane, m");
    add_field(clusters, "height", [](const C& c) -> const auto& { return c.height; }, "highest point above the local ground, m");
    add_field(clusters, "bottom", [](const C& c) -> const auto& { return c.bottom; }, "lowest point above the local ground, m");

    auto in_path = bind_records<rp::PathObstacle>(m, "PathObstacles", "The clusters in one wheel's path, ordered by s_start");
    using P = rp::PathObstacle;
    add_field(in_path, "id", [](const P& o) -> const auto& { return o.id; }, "cluster id (index into Result.obstacles)");
    add_field(in_path, "s_start", [](const P& o) -> const auto& { return o.s_start; }, "arc length of its nearest point in the corridor, m");
    add_field(in_path, "s_end", [](const P& o) -> const auto& { return o.s_end; }, "arc length of its farthest point in the corridor, m");
    add_field(in_path, "height", [](const P& o) -> const auto& { return o.height; }, "highest of those points above the local ground, m");
}

void bind_results(py::module_& m) {
    py::class_<rp::Iri>(m, "Iri", "International Roughness Index of one profile (or the mean of both wheels)")
        .def_property_readonly("value", [](const rp::Iri& i) { return optional_value(i.value); }, "m/km, or None with .reason")
        .def_readonly("length", &rp::Iri::length_m, "m, the stretch it covers")
        .def_property_readonly("backed_fraction", [](const rp::Iri& i) { return optional_value(i.backed_fraction); },
                               "bins of the stretch that hold points (the rest interpolated), or None when unknown")
        .def_property_readonly("noise", [](const rp::Iri& i) { return optional_value(i.noise); },
                               "m/km, the IRI the stretch's bin errors alone would give, or None when unknown")
        .def_property_readonly("reason", [](const rp::Iri& i) { return text_or_none(rp::to_string(i.reason)); })
        .def("__repr__", &iri_repr);

    py::class_<rp::Roughness>(m, "Roughness", "ISO 8608 roughness of one profile (or of the vehicle)")
        .def_property_readonly("iso_class", [](const rp::Roughness& r) -> py::object {
            return r.iso_class ? py::object(py::str(std::string(1, *r.iso_class))) : py::object(py::none());
        }, "'A'..'H', or None with .reason")
        .def_property_readonly("gd_n0", [](const rp::Roughness& r) { return optional_number(r.iso_class.has_value(), r.gd_n0); },
                               "G_d(n0) of the w = 2 fit, m³")
        .def_property_readonly("gd_n0_free", [](const rp::Roughness& r) { return optional_number(r.iso_class.has_value(), r.gd_n0_free); },
                               "G_d(n0) of the free-waviness fit, m³")
        .def_property_readonly("waviness", [](const rp::Roughness& r) { return optional_number(r.iso_class.has_value(), r.waviness); },
                               "w of the free fit")
        .def_property_readonly("band", [](const rp::Roughness& r) -> py::object {
            if (!r.iso_class) return py::none();
            return py::make_tuple(r.band_lo, r.band_hi);
        }, "(lo, hi) cycles/m actually used by the fit")
        .def_property_readonly("n", [](py::object self) { return view_of(self.cast<const rp::Roughness&>().spectrum.n, self); },
                               "spatial frequencies, cycles/m (n[0] = 0)")
        .def_property_readonly("psd", [](py::object self) { return view_of(self.cast<const rp::Roughness&>().spectrum.psd, self); },
                               "one-sided displacement PSD G_d(n), m³")
        .def_property_readonly("octave_centers", [](py::object self) { return view_of(self.cast<const rp::Roughness&>().octave_centers, self); })
        .def_property_readonly("octave_gd", [](py::object self) { return view_of(self.cast<const rp::Roughness&>().octave_gd, self); })
        .def_property_readonly("reason", [](const rp::Roughness& r) { return text_or_none(rp::to_string(r.reason)); })
        .def_property_readonly("confidence", [](const rp::Roughness& r) { return optional_number(r.iso_class.has_value(), r.confidence); },
                               "probability that the class is right, given the fit's spread")
        .def_property_readonly("noise_psd", [](py::object self) -> py::object {
            const auto& r = self.cast<const rp::Roughness&>();
            return r.noise_psd.empty() ? py::object(py::none()) : py::object(view_of(r.noise_psd, self));
        }, "m³, expected PSD of the bin errors on the grid n, or None when unknown")
        .def_property_readonly("noise_floor", [](const rp::Roughness& r) { return optional_value(r.noise_floor); },
                               "m³, mean of noise_psd over the analysis band")
        .def_property_readonly("backed_fraction", [](const rp::Roughness& r) { return optional_value(r.backed_fraction); },
                               "fraction of the stretch's bins that hold points")
        .def_property_readonly("band_limit", [](const rp::Roughness& r) { return text_or_none(rp::to_string(r.band_limit)); },
                               "what set the band's upper edge: requested, nyquist, sampling, noise or wheels")
        .def_readonly("iri", &rp::Roughness::iri)
        .def("__repr__", &roughness_repr);

    py::class_<rp::Profile>(m, "Profile", "Height profile under one wheel, binned along its path")
        .def_readonly("s0", &rp::Profile::s0)
        .def_readonly("ds", &rp::Profile::ds)
        .def_property_readonly("s", [](py::object self) { return view_of(self.cast<const rp::Profile&>().s, self); }, "bin centres, m")
        .def_property_readonly("z", [](py::object self) { return view_of(self.cast<const rp::Profile&>().z, self); },
                               "levelled height per bin, m; NaN where missing")
        .def_property_readonly("count", [](py::object self) { return view_of(self.cast<const rp::Profile&>().count, self); },
                               "points per bin (0 where interpolated or missing)")
        .def_property_readonly("spread", [](py::object self) { return view_of(self.cast<const rp::Profile&>().spread, self); },
                               "sample standard deviation of each bin's heights, m; NaN below 2 points")
        .def_readonly("roughness", &rp::Profile::roughness)
        .def_property_readonly("blocked", [](py::object self) {
            return view_of(self.cast<const rp::Profile&>().blocked, self, py::dtype("bool"));
        }, "bool per bin: covered by an obstacle (z is NaN there)")
        .def_property_readonly("obstacles", [](py::object self) {
            return records_or_none(self.cast<const rp::Profile&>().obstacles, self);
        }, "PathObstacles in this wheel's path, or None when clustering is off");

    py::class_<rp::Result>(m, "Result", "Everything one frame yields")
        .def_readonly("frame", &rp::Result::frame, "0-based count of process() calls on this estimator")
        .def_readonly("source", &rp::Result::source, "where the points came from, as given to process()")
        .def_readonly("timestamp", &rp::Result::timestamp, "s, as given to process(); None when not given")
        .def_readonly("speed_mps", &rp::Result::speed_mps, "m/s, the motion the paths were planned from")
        .def_readonly("yaw_rate_rps", &rp::Result::yaw_rate_rps, "rad/s, positive turning left")
        .def_property_readonly("ground_mask", [](py::object self) {
            return view_of(self.cast<const rp::Result&>().ground_mask, self, py::dtype("bool"));
        }, "bool per input row")
        .def_property_readonly("plane", [](const rp::Result& r) { return plane_array(r.plane); }, "(a, b, c, d), base frame, c > 0")
        .def_property_readonly("points", [](const rp::Result& r) {
            py::dict d;
            d["input"] = r.points.input, d["finite"] = r.points.finite, d["roi"] = r.points.roi, d["ground"] = r.points.ground;
            return d;
        }, "point counts: input rows, finite rows, in the region of interest, ground")
        .def_property_readonly("path", [](const rp::Result& r) { return path_dict(r.path); },
                               "the wheel paths (docs/output.md `path`): status, centre of rotation, wheel radii")
        .def_property_readonly("mounting", [](const rp::Result& r) {
            const rp::Extrinsics& e = r.extrinsics;
            py::dict d;
            d["extrinsics"] = py::make_tuple(e.x_m, e.y_m, e.z_m, e.roll_rad, e.pitch_rad, e.yaw_rad);
            d["source"] = r.mounting_source.empty() ? py::object(py::none()) : py::object(py::str(r.mounting_source));
            const std::optional<rp::MountingCheck> c =
                r.plane ? std::optional(rp::check_mounting(*r.plane)) : std::nullopt;
            d["ground_offset"] = c ? py::object(py::float_(c->offset_m)) : py::object(py::none());
            d["ground_tilt_deg"] = c ? py::object(py::float_(c->tilt_deg)) : py::object(py::none());
            d["disagrees"] = c ? py::object(py::bool_(c->disagrees)) : py::object(py::none());
            return d;
        }, "the output line's `mounting` (docs/output.md): extrinsics in force (x, y, z m; roll, pitch, yaw rad), "
           "their source, and how far the fitted ground lies off the base frame's level (`disagrees`)")
        .def_readonly("left", &rp::Result::left, "the left wheel's Profile (with its roughness)")
        .def_readonly("right", &rp::Result::right, "the right wheel's Profile (with its roughness)")
        .def_readonly("vehicle", &rp::Result::vehicle, "Roughness of both wheels together (ISO 8608 class, IRI)")
        .def_property_readonly("obstacles", [](py::object self) {
            return records_or_none(self.cast<const rp::Result&>().obstacles, self);
        }, "Obstacles: every cluster of the frame, or None when clustering is off")
        .def_property_readonly("cluster_labels", [](py::object self) {
            return view_of(self.cast<const rp::Result&>().cluster_labels, self);
        }, "int32 per input row: the id of its cluster, -1 for none")
        .def_property_readonly("timing_ms", [](const rp::Result& r) {
            py::dict d;
            d["ground"] = r.timing_ms.ground, d["path"] = r.timing_ms.path, d["profile"] = r.timing_ms.profile;
            d["roughness"] = r.timing_ms.roughness, d["obstacles"] = r.timing_ms.obstacles, d["total"] = r.timing_ms.total;
            return d;
        }, "ms per stage, measured inside C++ (ground includes the frame transform and the crop)")
        .def_property_readonly("reason", [](const rp::Result& r) -> py::object {
            return r.status == rp::FrameStatus::Ok ? py::object(py::none()) : py::object(py::str(rp::to_string(r.status)));
        }, "why the frame has no profiles (docs/output.md `reason`), None when it has them")
        .def_property_readonly("fusion", [](const rp::Result& r) -> py::object {
            if (!r.fusion) return py::none();
            const rp::FusionStatus& f = *r.fusion;
            py::dict d;
            d["method"] = rp::to_string(f.method), d["frames"] = f.frames, d["coverage"] = f.coverage;
            d["frame_coverage"] = f.frame_coverage;
            d["reset"] = f.reset.empty() ? py::object(py::none()) : py::object(py::str(f.reset));
            d["pose"] = py::make_tuple(f.pose.x_m, f.pose.y_m, f.pose.yaw_rad);
            d["time_ms"] = r.timing_ms.fusion;
            return d;
        }, "the temporal fusion's state after this frame (docs/output.md), or None without fusion")
        .def("to_json", [](const rp::Result& r, std::optional<std::int64_t> frame, bool timing) {
            return rp::result_to_json(r, rp::LineOptions{frame, timing});
        }, py::arg("frame") = py::none(), py::arg("timing") = true,
           "The CLI's output line for this frame; `frame` restates its number, timing=False leaves the times out")
        .def("to_dict", [](const rp::Result& r) { return py::module_::import("json").attr("loads")(rp::result_to_json(r)); },
             "The CLI's output line for this frame, parsed")
        .def("__repr__", &result_repr);
}
