// SPDX-License-Identifier: BSD-3-Clause
// What the binding files share: numpy views of C++ buffers kept alive by their owner, points read in place, the
// config from its JSON, and one bind_* function per module (module.cpp calls them all).
#pragma once

#include <memory>
#include <optional>
#include <string>
#include <type_traits>
#include <vector>

#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include "roadpreview/roadpreview.hpp"

namespace py = pybind11;
namespace rp = roadpreview;

void bind_obstacles(py::module_& m);  // results.cpp
void bind_results(py::module_& m);    // results.cpp
void bind_estimator(py::module_& m);  // estimator.cpp
void bind_stages(py::module_& m);     // stages.cpp
void bind_io(py::module_& m);         // io.cpp
void bind_calibration(py::module_& m);  // calibration.cpp
void bind_range_sensor(py::module_& m);  // range_sensor.cpp
void bind_drive(py::module_& m);      // drive.cpp
void bind_route(py::module_& m);      // route.cpp
void bind_roadside(py::module_& m);   // roadside.cpp
void bind_ouster_packets(py::module_& m);  // ouster_packets.cpp

// No bound object with state (Estimator, FrameSource, DriveRunner, roadside Processor) is thread-safe, and their
// long calls run without the GIL: another thread's call on the same object would corrupt it (a crash). While a call
// uses an object, another call's guard on it raises RuntimeError naming `what` instead. Made and destroyed with the
// GIL held, which keeps the set of objects in use consistent.
class InUse {
public:
    InUse(const void* object, const char* what);
    ~InUse();
    InUse(const InUse&) = delete;
    InUse& operator=(const InUse&) = delete;

private:
    const void* object_;
};

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

// A Python object that owns `value` (for C++ results handed out as views).
template <typename T>
py::object owner_of(std::unique_ptr<T> value) {
    return py::capsule(value.release(), [](void* p) { delete static_cast<T*>(p); });
}

/// The array, made read-only: writing would change a C++ buffer behind the user's back.
py::array read_only(py::array a);
/// Points as a view; `holder` keeps a converted copy alive when one is needed. TypeError / ValueError name `name`.
rp::PointsView points_from(const py::handle& obj, py::object& holder, const char* name = "points");
/// None where the JSON line has null: absent, or not finite (a flat stretch has no free-fit slope).
py::object optional_number(bool present, double v);
py::object plane_array(const std::optional<rp::Plane>& p);
py::dict path_dict(const rp::WheelPaths& p);
rp::Config config_from(const std::string& json);
std::vector<double> as_vector(const DoubleArray& a);
/// A 1-D array of integers (any integer dtype, each value within int32), named `what` in errors: floats and bools
/// are refused, not cast (−0.5 became label 0), and values beyond int32 are refused, not wrapped.
std::vector<std::int32_t> int32_vector(const py::handle& a, const char* what);
/// A 1-D bool array, named `what` in errors (0.5 is no mask value, and an (N, 1) array no mask of N).
std::vector<std::uint8_t> bool_vector(const py::handle& a, const char* what);
/// A 1-D array of real numbers as float64, named `what` in errors (a string or an object is no array of them).
std::vector<double> double_vector(const py::handle& a, const char* what);
/// A plane as the pipeline makes them — a unit normal pointing up (c > 0), finite d — else ValueError naming `what`:
/// the levelling divides by 1 + c, and a normal of another length scales the heights.
rp::Plane checked_plane(const std::array<double, 4>& plane, const char* what);
