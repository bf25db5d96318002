// SPDX-License-Identifier: BSD-3-Clause
#include "common.hpp"

#include <cmath>
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

py::array one_dimensional(const py::handle& obj, const char* what, const char* kinds, const char* expected) {
    const py::array a = py::array::ensure(obj);
    const std::string kind(1, a ? a.dtype().kind() : '?');
    if (!a || kind.find_first_of(kinds) == std::string::npos)
        throw py::type_error(std::string(what) + " must be " + expected + ", got " +
                             (a ? "dtype " + py::str(a.dtype()).cast<std::string>() : std::string("no array")));
    if (a.ndim() != 1)
        throw py::value_error(std::string(what) + " must be 1-D, got shape " + py::str(a.attr("shape")).cast<std::string>());
    return a;
}

}  // namespace

std::vector<std::int32_t> int32_vector(const py::handle& obj, const char* what) {
    const py::array a = one_dimensional(obj, what, "iu", "an array of integers");
    const auto wide = a.dtype().kind() == 'u' ? py::array_t<std::uint64_t, py::array::forcecast>::ensure(a).cast<py::array>()
                                              : py::array_t<std::int64_t, py::array::forcecast>::ensure(a).cast<py::array>();
    std::vector<std::int32_t> out(static_cast<std::size_t>(a.size()));
    for (py::ssize_t i = 0; i < a.size(); ++i) {
        const bool is_unsigned = a.dtype().kind() == 'u';
        const auto u = is_unsigned ? *static_cast<const std::uint64_t*>(wide.data(i)) : 0;
        const auto v = is_unsigned ? static_cast<std::int64_t>(std::min<std::uint64_t>(u, INT64_MAX))
                                   : *static_cast<const std::int64_t*>(wide.data(i));
        if (v < INT32_MIN || v > INT32_MAX)
            throw py::value_error(std::string(what) + " must fit in int32, got " + std::to_string(v) + " at " +
                                  std::to_string(i));
        out[static_cast<std::size_t>(i)] = static_cast<std::int32_t>(v);
    }
    return out;
}

std::vector<std::uint8_t> bool_vector(const py::handle& obj, const char* what) {
    const py::array a = one_dimensional(obj, what, "b", "a bool array");
    const auto b = py::array_t<bool, py::array::c_style | py::array::forcecast>::ensure(a);
    return std::vector<std::uint8_t>(b.data(), b.data() + b.size());
}

std::vector<double> as_vector(const DoubleArray& a) {
    if (a.ndim() != 1) throw py::value_error("expected a 1-D array, got " + std::to_string(a.ndim()) + "-D");
    return std::vector<double>(a.data(), a.data() + a.size());
}
