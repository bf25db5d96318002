// SPDX-License-Identifier: BSD-3-Clause
// Drives from Python: rp.run(...) and rp.drive.run(...) iterate a recording's results through the C++
// DriveRunner, the policy the CLI follows (docs/method.md, "Drives"), whether the frames come from a C++ reader
// or from Python (ROS bags), and the motion and poses from files or from memory.
#include <pybind11/stl/filesystem.h>

#include <filesystem>
#include <memory>
#include <string>
#include <tuple>
#include <vector>

#include "common.hpp"

namespace {

// A FrameSource owned by Python (rp.io.open's), lent to the runner; the runner's Python object keeps it alive.
class LentSource : public rp::FrameSource {
public:
    explicit LentSource(rp::FrameSource& source) : source_(source) {}
    std::optional<rp::Frame> next() override { return source_.next(); }
    rp::SourceInfo info() const override { return source_.info(); }

private:
    rp::FrameSource& source_;
};

template <typename T>
T attribute_or(const py::handle& obj, const char* name, T fallback) {
    if (!py::hasattr(obj, name)) return fallback;
    const py::object v = obj.attr(name);
    return v.is_none() ? fallback : v.cast<T>();
}

// A frame from Python: an rp.io Frame as it is, or any object with .points ((N, ≥3) float; a fourth column is
// the intensity) and optionally .timestamp (s or None), .source, .frame_id and .sequence_break (bag frames).
rp::Frame frame_from(const py::handle& obj, std::int64_t index) {
    if (py::isinstance<rp::Frame>(obj)) return obj.cast<rp::Frame>();
    rp::Frame f;
    f.source = attribute_or<std::string>(obj, "source", "");
    f.frame_id = attribute_or<std::int64_t>(obj, "frame_id", index);
    f.sequence_break = attribute_or<std::string>(obj, "sequence_break", "");
    if (py::hasattr(obj, "timestamp") && !obj.attr("timestamp").is_none())
        f.timestamp = obj.attr("timestamp").cast<double>();
    if (!py::hasattr(obj, "points"))
        throw py::type_error("frame " + std::to_string(index) + " of " + f.source + " has no .points");
    const py::object points = obj.attr("points");
    py::object holder;
    const std::string name = "frame " + std::to_string(index) + " of " + f.source + ": points";
    points_from(points, holder, name.c_str());  // the shape and dtype checks, with their messages
    const auto a = py::array_t<float, py::array::c_style | py::array::forcecast>::ensure(points);
    const auto rows = static_cast<Eigen::Index>(a.shape(0)), columns = static_cast<Eigen::Index>(a.shape(1));
    const auto in = a.unchecked<2>();
    f.points.setZero(rows, 4);
    for (Eigen::Index i = 0; i < rows; ++i)
        for (Eigen::Index c = 0; c < std::min<Eigen::Index>(columns, 4); ++c) f.points(i, c) = in(i, c);
    return f;
}

// Frames from a Python iterable (rosbags' BagSource): each next() takes the GIL, which the runner releases.
class PythonSource : public rp::FrameSource {
public:
    explicit PythonSource(const py::handle& iterable) : iterator_(py::iter(iterable)) {
        if (!py::hasattr(iterable, "info")) return;
        const py::object i = iterable.attr("info");
        if (!py::isinstance<py::dict>(i)) return;
        const py::dict d = i.cast<py::dict>();
        info_.format = d.contains("format") ? py::str(d["format"]).cast<std::string>() : "";
        info_.sensor_model = d.contains("sensor_model") ? py::str(d["sensor_model"]).cast<std::string>() : "";
        info_.beams = d.contains("beams") ? d["beams"].cast<int>() : 0;
    }
    ~PythonSource() override {
        py::gil_scoped_acquire gil;
        iterator_ = py::object();
    }
    std::optional<rp::Frame> next() override {
        py::gil_scoped_acquire gil;
        const py::object item = py::reinterpret_steal<py::object>(PyIter_Next(iterator_.ptr()));
        if (!item) {
            if (PyErr_Occurred()) throw py::error_already_set();
            return std::nullopt;
        }
        return frame_from(item, read_++);
    }
    rp::SourceInfo info() const override { return info_; }

private:
    py::object iterator_;
    rp::SourceInfo info_;
    std::int64_t read_ = 0;
};

std::unique_ptr<rp::FrameSource> source_from(const py::handle& source) {
    if (py::isinstance<rp::FrameSource>(source)) return std::make_unique<LentSource>(source.cast<rp::FrameSource&>());
    return std::make_unique<PythonSource>(source);
}

struct Note {
    bool warning;
    std::string text;
};

// The runner and the notes it made since Python last looked (the runner works without the GIL), and the rp.io
// source it reads, if it was given one (a call on that source from another thread meanwhile is refused).
struct PyDriveRunner {
    std::shared_ptr<std::vector<Note>> notes = std::make_shared<std::vector<Note>>();
    std::unique_ptr<rp::DriveRunner> runner;
    const rp::FrameSource* lent = nullptr;
};

void emit_notes(std::vector<Note>& notes, py::list& kept) {
    const py::object warn = py::module_::import("warnings").attr("warn");
    for (const Note& n : notes) {
        kept.append(n.text);
        if (n.warning) warn(n.text, py::module_::import("builtins").attr("RuntimeWarning"), 2);
    }
    notes.clear();
}

std::vector<rp::Pose2> poses_from(const std::vector<std::array<double, 3>>& rows) {
    std::vector<rp::Pose2> out;
    for (std::size_t k = 0; k < rows.size(); ++k) {
        const auto& p = rows[k];
        if (!std::isfinite(p[0]) || !std::isfinite(p[1]) || !std::isfinite(p[2]))
            throw std::invalid_argument("poses: pose " + std::to_string(k) + " is not finite (x, y, yaw)");
        out.push_back({p[0], p[1], p[2]});
    }
    return out;
}

py::array_t<double> copy_of(const std::vector<double>& v) {
    return py::array_t<double>(static_cast<py::ssize_t>(v.size()), v.data());
}

void bind_motion_table(py::module_& m) {
    py::class_<rp::MotionTable>(m, "MotionTable",
                                "Speed (m/s) and yaw rate (rad/s) against time (s), linearly interpolated")
        .def_static("read_csv",
                    [](const std::filesystem::path& path) { return rp::MotionTable::read_csv(path.string()); },
                    py::arg("path"), "A CSV with the header t,speed,yaw_rate (any order, other columns ignored)")
        .def_static("from_samples", [](const DoubleArray& t, const DoubleArray& speed, const DoubleArray& yaw_rate,
                                       const std::string& source) {
            return rp::MotionTable::from_samples(as_vector(t), as_vector(speed), as_vector(yaw_rate), source);
        }, py::arg("t"), py::arg("speed"), py::arg("yaw_rate"), py::arg("source") = "motion",
           "From arrays (s, m/s, rad/s): at least two rows, finite, t increasing; errors name `source`")
        .def("at", [](const rp::MotionTable& table, double t) {
            const rp::Motion motion = table.at(t);
            return py::make_tuple(motion.speed_mps, motion.yaw_rate_rps);
        }, py::arg("t"), "(speed, yaw_rate) at time t; RuntimeError outside the table's span")
        .def_property_readonly("source", &rp::MotionTable::source)
        .def_property_readonly("t", [](const rp::MotionTable& table) { return copy_of(table.times()); }, "s")
        .def_property_readonly("speed", [](const rp::MotionTable& table) { return copy_of(table.speeds()); }, "m/s")
        .def_property_readonly("yaw_rate", [](const rp::MotionTable& table) { return copy_of(table.yaw_rates()); },
                               "rad/s")
        .def("__len__", [](const rp::MotionTable& table) { return table.times().size(); })
        .def("__repr__", [](const rp::MotionTable& table) {
            return "<roadpreview.MotionTable " + table.source() + ": " + std::to_string(table.times().size()) +
                   " rows>";
        });
}

}  // namespace

void bind_drive(py::module_& m) {
    bind_motion_table(m);
    m.def("read_kitti_poses", [](const std::filesystem::path& path) {
        std::vector<std::tuple<double, double, double>> out;
        for (const rp::Pose2& p : rp::read_kitti_poses(path.string())) out.emplace_back(p.x_m, p.y_m, p.yaw_rad);
        return out;
    }, py::arg("path"), "(x, y, yaw) per pose of a KITTI poses file, as the DriveRunner reads them");
    py::class_<PyDriveRunner>(m, "DriveRunner", "Results of a recording's frames, one per next()")
        .def(py::init([](const py::object& source, const std::string& config_json, std::optional<double> speed_mps,
                         std::optional<double> yaw_rate_rps, const std::string& motion_file,
                         std::optional<rp::MotionTable> motion, const std::string& poses_file,
                         std::optional<std::vector<std::array<double, 3>>> poses, double frame_rate_hz,
                         std::int64_t first_frame, std::int64_t last_frame) {
                 PyDriveRunner r;
                 rp::DriveOptions o;
                 o.speed_mps = speed_mps;
                 o.yaw_rate_rps = yaw_rate_rps;
                 o.motion_file = motion_file;
                 o.motion = std::move(motion);
                 o.poses_file = poses_file;
                 if (poses) o.poses = poses_from(*poses);
                 o.frame_rate_hz = frame_rate_hz;
                 o.first_frame = first_frame;
                 o.last_frame = last_frame;
                 o.on_note = [notes = r.notes](bool warning, const std::string& text) {
                     notes->push_back({warning, text});
                 };
                 if (py::isinstance<rp::FrameSource>(source)) r.lent = &source.cast<const rp::FrameSource&>();
                 r.runner = std::make_unique<rp::DriveRunner>(source_from(source),
                                                              rp::config_from_json(config_json, "config"), o);
                 return r;
             }),
             py::arg("source"), py::arg("config_json"), py::kw_only(), py::arg("speed_mps") = py::none(),
             py::arg("yaw_rate_rps") = py::none(), py::arg("motion_file") = "", py::arg("motion") = py::none(),
             py::arg("poses_file") = "", py::arg("poses") = py::none(), py::arg("frame_rate_hz") = 0.0,
             py::arg("first_frame") = 0, py::arg("last_frame") = std::numeric_limits<std::int64_t>::max(),
             py::keep_alive<1, 2>(),
             "source: an rp.io FrameSource, or any iterable of frames with .points (bags); poses: (x, y, yaw) each")
        .def("next", [](PyDriveRunner& r, py::list notes) -> py::object {
            std::optional<rp::DriveStep> step;
            {
                const InUse in_use(&r, "DriveRunner");
                const std::optional<InUse> source_in_use =
                    r.lent ? std::optional<InUse>(std::in_place, r.lent, "FrameSource") : std::nullopt;
                py::gil_scoped_release release;
                step = r.runner->next();
            }
            emit_notes(*r.notes, notes);
            if (!step) return py::none();
            return py::make_tuple(std::move(step->input.frame), std::move(step->result));
        }, "(frame, result) of the next frame, or None at the end; notes made meanwhile are appended to `notes`")
        .def_property_readonly("config_json", [](const PyDriveRunner& r) {
            const InUse in_use(&r, "DriveRunner");
            return rp::config_to_json(r.runner->config());
        }, "the config in force: the mounting the first frame gave, once it did")
        .def_property_readonly("mounting_disagreements", [](const PyDriveRunner& r) {
            const InUse in_use(&r, "DriveRunner");
            return r.runner->mounting_disagreements();
        })
        .def_property_readonly("frames_read", [](const PyDriveRunner& r) {
            const InUse in_use(&r, "DriveRunner");
            return r.runner->frames_read();
        });
}
