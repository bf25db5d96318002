// SPDX-License-Identifier: BSD-3-Clause
#include "common.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <string>
#include <type_traits>
#include <unordered_set>

namespace {
std::unordered_set<const void*>& objects_in_use() {
    static std::unordered_set<const void*> in_use;
    return in_use;
}
}  // namespace

InUse::InUse(const void* object, const char* what) : object_(object) {
    if (!objects_in_use().insert(object_).second)
        throw std::runtime_error(std::string("this ") + what + " is in use by another thread: it is not thread-safe, "
                                 "give each thread its own");
}

InUse::~InUse() { objects_in_use().erase(object_); }

py::array read_only(py::array a) {
    a.attr("setflags")(false);
    return a;
}

rp::PointsView points_from(const py::handle& obj, py::object& holder, const char* name) {
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

namespace {

// A 1-D array of one of the dtype `kinds` (an empty one of any dtype: an empty list reads as float64).
py::array one_dimensional(const py::handle& obj, const char* what, const char* kinds, const char* expected) {
    const py::array a = py::array::ensure(obj);
    if (!a) throw py::type_error(std::string(what) + " must be " + expected + ", got no array");
    if (a.size() > 0 && std::string(kinds).find(a.dtype().kind()) == std::string::npos)
        throw py::type_error(std::string(what) + " must be " + expected + ", got dtype " +
                             py::str(a.dtype()).cast<std::string>());
    if (a.ndim() != 1)
        throw py::value_error(std::string(what) + " must be 1-D, got shape " + py::str(a.attr("shape")).cast<std::string>());
    return a;
}

// `a`'s values as int32, read as the widest integer T of their kind; a value beyond int32 is an error.
template <typename T>
std::vector<std::int32_t> narrowed(const py::array& a, const char* what) {
    const auto values = py::array_t<T, py::array::forcecast>::ensure(a);
    std::vector<std::int32_t> out(static_cast<std::size_t>(values.size()));
    for (py::ssize_t i = 0; i < values.size(); ++i) {
        const T v = values.at(i);
        if ((std::is_signed_v<T> && v < static_cast<T>(INT32_MIN)) || v > static_cast<T>(INT32_MAX))
            throw py::value_error(std::string(what) + " must fit in int32, got " + std::to_string(v) + " at " +
                                  std::to_string(i));
        out[static_cast<std::size_t>(i)] = static_cast<std::int32_t>(v);
    }
    return out;
}

}  // namespace

std::vector<std::int32_t> int32_vector(const py::handle& obj, const char* what) {
    const py::array a = one_dimensional(obj, what, "iu", "an array of integers");
    return a.dtype().kind() == 'u' ? narrowed<std::uint64_t>(a, what) : narrowed<std::int64_t>(a, what);
}

std::vector<std::uint8_t> bool_vector(const py::handle& obj, const char* what) {
    const py::array a = one_dimensional(obj, what, "b", "a bool array");
    const auto b = py::array_t<bool, py::array::c_style | py::array::forcecast>::ensure(a);
    return std::vector<std::uint8_t>(b.data(), b.data() + b.size());
}

std::vector<double> double_vector(const py::handle& obj, const char* what) {
    const py::array a = one_dimensional(obj, what, "fiu", "an array of real numbers");
    const auto d = py::array_t<double, py::array::c_style | py::array::forcecast>::ensure(a);
    return std::vector<double>(d.data(), d.data() + d.size());
}

rp::Plane checked_plane(const std::array<double, 4>& plane, const char* what) {
    const double norm = std::sqrt(plane[0] * plane[0] + plane[1] * plane[1] + plane[2] * plane[2]);
    if (!(std::abs(norm - 1.0) <= 1e-6 && plane[2] > 0.0 && std::isfinite(plane[3])))
        throw py::value_error(std::string(what) + " must be (a, b, c, d) with a unit normal pointing up (c > 0), got (" +
                              std::to_string(plane[0]) + ", " + std::to_string(plane[1]) + ", " +
                              std::to_string(plane[2]) + ", " + std::to_string(plane[3]) + ")");
    return plane;
}

std::vector<double> as_vector(const DoubleArray& a) {
    if (a.ndim() != 1) throw py::value_error("expected a 1-D array, got " + std::to_string(a.ndim()) + "-D");
    return std::vector<double>(a.data(), a.data() + a.size());
}
