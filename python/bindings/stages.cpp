// SPDX-License-Identifier: BSD-3-Clause
// The stages one by one (rp.native): ground, paths, profiles, roughness, IRI, obstacles, for the cross-checks
// against the numpy reference. No pipeline logic here: each call is one library function.
#include <cmath>

#include "common.hpp"

namespace {

// A profile of heights z with the count and spread of the points behind each bin (for the stage functions).
rp::Profile profile_of(const DoubleArray& z, double ds,
                       const py::object& count, const py::object& spread) {
    rp::Profile p;
    p.ds = ds;
    p.z = as_vector(z);
    p.count = int32_vector(count, "count");
    p.spread = double_vector(spread, "spread");
    if (p.count.size() != p.z.size() || p.spread.size() != p.z.size())
        throw py::value_error("z, count and spread must have one entry per bin");
    return p;
}

void bind_obstacle_stages(py::module_& m) {
    m.def("cluster_labels", [](py::handle points, const std::string& config_json) {
        py::object holder;
        const rp::PointsView view = points_from(points, holder);
        const rp::ObstaclesConfig cfg = config_from(config_json).obstacles;
        std::vector<std::int32_t> labels;
        {
            py::gil_scoped_release release;
            labels = rp::cluster_labels(view, cfg);
        }
        return py::array_t<std::int32_t>(static_cast<py::ssize_t>(labels.size()), labels.data());
    }, "Euclidean cluster id of every point (-1: none)");
    m.def("find_obstacles", [](py::handle base_points, py::handle ground_mask, std::array<double, 4> given_plane,
                               const std::string& config_json) {
        const rp::Plane plane = checked_plane(given_plane, "plane");
        py::object holder;
        const rp::Config cfg = config_from(config_json);
        const rp::PointsView view = points_from(base_points, holder, "base_points");
        const std::vector<std::uint8_t> mask = bool_vector(ground_mask, "ground_mask");
        std::unique_ptr<rp::Clustering> clustering;
        {
            py::gil_scoped_release release;
            clustering = std::make_unique<rp::Clustering>(rp::find_obstacles(view, mask, plane, cfg.ground, cfg.obstacles));
        }
        const rp::Clustering& c = *clustering;
        py::object owner = owner_of(std::move(clustering));
        return py::make_tuple(ClustersRef{&c.clusters, owner}, view_of(c.label, owner));
    }, "(Obstacles, cluster id per point) of the non-ground ROI points among base-frame points");
    m.def("wheel_obstacles", [](py::handle base_points, py::handle label_array,
                                const ClustersRef& obstacles,
                                std::array<double, 4> given_plane, double speed, double yaw_rate,
                                const std::string& wheel, const std::string& config_json) {
        const rp::Plane plane = checked_plane(given_plane, "plane");
        if (wheel != "left" && wheel != "right") throw py::value_error("wheel must be 'left' or 'right', got '" + wheel + "'");
        py::object holder;
        const rp::Config cfg = config_from(config_json);
        const rp::PointsView view = points_from(base_points, holder, "base_points");
        const std::vector<std::int32_t> labels = int32_vector(label_array, "labels");
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

}  // namespace

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
        if (!plane.is_none()) pl = checked_plane(plane.cast<std::array<double, 4>>(), "plane");
        const rp::Levelling L = rp::levelling_for(cfg.profile.level && pl ? &*pl : nullptr);
        const rp::WheelPaths paths = rp::plan_paths(speed, yaw_rate, cfg.track_width, cfg.path);
        rp::WheelProfiles w;
        {
            py::gil_scoped_release release;
            const std::vector<std::uint8_t> all(static_cast<std::size_t>(view.rows()), 1);
            const std::vector<double> local_z =
                cfg.profile.level && cfg.profile.level_local && pl
                    ? rp::local_ground_heights(view, all, *pl, cfg.profile.level_band_m, paths)
                    : std::vector<double>{};
            w = rp::build_profiles(view, all, L, paths, cfg.tire_width, cfg.profile, nullptr,
                                   local_z.empty() ? nullptr : &local_z);
            for (rp::Profile* p : {&w.left, &w.right}) {
                if (paths.status == rp::PathStatus::Stopped) {
                    p->roughness.reason = rp::RoughnessReason::VehicleStopped;
                    p->roughness.iri.reason = rp::IriReason::VehicleStopped;
                } else {
                    rp::rate_profile(*p, cfg);
                }
            }
        }
        return py::make_tuple(std::move(w.left), std::move(w.right));
    }, "Profiles of both wheels, with their roughness and IRI, from ground points given in the base frame");
    m.def("level_points", [](py::handle points, std::array<double, 4> given_plane) {
        const rp::Plane plane = checked_plane(given_plane, "plane");
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
        const int given = !count_left.is_none() + !spread_left.is_none() + !count_right.is_none() + !spread_right.is_none();
        if (given != 0 && given != 4)  // a count without its spread was ignored, silently
            throw py::value_error("count_left and spread_left and count_right and spread_right: give all four or none");
        const bool supported = given == 4;
        if (!supported) return rp::vehicle_roughness(as_vector(zl), as_vector(zr), ds, cfg);
        return rp::vehicle_roughness(profile_of(zl, ds, count_left, spread_left), profile_of(zr, ds, count_right, spread_right), cfg);
    }, py::arg("z_left"), py::arg("z_right"), py::arg("ds"), py::arg("config_json"), py::arg("count_left") = py::none(),
       py::arg("spread_left") = py::none(), py::arg("count_right") = py::none(), py::arg("spread_right") = py::none());
    m.def("noise_psd", [](py::handle count_array, py::handle spread_array, double ds) -> py::object {
        const std::vector<std::int32_t> count = int32_vector(count_array, "count");
        const std::vector<double> spread = double_vector(spread_array, "spread");
        if (count.size() != spread.size()) throw py::value_error("count and spread differ in length");
        const auto psd = rp::noise_psd(count.data(), spread.data(), count.size(), ds);
        if (!psd) return py::none();
        return py::array_t<double>(static_cast<py::ssize_t>(psd->size()), psd->data());
    });
    m.def("iri_noise", [](py::handle count_array, py::handle spread_array, double ds) -> std::optional<double> {
        const std::vector<std::int32_t> count = int32_vector(count_array, "count");
        const std::vector<double> spread = double_vector(spread_array, "spread");
        if (count.size() != spread.size()) throw py::value_error("count and spread differ in length");
        return rp::iri_noise(count.data(), spread.data(), count.size(), ds);
    });
    m.def("resolved_fraction", [](py::handle count_array, double ds, DoubleArray n) {
        const std::vector<std::int32_t> count = int32_vector(count_array, "count");
        const std::vector<double> phi = rp::resolved_fraction(count.data(), count.size(), ds, as_vector(n));
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
    // What the Estimator would refuse of a config, said naming `source` (a config file).
    m.def("check_config", [](const std::string& config_json, const std::string& source) {
        rp::validate(rp::config_from_json(config_json, source));
    }, py::arg("config_json"), py::arg("source"));
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

