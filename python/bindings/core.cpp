// SPDX-License-Identifier: BSD-3-Clause
// pybind11 bindings. Points are read in place when they are float32 with unit column stride (N×3, N×4,
// or a column slice of either); anything else is converted once. Result arrays are read-only numpy
// views of the C++ result's buffers (no copy), kept alive by the result object.
#include <cmath>
#include <cstdio>
#include <memory>
#include <type_traits>

#include <pybind11/pybind11.h>
#include <pybind11/numpy.h>
#include <pybind11/stl.h>

#include "roadpreview/roadpreview.hpp"

namespace py = pybind11;
namespace rp = roadpreview;

void bind_io(py::module_& m);  // io.cpp
void bind_calibration(py::module_& m);  // calibration.cpp
void bind_range_sensor(py::module_& m);  // range_sensor.cpp
void bind_ouster_packets(py::module_& m);  // ouster_packets.cpp

namespace {

// A 1-D (or any) float64 array, converted once when the caller passes another dtype or layout.
using DoubleArray = py::array_t<double, py::array::c_style | py::array::forcecast>;

template <typename T>
py::array view_of(const std::vector<T>& v, py::handle owner, py::dtype dtype = py::dtype::of<T>()) {
    py::array a(dtype, {static_cast<py::ssize_t>(v.size())}, {static_cast<py::ssize_t>(sizeof(T))}, v.data(), owner);
    a.attr("setflags")(false);  // writing would change the C++ result behind the user's back
    return a;
}

// A list of obstacle records inside a C++ object that `owner` keeps alive.
template <typename Record>
struct RecordsRef {
    const std::vector<Record>* items;
    py::object owner;
};
using ClustersRef = RecordsRef<rp::Cluster>;
using PathObstaclesRef = RecordsRef<rp::PathObstacle>;

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

// A Python object that owns `value` (for C++ results handed out as views).
template <typename T>
py::object owner_of(std::unique_ptr<T> value) {
    return py::capsule(value.release(), [](void* p) { delete static_cast<T*>(p); });
}

// Points as a view; `holder` keeps a converted copy alive when one is needed.
rp::PointsView points_from(const py::handle& obj, py::object& holder, const char* name = "points") {
    if (!py::isinstance<py::array>(obj))
        throw py::type_error(std::string(name) + " must be a numpy array, got " + std::string(py::str(obj.get_type().attr("__name__"))));
    auto a = py::reinterpret_borrow<py::array>(obj);
    const std::string shape = py::str(a.attr("shape"));
    if (a.ndim() != 2) throw py::value_error(std::string(name) + " must be a 2-D array (N, 3) or (N, 4), got shape " + shape);
    if (a.shape(1) < 3) throw py::value_error(std::string(name) + " needs at least 3 columns (x, y, z), got shape " + shape);
    const char kind = a.dtype().kind();
    if (kind != 'f' || (a.itemsize() != 4 && a.itemsize() != 8))
        throw py::type_error(std::string(name) + " must be float32 or float64, got " + std::string(py::str(a.dtype())));
    // Non-native byte order (a big-endian '>f4' array on this machine) is converted by the copy below.
    const bool native = a.dtype().attr("isnative").cast<bool>();
    const bool in_place = native && a.itemsize() == 4 && a.strides(1) == 4 && a.strides(0) > 0 && a.strides(0) % 4 == 0;
    if (in_place) {
        holder = a;
        return rp::points_view(static_cast<const float*>(a.data()), a.shape(0), a.strides(0) / 4);
    }
    auto copy = py::array_t<float, py::array::c_style | py::array::forcecast>::ensure(a);
    holder = copy;
    return rp::points_view(copy.data(), copy.shape(0), copy.shape(1));
}

// None where the JSON line has null: absent, or not finite (a flat stretch has no free-fit slope).
py::object optional_number(bool present, double v) {
    return present && std::isfinite(v) ? py::object(py::float_(v)) : py::object(py::none());
}

py::object plane_array(const std::optional<rp::Plane>& p) {
    if (!p) return py::none();
    return py::array_t<double>(4, p->data());
}

py::dict path_dict(const rp::WheelPaths& p) {
    const bool arc = p.status == rp::PathStatus::Arc;
    py::dict d;
    d["status"] = rp::to_string(p.status);
    d["icr_y"] = optional_number(arc, p.icr_y);
    d["left_radius"] = optional_number(arc, p.left_radius);
    d["right_radius"] = optional_number(arc, p.right_radius);
    return d;
}

rp::Config config_from(const std::string& json) { return rp::config_from_json(json, "config"); }

std::vector<double> as_vector(const DoubleArray& a) {
    if (a.ndim() != 1) throw py::value_error("expected a 1-D array, got " + std::to_string(a.ndim()) + "-D");
    return std::vector<double>(a.data(), a.data() + a.size());
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

template <typename Record>
py::object records_or_none(const std::optional<std::vector<Record>>& items, py::object owner) {
    return items ? py::cast(RecordsRef<Record>{&*items, std::move(owner)}) : py::object(py::none());
}

// A profile of heights z with the count and spread of the points behind each bin (for the stage functions).
rp::Profile profile_of(const DoubleArray& z, double ds,
                       const py::object& count, const py::object& spread) {
    rp::Profile p;
    p.ds = ds;
    p.z = as_vector(z);
    const auto c = py::array_t<std::int32_t, py::array::c_style | py::array::forcecast>::ensure(count);
    if (!c || c.ndim() != 1) throw py::value_error("count must be a 1-D array of integers");
    p.count.assign(c.data(), c.data() + c.size());
    p.spread = as_vector(DoubleArray::ensure(spread));
    if (p.count.size() != p.z.size() || p.spread.size() != p.z.size())
        throw py::value_error("z, count and spread must have one entry per bin");
    return p;
}

py::object optional_value(const std::optional<double>& v) { return optional_number(v.has_value(), v.value_or(0.0)); }

// Short one-line descriptions for the interactive prompt: what a user checks first.
std::string printed(const char* format, double v) {
    char buf[64];
    std::snprintf(buf, sizeof buf, format, v);
    return buf;
}

std::string iri_text(const rp::Iri& i) {
    if (!i.value) return "None (" + i.reason + ")";
    return printed("%.2f", *i.value) + " m/km over " + printed("%.1f", i.length_m) + " m";
}

std::string iri_repr(const rp::Iri& i) { return "<roadpreview.Iri " + iri_text(i) + ">"; }

std::string roughness_repr(const rp::Roughness& r) {
    if (!r.iso_class) return "<roadpreview.Roughness no class: " + r.reason + "; IRI " + iri_text(r.iri) + ">";
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
    if (!r.reason.empty()) return out + "; no profiles: " + r.reason + ">";
    return out + "; class left " + cls(r.left.roughness) + ", right " + cls(r.right.roughness) + ", vehicle " +
           cls(r.vehicle) + "; " + printed("%.2f", r.timing_ms.total) + " ms>";
}

void bind_results(py::module_& m) {
    py::class_<rp::Iri>(m, "Iri", "International Roughness Index of one profile (or the mean of both wheels)")
        .def_property_readonly("value", [](const rp::Iri& i) { return optional_value(i.value); }, "m/km, or None with .reason")
        .def_readonly("length", &rp::Iri::length_m, "m, the stretch it covers")
        .def_property_readonly("backed_fraction", [](const rp::Iri& i) { return optional_value(i.backed_fraction); },
                               "bins of the stretch that hold points (the rest interpolated), or None when unknown")
        .def_property_readonly("reason", [](const rp::Iri& i) -> py::object {
            return i.reason.empty() ? py::object(py::none()) : py::object(py::str(i.reason));
        })
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
        .def_property_readonly("reason", [](const rp::Roughness& r) -> py::object {
            return r.reason.empty() ? py::object(py::none()) : py::object(py::str(r.reason));
        })
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
        .def_property_readonly("band_limit", [](const rp::Roughness& r) -> py::object {
            return r.band_limit.empty() ? py::object(py::none()) : py::object(py::str(r.band_limit));
        }, "what set the band's upper edge: requested, nyquist, sampling or noise")
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
        .def_readonly("frame", &rp::Result::frame)
        .def_readonly("source", &rp::Result::source)
        .def_readonly("timestamp", &rp::Result::timestamp)
        .def_property_readonly("ground_mask", [](py::object self) {
            return view_of(self.cast<const rp::Result&>().ground_mask, self, py::dtype("bool"));
        }, "bool per input row")
        .def_property_readonly("plane", [](const rp::Result& r) { return plane_array(r.plane); }, "(a, b, c, d), base frame, c > 0")
        .def_property_readonly("points", [](const rp::Result& r) {
            py::dict d;
            d["input"] = r.points.input, d["finite"] = r.points.finite, d["roi"] = r.points.roi, d["ground"] = r.points.ground;
            return d;
        })
        .def_property_readonly("path", [](const rp::Result& r) { return path_dict(r.path); })
        .def_readonly("left", &rp::Result::left)
        .def_readonly("right", &rp::Result::right)
        .def_readonly("vehicle", &rp::Result::vehicle)
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
        })
        .def_property_readonly("reason", [](const rp::Result& r) -> py::object {
            return r.reason.empty() ? py::object(py::none()) : py::object(py::str(r.reason));
        })
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
        .def("to_json", &rp::result_to_json, "The CLI's output line for this frame")
        .def("to_dict", [](const rp::Result& r) { return py::module_::import("json").attr("loads")(rp::result_to_json(r)); },
             "The CLI's output line for this frame, parsed")
        .def("__repr__", &result_repr);
}

void bind_estimator(py::module_& m) {
    py::class_<rp::Estimator>(m, "Estimator")
        .def(py::init([](const std::string& config_json) { return rp::Estimator(config_from(config_json)); }), py::arg("config_json"))
        .def("process", [](rp::Estimator& est, py::handle points, double speed, double yaw_rate, const std::string& source,
                           std::optional<double> timestamp, const std::string& yaw_rate_source,
                           std::optional<std::array<double, 3>> pose) {
            py::object holder;
            const rp::PointsView view = points_from(points, holder);
            rp::FrameMotion motion{timestamp, std::nullopt};
            if (pose) motion.pose = rp::Pose2{(*pose)[0], (*pose)[1], (*pose)[2]};
            rp::Result r;
            {
                py::gil_scoped_release release;
                r = est.process(view, speed, yaw_rate, source, motion);
            }
            r.yaw_rate_source = yaw_rate_source;
            return r;
        }, py::arg("points"), py::arg("speed"), py::arg("yaw_rate"), py::arg("source") = "", py::arg("timestamp") = py::none(),
           py::arg("yaw_rate_source") = "", py::arg("pose") = py::none())
        .def("reset", &rp::Estimator::reset, "Forgets the fused map, the pose and the clock");
}

void bind_obstacle_stages(py::module_& m) {
    m.def("cluster_labels", [](py::handle points, const std::string& config_json) {
        py::object holder;
        const rp::PointsView view = points_from(points, holder);
        const std::vector<std::int32_t> labels = rp::cluster_labels(view, config_from(config_json).obstacles);
        return py::array_t<std::int32_t>(static_cast<py::ssize_t>(labels.size()), labels.data());
    }, "Euclidean cluster id of every point (-1: none)");
    m.def("find_obstacles", [](py::handle base_points, py::array_t<bool, py::array::c_style | py::array::forcecast> ground_mask,
                               std::array<double, 4> plane, const std::string& config_json) {
        py::object holder;
        const rp::Config cfg = config_from(config_json);
        const rp::PointsView view = points_from(base_points, holder, "base_points");
        const std::vector<std::uint8_t> mask(ground_mask.data(), ground_mask.data() + ground_mask.size());
        auto clustering = std::make_unique<rp::Clustering>(rp::find_obstacles(view, mask, plane, cfg.ground, cfg.obstacles));
        const rp::Clustering& c = *clustering;
        py::object owner = owner_of(std::move(clustering));
        return py::make_tuple(ClustersRef{&c.clusters, owner}, view_of(c.label, owner));
    }, "(Obstacles, cluster id per point) of the non-ground ROI points among base-frame points");
    m.def("wheel_obstacles", [](py::handle base_points, py::array_t<std::int32_t, py::array::c_style | py::array::forcecast> label_array,
                                const ClustersRef& obstacles,
                                std::array<double, 4> plane, double speed, double yaw_rate, const std::string& wheel,
                                const std::string& config_json) {
        if (wheel != "left" && wheel != "right") throw py::value_error("wheel must be 'left' or 'right', got '" + wheel + "'");
        py::object holder;
        const rp::Config cfg = config_from(config_json);
        const rp::PointsView view = points_from(base_points, holder, "base_points");
        const std::vector<std::int32_t> labels(label_array.data(), label_array.data() + label_array.size());
        const rp::Clustering clustering{*obstacles.items, labels};
        const rp::Levelling L = rp::levelling_for(cfg.profile.level ? &plane : nullptr);
        const rp::WheelPaths paths = rp::plan_paths(speed, yaw_rate, cfg.track_width, cfg.path);
        auto found = std::make_unique<std::vector<rp::PathObstacle>>(rp::wheel_obstacles(
            view, clustering, plane, L, paths, wheel == "left" ? rp::Wheel::Left : rp::Wheel::Right, cfg.tire_width,
            cfg.profile.preview_length_m, cfg.obstacles));
        const auto* items = found.get();
        return PathObstaclesRef{items, owner_of(std::move(found))};
    }, "The clusters in one wheel's widened corridor");
    m.def("blocked_bins", [](const std::vector<double>& s_start, const std::vector<double>& s_end, const std::string& config_json) {
        if (s_start.size() != s_end.size()) throw py::value_error("s_start and s_end differ in length");
        const rp::Config cfg = config_from(config_json);
        std::vector<rp::PathObstacle> obstacles;
        for (std::size_t i = 0; i < s_start.size(); ++i) obstacles.push_back({0, s_start[i], s_end[i], 0.0});
        const std::vector<std::uint8_t> blocked =
            rp::blocked_bins(obstacles, rp::bin_count(cfg.profile), cfg.profile.ds_m, cfg.obstacles.safety_margin_m);
        py::array_t<bool> out(static_cast<py::ssize_t>(blocked.size()));
        std::copy(blocked.begin(), blocked.end(), out.mutable_data());
        return out;
    });
}

void bind_stages(py::module_& m) {
    m.def("to_base_frame", [](py::handle points, const std::string& config_json) {
        py::object holder;
        const rp::PointsView v = points_from(points, holder);
        const rp::RigidTransform T = rp::to_rigid_transform(rp::effective_extrinsics(config_from(config_json)));
        py::array_t<bool> finite(v.rows());
        std::vector<double> base;
        for (Eigen::Index i = 0; i < v.rows(); ++i) {
            const double p[3] = {v(i, 0), v(i, 1), v(i, 2)};
            finite.mutable_at(i) = std::isfinite(p[0]) && std::isfinite(p[1]) && std::isfinite(p[2]);
            if (!finite.at(i)) continue;
            double b[3];
            rp::transform_point(T, p, b);
            base.insert(base.end(), b, b + 3);
        }
        py::array_t<double> xyz({static_cast<py::ssize_t>(base.size() / 3), py::ssize_t(3)});
        std::copy(base.begin(), base.end(), xyz.mutable_data());
        return py::make_tuple(xyz, finite);
    });
    m.def("fit_plane", [](py::handle points) {
        py::object holder;
        return plane_array(rp::fit_plane(points_from(points, holder)));
    });
    m.def("fit_ground", [](py::handle points, const std::string& config_json) {
        py::object holder;
        const rp::Config cfg = config_from(config_json);
        const rp::PointsView view = points_from(points, holder);
        rp::GroundFit fit;
        {
            py::gil_scoped_release release;
            fit = rp::fit_ground(view, cfg.ground);
        }
        py::array_t<bool> mask(static_cast<py::ssize_t>(fit.mask.size()));
        std::copy(fit.mask.begin(), fit.mask.end(), mask.mutable_data());
        return py::make_tuple(mask, plane_array(fit.plane));
    });
    m.def("plan_path", [](double speed, double yaw_rate, const std::string& config_json) {
        const rp::Config cfg = config_from(config_json);
        return path_dict(rp::plan_paths(speed, yaw_rate, cfg.track_width, cfg.path));
    });
    m.def("wheel_profiles", [](py::handle ground_points, py::object plane, double speed, double yaw_rate,
                               const std::string& config_json) {
        py::object holder;
        const rp::Config cfg = config_from(config_json);
        const rp::PointsView view = points_from(ground_points, holder, "ground_points");
        std::optional<rp::Plane> pl;
        if (!plane.is_none()) pl = plane.cast<std::array<double, 4>>();
        const rp::Levelling L = rp::levelling_for(cfg.profile.level && pl ? &*pl : nullptr);
        const rp::WheelPaths paths = rp::plan_paths(speed, yaw_rate, cfg.track_width, cfg.path);
        const std::vector<std::uint8_t> all(static_cast<std::size_t>(view.rows()), 1);
        rp::WheelProfiles w = rp::build_profiles(view, all, L, paths, cfg.tire_width, cfg.profile);
        for (rp::Profile* p : {&w.left, &w.right}) {
            if (paths.status == rp::PathStatus::Stopped) {
                p->roughness.reason = p->roughness.iri.reason = "vehicle stopped";
                continue;
            }
            p->roughness = rp::analyze_roughness(*p, cfg.roughness);
            p->roughness.iri = rp::profile_iri(p->z, cfg.profile.ds_m, cfg.iri);
        }
        return py::make_tuple(std::move(w.left), std::move(w.right));
    }, "Profiles of both wheels, with their roughness and IRI, from ground points given in the base frame");
    m.def("level_points", [](py::handle points, std::array<double, 4> plane) {
        py::object holder;
        const rp::PointsView v = points_from(points, holder);
        const rp::Levelling L = rp::levelling_for(&plane);
        py::array_t<double> out({v.rows(), Eigen::Index(3)});
        auto o = out.mutable_unchecked<2>();
        for (Eigen::Index i = 0; i < v.rows(); ++i)
            for (int r = 0; r < 3; ++r) o(i, r) = L.R[r][0] * v(i, 0) + L.R[r][1] * v(i, 1) + L.R[r][2] * v(i, 2);
        return out;
    });
    m.def("fill_gaps", [](DoubleArray z, double ds, double max_gap_m,
                          std::optional<std::vector<bool>> blocked) {
        std::vector<double> v = as_vector(z);
        std::vector<std::uint8_t> flags;
        if (blocked) flags.assign(blocked->begin(), blocked->end());
        rp::fill_gaps(v, ds, max_gap_m, blocked ? &flags : nullptr);
        return py::array_t<double>(static_cast<py::ssize_t>(v.size()), v.data());
    }, py::arg("z"), py::arg("ds"), py::arg("max_gap_m"), py::arg("blocked") = py::none());
    m.def("longest_valid_stretch", [](DoubleArray z) {
        return rp::longest_valid_stretch(as_vector(z));
    });
    m.def("displacement_psd", [](DoubleArray x, double ds) {
        const std::vector<double> v = as_vector(x);
        if (v.size() < 2) throw py::value_error("displacement_psd needs at least 2 samples");
        rp::Spectrum sp = rp::displacement_psd(v.data(), v.size(), ds);
        return py::make_tuple(py::array_t<double>(static_cast<py::ssize_t>(sp.n.size()), sp.n.data()),
                              py::array_t<double>(static_cast<py::ssize_t>(sp.psd.size()), sp.psd.data()));
    });
    m.def("analyze_roughness", [](DoubleArray z, double ds,
                                  const std::string& config_json, py::object count, py::object spread) {
        const rp::RoughnessConfig cfg = config_from(config_json).roughness;
        if (count.is_none() != spread.is_none()) throw py::value_error("give both count and spread, or neither");
        if (count.is_none()) return rp::analyze_roughness(as_vector(z), ds, cfg);
        return rp::analyze_roughness(profile_of(z, ds, count, spread), cfg);
    }, py::arg("z"), py::arg("ds"), py::arg("config_json"), py::arg("count") = py::none(), py::arg("spread") = py::none());
    m.def("vehicle_roughness", [](DoubleArray zl,
                                  DoubleArray zr, double ds,
                                  const std::string& config_json, py::object count_left, py::object spread_left,
                                  py::object count_right, py::object spread_right) {
        const rp::RoughnessConfig cfg = config_from(config_json).roughness;
        const bool supported = !count_left.is_none() && !spread_left.is_none() && !count_right.is_none() && !spread_right.is_none();
        if (!supported) return rp::vehicle_roughness(as_vector(zl), as_vector(zr), ds, cfg);
        return rp::vehicle_roughness(profile_of(zl, ds, count_left, spread_left), profile_of(zr, ds, count_right, spread_right), cfg);
    }, py::arg("z_left"), py::arg("z_right"), py::arg("ds"), py::arg("config_json"), py::arg("count_left") = py::none(),
       py::arg("spread_left") = py::none(), py::arg("count_right") = py::none(), py::arg("spread_right") = py::none());
    m.def("noise_psd", [](py::array_t<std::int32_t, py::array::c_style | py::array::forcecast> count,
                          DoubleArray spread, double ds) -> py::object {
        if (count.size() != spread.size()) throw py::value_error("count and spread differ in length");
        const auto psd = rp::noise_psd(count.data(), spread.data(), static_cast<std::size_t>(count.size()), ds);
        if (!psd) return py::none();
        return py::array_t<double>(static_cast<py::ssize_t>(psd->size()), psd->data());
    });
    m.def("resolved_fraction", [](py::array_t<std::int32_t, py::array::c_style | py::array::forcecast> count, double ds,
                                  DoubleArray n) {
        const std::vector<double> phi = rp::resolved_fraction(count.data(), static_cast<std::size_t>(count.size()), ds, as_vector(n));
        return py::array_t<double>(static_cast<py::ssize_t>(phi.size()), phi.data());
    });
    m.def("iri_rectified_slope", [](DoubleArray z, double ds) {
        const std::vector<double> v = as_vector(z);
        const std::vector<double> rs = rp::iri_rectified_slope(v.data(), v.size(), ds);
        return py::array_t<double>(static_cast<py::ssize_t>(rs.size()), rs.data());
    });
    m.def("profile_iri", [](DoubleArray z, double ds,
                            const std::string& config_json) {
        return rp::profile_iri(as_vector(z), ds, config_from(config_json).iri);
    });
    m.def("iso_class", [](double gd) { return std::string(1, rp::iso_class(gd)); });
    m.def("estimate_mounting", [](py::handle points, const std::string& config_json) -> py::object {
        py::object holder;
        const rp::PointsView view = points_from(points, holder);
        const auto m = rp::estimate_mounting(view, config_from(config_json).ground);
        if (!m) return py::none();
        py::dict d;
        d["height_m"] = m->height_m, d["roll_rad"] = m->roll_rad, d["pitch_rad"] = m->pitch_rad;
        d["ground_points"] = m->ground_points;
        return d;
    }, "Sensor height, roll and pitch from the ground fitted to sensor-frame points, or None without ground");
    bind_obstacle_stages(m);
}

}  // namespace

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
