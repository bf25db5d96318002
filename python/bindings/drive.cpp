// SPDX-License-Identifier: BSD-3-Clause
// Drives from Python: rp.run(...) iterates a recording's results through the C++ DriveRunner, the policy the
// CLI follows (docs/method.md, "Drives").
#include <memory>
#include <string>
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

struct Note {
    bool warning;
    std::string text;
};

// The runner and the notes it made since Python last looked (the runner works without the GIL).
struct PyDriveRunner {
    std::shared_ptr<std::vector<Note>> notes = std::make_shared<std::vector<Note>>();
    std::unique_ptr<rp::DriveRunner> runner;
};

void emit_notes(std::vector<Note>& notes, py::list& kept) {
    const py::object warn = py::module_::import("warnings").attr("warn");
    for (const Note& n : notes) {
        kept.append(n.text);
        if (n.warning) warn(n.text, py::module_::import("builtins").attr("RuntimeWarning"), 2);
    }
    notes.clear();
}

}  // namespace

void bind_drive(py::module_& m) {
    py::class_<PyDriveRunner>(m, "DriveRunner", "Results of a recording's frames, one per next()")
        .def(py::init([](rp::FrameSource& source, const std::string& config_json, std::optional<double> speed_mps,
                         std::optional<double> yaw_rate_rps, const std::string& motion_file,
                         const std::string& poses_file, double frame_rate_hz, std::int64_t first_frame,
                         std::int64_t last_frame) {
                 PyDriveRunner r;
                 rp::DriveOptions o;
                 o.speed_mps = speed_mps;
                 o.yaw_rate_rps = yaw_rate_rps;
                 o.motion_file = motion_file;
                 o.poses_file = poses_file;
                 o.frame_rate_hz = frame_rate_hz;
                 o.first_frame = first_frame;
                 o.last_frame = last_frame;
                 o.on_note = [notes = r.notes](bool warning, const std::string& text) {
                     notes->push_back({warning, text});
                 };
                 r.runner = std::make_unique<rp::DriveRunner>(std::make_unique<LentSource>(source),
                                                              rp::config_from_json(config_json, "config"), o);
                 return r;
             }),
             py::keep_alive<1, 2>())
        .def("next", [](PyDriveRunner& r, py::list notes) -> py::object {
            std::optional<rp::DriveStep> step;
            {
                py::gil_scoped_release release;
                step = r.runner->next();
            }
            emit_notes(*r.notes, notes);
            if (!step) return py::none();
            return py::make_tuple(std::move(step->input.frame), std::move(step->result));
        }, "(frame, result) of the next frame, or None at the end; notes made meanwhile are appended to `notes`")
        .def_property_readonly("config_json", [](const PyDriveRunner& r) { return rp::config_to_json(r.runner->config()); },
                               "the config in force: the mounting the first frame gave, once it did")
        .def_property_readonly("mounting_disagreements",
                               [](const PyDriveRunner& r) { return r.runner->mounting_disagreements(); })
        .def_property_readonly("frames_read", [](const PyDriveRunner& r) { return r.runner->frames_read(); });
}
