// SPDX-License-Identifier: BSD-3-Clause
// Bindings of the range sensor module (roadpreview.range_sensor wraps them): calibration, samples, windows.
#include <limits>

#include "common.hpp"

namespace {

std::vector<double> to_vector(const DoubleArray& a) { return {a.data(), a.data() + a.size()}; }

py::dict distance_dict(const rp::DistanceCalibration& d) {
    py::dict out;
    out["a1"] = d.a1;
    out["a2"] = d.a2;
    out["temperature_c"] = d.temperature_c;
    out["rms_m"] = d.rms_m;
    out["r_squared"] = d.r_squared;
    out["used"] = d.used;
    out["rejected"] = d.rejected;
    out["a1_sigma"] = d.a1_sigma;
    out["a2_sigma"] = d.a2_sigma;
    return out;
}

py::dict shift_dict(const rp::RunShift& r) {
    py::dict out;
    out["source"] = r.source;
    out["speed_mps"] = r.speed_mps;
    out["shift_m"] = r.shift_m;
    out["shift_sigma_m"] = r.shift_sigma_m;
    out["z_offset_m"] = r.z_offset_m;
    out["rms_m"] = r.rms_m;
    out["xcorr_shift_m"] = r.xcorr_shift_m;
    out["samples"] = r.samples;
    return out;
}

py::dict offset_dict(const rp::OffsetCalibration& o) {
    py::dict out;
    out["b1_s"] = o.b1_s;
    out["b2_m"] = o.b2_m;
    out["b1_sigma_s"] = o.b1_sigma_s;
    out["b2_sigma_m"] = o.b2_sigma_m;
    out["b1_xcorr_s"] = o.b1_xcorr_s;
    out["b2_xcorr_m"] = o.b2_xcorr_m;
    py::list runs;
    for (const rp::RunShift& r : o.runs) runs.append(shift_dict(r));
    out["runs"] = runs;
    return out;
}

rp::RangeCalibration calibration_from(const std::string& path) {
    return path.empty() ? rp::RangeCalibration{} : rp::read_range_calibration(path);
}

rp::RangeMotion motion_from(const std::string& motion_path, std::optional<double> speed, double yaw_rate) {
    if (!motion_path.empty()) return rp::RangeMotion(rp::MotionTable::read_csv(motion_path));
    if (!speed) throw std::invalid_argument("give a motion file or a speed");
    return rp::RangeMotion(*speed, yaw_rate);
}

using ReferenceArrays = std::vector<std::vector<std::pair<DoubleArray, DoubleArray>>>;  // [sensor][run]: (x, z)

std::vector<std::vector<rp::ReferenceProfile>> references_from(const ReferenceArrays& refs, bool leaning_datum) {
    std::vector<std::vector<rp::ReferenceProfile>> out;
    for (const auto& per_sensor : refs) {
        out.emplace_back();
        for (const auto& [x, z] : per_sensor) out.back().push_back({to_vector(x), to_vector(z), leaning_datum});
    }
    return out;
}

// Samples as a dict of equal-length arrays.
py::dict samples_dict(const std::vector<rp::RangeSample>& samples) {
    const auto n = static_cast<py::ssize_t>(samples.size());
    py::array_t<double> t(n), s(n), z(n), ahead(n), speed(n), ttw(n);
    py::array_t<std::int32_t> sensor(n);
    for (py::ssize_t i = 0; i < n; ++i) {
        const rp::RangeSample& x = samples[static_cast<std::size_t>(i)];
        t.mutable_at(i) = x.t_s;
        sensor.mutable_at(i) = x.sensor;
        s.mutable_at(i) = x.s_m;
        z.mutable_at(i) = x.z_m;
        ahead.mutable_at(i) = x.ahead_m;
        speed.mutable_at(i) = x.speed_mps;
        ttw.mutable_at(i) = x.time_to_wheel_s;
    }
    py::dict out;
    out["t"] = t;
    out["sensor"] = sensor;
    out["s"] = s;
    out["z"] = z;
    out["ahead"] = ahead;
    out["speed"] = speed;
    out["time_to_wheel"] = ttw;
    return out;
}

}  // namespace

void bind_range_sensor(py::module_& m) {
    m.def("range_layout", [](const std::string& path) {
        py::list out;
        for (const rp::RangeSensor& s : rp::read_range_layout(path)) {
            py::dict d;
            d["id"] = s.id;
            d["kind"] = s.kind == rp::RangeKind::Ultrasonic ? "ultrasonic" : "laser";
            d["wheel"] = s.wheel == rp::Wheel::Left ? "left" : "right";
            d["x_m"] = s.x_m;
            d["y_m"] = s.y_m;
            d["height_m"] = s.height_m;
            d["pitch_deg"] = s.pitch_deg;
            d["beam_half_angle_deg"] = s.beam_half_angle_deg;
            d["min_count"] = s.min_count;
            d["max_count"] = s.max_count;
            d["max_distance_m"] = s.max_distance_m;
            d["foot_m"] = rp::geometric_foot_m(s);
            out.append(d);
        }
        return out;
    }, py::arg("path"));
    m.def("range_calibrate_distance", [](DoubleArray counts, DoubleArray distances) {
        return distance_dict(rp::calibrate_distance(to_vector(counts), to_vector(distances)));
    }, py::arg("counts"), py::arg("distances"));
    m.def("range_calibration_yaml", [](const std::string& path) {
        return rp::range_calibration_to_yaml(rp::read_range_calibration(path));
    }, py::arg("path"));
    m.def("range_write_distance_calibration", [](DoubleArray counts, DoubleArray distances,
        const std::string& keep_path,
                                                 const std::string& out_path) {
        rp::RangeCalibration cal = calibration_from(keep_path);
        cal.distance = rp::calibrate_distance(to_vector(counts), to_vector(distances));
        rp::write_range_calibration(cal, out_path);
        return distance_dict(*cal.distance);
    });
    m.def("range_samples", [](const std::string& readings, const std::string& layout, const std::string& calibration,
                              const std::string& motion, std::optional<double> speed, double yaw_rate, bool raw) {
        const auto sensors = rp::read_range_layout(layout);
        rp::RangeCalibration cal = calibration_from(calibration);
        if (raw)
            for (const auto& s : sensors) cal.sensors[s.id].offset = rp::OffsetCalibration{};
        std::vector<rp::RangeSample> samples;
        {
            py::gil_scoped_release release;
            samples = rp::read_range_samples(readings, sensors, cal, motion_from(motion, speed, yaw_rate));
        }
        return samples_dict(samples);
    });
    m.def("range_register_run", [](DoubleArray x, DoubleArray z, DoubleArray ref_x, DoubleArray ref_z, double guess,
                                   double search, bool fit_tilt) {
        return shift_dict(rp::register_run(to_vector(x), to_vector(z), to_vector(ref_x), to_vector(ref_z), guess,
            search, fit_tilt));
    }, py::arg("x"), py::arg("z"), py::arg("ref_x"), py::arg("ref_z"), py::arg("guess"), py::arg("search"),
       py::arg("fit_tilt") = false);
    m.def("range_calibrate_offsets", [](const std::vector<std::string>& runs, const std::vector<std::string>& motions,
                                        const std::string& layout, const std::string& calibration,
                                        const ReferenceArrays& refs, bool leaning_datum, double search,
                                        const std::string& output) {
        const auto sensors = rp::read_range_layout(layout);
        std::vector<rp::RangeMotion> motion;
        for (const std::string& path : motions) motion.emplace_back(rp::MotionTable::read_csv(path));
        const auto references = references_from(refs, leaning_datum);
        rp::RangeCalibration cal;
        {
            py::gil_scoped_release release;
            cal = rp::calibrate_offsets(sensors, calibration_from(calibration), runs, motion, references, search);
        }
        if (!output.empty()) rp::write_range_calibration(cal, output);
        py::dict out;
        for (const auto& s : sensors) out[py::str(s.id)] = offset_dict(*cal.offset_for(s.id));
        return out;
    });
    m.def("range_process", [](const std::string& readings, const std::string& layout, const std::string& calibration,
                              const std::string& motion, std::optional<double> speed, double yaw_rate,
                              double frame_length_m) {
        rp::RangeProfilerConfig cfg;
        cfg.frame_length_m = frame_length_m;
        rp::RangeProfiler profiler(rp::read_range_layout(layout), calibration_from(calibration), cfg);
        std::vector<std::string> lines;
        {
            py::gil_scoped_release release;
            profiler.run(readings, motion_from(motion, speed, yaw_rate), [&](const rp::RangeWindow& w) {
                lines.push_back(rp::range_window_to_json(w, profiler.layout(), readings));
            });
        }
        return lines;
    });
    m.def("fusion_map_cells", [](const rp::Estimator& est, DoubleArray x, DoubleArray y) {
        const InUse in_use(&est, "Estimator");
        const rp::TemporalFusion* fusion = est.fusion();
        if (!fusion) throw std::invalid_argument("the estimator has no fusion map (fusion.method is \"none\")");
        if (x.size() != y.size()) throw std::invalid_argument("x and y must have the same length");
        py::array_t<double> out({x.size(), py::ssize_t{3}});
        auto o = out.mutable_unchecked<2>();
        const rp::ElevationMap& map = fusion->map();
        for (py::ssize_t i = 0; i < x.size(); ++i) {
            const std::int64_t k = map.slot(x.data()[i], y.data()[i]);
            const rp::MapCell* c = k < 0 ? nullptr : &map.cell(k);
            const bool seen = c && c->observations > 0;
            const auto centre = k < 0 ? std::array<double, 2>{0.0, 0.0} : map.centre(k);
            const double nan = std::numeric_limits<double>::quiet_NaN();
            o(i, 0) = seen ? centre[0] + c->dx : nan;
            o(i, 1) = seen ? centre[1] + c->dy : nan;
            o(i, 2) = seen ? c->height : nan;
        }
        return out;
    }, py::arg("estimator"), py::arg("x"), py::arg("y"),
       "The fused map's cells at odometry x, y: (N, 3) of where each cell's height lies (x, y: its centre plus the "
       "fused points' offset) and the height, m; NaN rows where empty");
    m.def("fuse_map_samples", [](rp::Estimator& est, DoubleArray x, DoubleArray y, DoubleArray z,
        DoubleArray variance) {
        const InUse in_use(&est, "Estimator");
        if (x.size() != y.size() || x.size() != z.size() || x.size() != variance.size())
            throw std::invalid_argument("x, y, z and variance must have the same length");
        std::vector<rp::MapSample> samples(static_cast<std::size_t>(x.size()));
        for (py::ssize_t i = 0; i < x.size(); ++i)
            samples[static_cast<std::size_t>(i)] = {x.data()[i], y.data()[i], z.data()[i], variance.data()[i]};
        return est.fuse_samples(samples);
    }, py::arg("estimator"), py::arg("x"), py::arg("y"), py::arg("z"), py::arg("variance"));
}
