// SPDX-License-Identifier: BSD-3-Clause
// Recordings from Python: rp.io.open(...) iterates frames decoded in C++; a frame's arrays are read-only
// numpy views of its buffers, kept alive by the frame.
#include <atomic>
#include <mutex>

#include "common.hpp"

namespace {

// SourceOptions::roi_columns: the region `config_json` crops to, facing each direction (+1 ahead, -1 behind).
std::vector<rp::SensorRoi> roi_regions(const std::string& config_json, const std::vector<double>& directions) {
    if (config_json.empty()) return {};
    const rp::Config cfg = rp::config_from_json(config_json, "roi_columns");
    std::vector<rp::SensorRoi> regions;
    for (const double d : directions) regions.push_back(rp::sensor_roi(cfg, d));
    return regions;
}

py::dict info_dict(const rp::SourceInfo& s) {
    py::dict d;
    d["format"] = s.format;
    d["sensor_model"] = s.sensor_model;
    d["profile"] = s.profile;
    d["metadata"] = s.metadata;
    d["lidar_port"] = s.lidar_port;
    d["lidar_port_origin"] = s.lidar_port_origin;
    d["frame_rate_hz"] = s.frame_rate_hz;
    d["notes"] = s.notes;
    d["beams"] = s.beams;
    d["serial"] = s.serial;
    d["datagrams_received"] = s.datagrams_received;
    d["datagrams_dropped"] = s.datagrams_dropped;
    return d;
}

// A live source the caller can close from any thread (rp.io.open_live): close() ends the stream — a next() waiting
// on another thread returns within the input's 20 ms poll (the frame being assembled, or the end) — and frees the
// sockets once no next() is running. The stop flag is the one the CLI's Ctrl-C sets (LiveOptions::stop).
class ClosableLive final : public rp::FrameSource {
public:
    ClosableLive(const std::string& url, rp::LiveOptions options) {
        options.stop = &closed_;
        source_ = rp::open_live(url, options);
    }

    std::optional<rp::Frame> next() override {
        std::lock_guard<std::mutex> lock(mutex_);
        if (!source_) return std::nullopt;
        std::optional<rp::Frame> frame;
        try {
            frame = source_->next();
        } catch (const std::runtime_error&) {
            // Closed before any datagram came: the end the caller asked for, not a silent sensor's error.
            if (!closed_ || source_->info().datagrams_received != 0) throw;
        }
        if (closed_) release();
        return frame;
    }

    rp::SourceInfo info() const override {
        std::lock_guard<std::mutex> lock(mutex_);
        return source_ ? source_->info() : info_at_close_;
    }

    void close() {
        closed_ = true;
        std::lock_guard<std::mutex> lock(mutex_);  // a next() running returns within the poll once closed_ is set
        if (source_) release();
    }

private:
    void release() {
        info_at_close_ = source_->info();
        source_.reset();
    }

    std::atomic<bool> closed_{false};
    mutable std::mutex mutex_;
    std::unique_ptr<rp::FrameSource> source_;
    rp::SourceInfo info_at_close_;
};

// Three doubles per IMU sample, from `member`.
py::array imu_vectors(const rp::Frame& f, std::array<double, 3> rp::ImuSample::*member) {
    py::array_t<double> out({static_cast<py::ssize_t>(f.imu.size()), py::ssize_t(3)});
    auto o = out.mutable_unchecked<2>();
    for (std::size_t i = 0; i < f.imu.size(); ++i)
        for (int k = 0; k < 3; ++k) o(static_cast<py::ssize_t>(i), k) = (f.imu[i].*member)[static_cast<std::size_t>(k)];
    return out;
}

rp::DisparityImage disparity_from(const py::array_t<float, py::array::c_style | py::array::forcecast>& a) {
    if (a.ndim() != 2) throw py::value_error("a disparity image must be 2-D (rows, columns), got " + std::to_string(a.ndim()) + "-D");
    return Eigen::Map<const rp::DisparityImage>(a.data(), a.shape(0), a.shape(1));
}

using Grey8 = Eigen::Matrix<std::uint8_t, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;

Grey8 grey8_from(const py::array& a, const char* name) {
    if (a.ndim() != 2 || !py::isinstance<py::array_t<std::uint8_t>>(a))
        throw py::type_error(std::string(name) + " must be a 2-D uint8 grey image");
    const auto g = a.cast<py::array_t<std::uint8_t, py::array::c_style | py::array::forcecast>>();
    return Eigen::Map<const Grey8>(g.data(), g.shape(0), g.shape(1));
}

py::dict points_dict(rp::StereoPoints&& p, int first_row) {
    py::dict d;
    auto owned = std::make_unique<rp::StereoPoints>(std::move(p));
    const rp::StereoPoints& s = *owned;
    py::capsule owner(owned.release(), [](void* q) { delete static_cast<rp::StereoPoints*>(q); });
    d["points"] = py::array(py::dtype::of<float>(), {s.points.rows(), Eigen::Index(4)},
                            {Eigen::Index(4 * sizeof(float)), Eigen::Index(sizeof(float))}, s.points.data(), owner);
    d["range_variances"] = py::array(py::dtype::of<float>(), {static_cast<py::ssize_t>(s.range_variances.size())},
                                     {py::ssize_t(sizeof(float))}, s.range_variances.data(), owner);
    d["pixels"] = py::array(py::dtype::of<std::int32_t>(), {static_cast<py::ssize_t>(s.pixels.size())},
                            {py::ssize_t(sizeof(std::int32_t))}, s.pixels.data(), owner);
    d["error_groups"] = py::array(py::dtype::of<std::int32_t>(), {static_cast<py::ssize_t>(s.error_groups.size())},
                                  {py::ssize_t(sizeof(std::int32_t))}, s.error_groups.data(), owner);
    d["first_row"] = first_row;
    return d;
}

py::array disparity_array(const rp::DisparityImage& d) {
    py::array_t<float> out({static_cast<py::ssize_t>(d.rows()), static_cast<py::ssize_t>(d.cols())});
    std::copy(d.data(), d.data() + d.size(), out.mutable_data());
    return out;
}

void bind_stereo(py::module_& m) {
    m.def("read_stereo_calibration", [](const std::string& path) {
        const rp::StereoCalibration c = rp::read_stereo_calibration(path);
        py::dict d;
        d["fx"] = c.fx_px, d["fy"] = c.fy_px, d["cx"] = c.cx_px, d["cy"] = c.cy_px, d["baseline"] = c.baseline_m;
        d["source"] = c.source;
        if (c.extrinsics) {
            const rp::Extrinsics& e = *c.extrinsics;
            py::dict x;
            x["x_m"] = e.x_m, x["y_m"] = e.y_m, x["z_m"] = e.z_m, x["roll_rad"] = e.roll_rad, x["pitch_rad"] = e.pitch_rad;
            x["yaw_rad"] = e.yaw_rad;
            d["extrinsics"] = x;
        } else {
            d["extrinsics"] = py::none();
        }
        return d;
    });
    // (points dict, disparity) of one pair: files or arrays; a precomputed disparity (file or array) skips matching.
    m.def("stereo_points", [](py::object left, py::object right, const std::string& calib_path, py::object disparity,
                              const std::string& config_json) {
        if (left.is_none() != right.is_none())
            throw py::value_error("stereo_points: give both the left and the right image, or neither (with a disparity)");
        if (left.is_none() && disparity.is_none())
            throw py::value_error("stereo_points: give the left and right images, or a disparity");
        if (py::isinstance<py::str>(left) != py::isinstance<py::str>(right))
            throw py::type_error("stereo_points: left and right must both be file names or both be arrays");
        const rp::Config cfg = rp::config_from_json(config_json, "config");
        const rp::StereoCalibration calib = rp::read_stereo_calibration(calib_path);
        const rp::Extrinsics camera = rp::stereo_camera_pose(cfg, calib);
        std::optional<rp::StereoImages> pair;
        if (py::isinstance<py::str>(left)) {
            pair = rp::read_stereo_pair(left.cast<std::string>(), right.cast<std::string>());
        } else if (!left.is_none()) {
            pair = rp::StereoImages{grey8_from(left, "left"), grey8_from(right, "right")};
            if (pair->left.rows() != pair->right.rows() || pair->left.cols() != pair->right.cols())
                throw py::value_error("left and right images differ in size");
        }
        rp::DisparityImage d;
        if (py::isinstance<py::str>(disparity)) d = rp::read_disparity_png(disparity.cast<std::string>());
        else if (!disparity.is_none()) d = disparity_from(disparity);
        if (pair && !disparity.is_none() && (d.rows() != pair->left.rows() || d.cols() != pair->left.cols()))
            throw py::value_error("the disparity image and the images differ in size");
        const auto rows = static_cast<int>(pair ? pair->left.rows() : d.rows());
        const int first_row = rp::first_road_row(calib, camera, rows, cfg.stereo);
        std::optional<rp::GreyImage> grey;
        rp::StereoPoints p;
        const bool match = disparity.is_none();  // asked with the GIL held
        {
            py::gil_scoped_release release;
            if (match) d = rp::match_stereo(*pair, first_row, cfg.stereo);
            if (pair) grey = rp::GreyImage(pair->left.cast<float>() / 255.0f);
            p = rp::disparity_to_points(d, first_row, calib, cfg.stereo, grey ? &*grey : nullptr);
        }
        return py::make_tuple(points_dict(std::move(p), first_row), disparity_array(d));
    });
    m.def("open_stereo", [](const std::vector<std::string>& left, const std::vector<std::string>& right,
                            const std::vector<std::string>& disparity, const std::string& calib, const std::string& config_json) {
        rp::StereoInputs in{left, right, disparity, calib};
        return std::unique_ptr<rp::FrameSource>(new rp::StereoSource(in, rp::config_from_json(config_json, "config")));
    });
}

}  // namespace

void bind_io(py::module_& m) {
    py::class_<rp::Frame>(m, "Frame", "One frame of a recording, decoded in C++")
        .def_property_readonly("points", [](py::object self) {
            const auto& f = self.cast<const rp::Frame&>();
            return read_only(py::array(py::dtype::of<float>(), {f.points.rows(), Eigen::Index(4)},
                                       {Eigen::Index(4 * sizeof(float)), Eigen::Index(sizeof(float))}, f.points.data(), self));
        }, "(N, 4) float32: x, y, z (m, sensor frame) and intensity (reflectivity; 0 when none)")
        .def_readonly("source", &rp::Frame::source)
        .def_readonly("sequence_break", &rp::Frame::sequence_break,
                      "files: why this frame does not continue the previous file's sequence; empty when it does")
        .def_readonly("timestamp", &rp::Frame::timestamp, "s (pcaps: capture time of the first packet, UNIX epoch), or None")
        .def_readonly("frame_id", &rp::Frame::frame_id, "Ouster frame id, Velodyne sweep count, or index of the file")
        .def_property_readonly("point_times", [](py::object self) {
            const auto& t = self.cast<const rp::Frame&>().point_times;
            return read_only(py::array(py::dtype::of<float>(), {static_cast<py::ssize_t>(t.size())},
                                       {py::ssize_t(sizeof(float))}, t.data(), self));
        }, "float32 s after .timestamp per point; empty when unknown")
        .def_property_readonly("beams", [](py::object self) {
            const auto& b = self.cast<const rp::Frame&>().beams;
            return read_only(py::array(py::dtype::of<std::int32_t>(), {static_cast<py::ssize_t>(b.size())},
                                       {py::ssize_t(sizeof(std::int32_t))}, b.data(), self));
        }, "int32 beam of each point (Ouster row from the top, Velodyne laser id, -1: none); empty when unknown")
        .def_property_readonly("range_variances", [](py::object self) {
            const auto& v = self.cast<const rp::Frame&>().range_variances;
            return read_only(py::array(py::dtype::of<float>(), {static_cast<py::ssize_t>(v.size())},
                                       {py::ssize_t(sizeof(float))}, v.data(), self));
        }, "float32 m² per point: variance along its line of sight (stereo); empty when unknown")
        .def_property_readonly("error_groups", [](py::object self) {
            const auto& g = self.cast<const rp::Frame&>().error_groups;
            return read_only(py::array(py::dtype::of<std::int32_t>(), {static_cast<py::ssize_t>(g.size())},
                                       {py::ssize_t(sizeof(std::int32_t))}, g.data(), self));
        }, "int32 per point: points with one id share their range error (stereo); empty when unknown")
        .def_property_readonly("imu_timestamps", [](const rp::Frame& f) {
            std::vector<double> t;
            for (const auto& s : f.imu) t.push_back(s.timestamp);
            return py::array_t<double>(static_cast<py::ssize_t>(t.size()), t.data());
        })
        .def_property_readonly("imu_angular_velocity", [](const rp::Frame& f) {
            return imu_vectors(f, &rp::ImuSample::angular_velocity);
        }, "(K, 3) rad/s in the sensor frame")
        .def_property_readonly("imu_linear_acceleration", [](const rp::Frame& f) {
            return imu_vectors(f, &rp::ImuSample::linear_acceleration);
        }, "(K, 3) m/s² in the sensor frame")
        .def_property_readonly("diagnostics", [](const rp::Frame& f) {
            py::dict d;
            d["missing_columns"] = f.diagnostics.missing_columns;
            d["cut_columns"] = f.diagnostics.cut_columns;
            d["invalid_columns"] = f.diagnostics.invalid_columns;
            d["skipped_packets"] = f.diagnostics.skipped_packets;
            d["lost_packets"] = f.diagnostics.lost_packets;
            d["late_packets"] = f.diagnostics.late_packets;
            d["duplicate_packets"] = f.diagnostics.duplicate_packets;
            d["complete"] = f.diagnostics.complete;
            return d;
        })
        .def_readonly("arrival_s", &rp::Frame::arrival_s,
                      "live: steady-clock time (s, rp.io.steady_now_s) its last datagram arrived; 0 otherwise")
        .def_readonly("completed_s", &rp::Frame::completed_s,
                      "live: steady-clock time (s) the decoder had completed it (its last datagram decoded, the "
                      "frame built); 0 otherwise")
        .def("__repr__", [](const rp::Frame& f) {
            return "<roadpreview.Frame " + std::to_string(f.frame_id) + " of " + f.source + ": " +
                   std::to_string(f.points.rows()) + " points>";
        });

    py::class_<rp::FrameSource>(m, "FrameSource", "Iterates the frames of a recording, one at a time")
        .def("__iter__", [](py::object self) { return self; })
        .def("__next__", [](rp::FrameSource& s) {
            std::optional<rp::Frame> f;
            {
                const InUse in_use(&s, "FrameSource");
                py::gil_scoped_release release;
                f = s.next();
            }
            if (!f) throw py::stop_iteration();
            return std::move(*f);
        })
        .def_property_readonly("info", [](const rp::FrameSource& s) {
            const InUse in_use(&s, "FrameSource");
            return info_dict(s.info());
        })
        .def("__repr__", [](const rp::FrameSource& s) {
            const rp::SourceInfo i = [&] {
                const InUse in_use(&s, "FrameSource");
                return s.info();
            }();
            std::string out = "<roadpreview.FrameSource " + i.format;
            for (const std::string* part : {&i.sensor_model, &i.profile, &i.metadata})
                if (!part->empty()) out += ", " + *part;
            return out + ">";
        });

    py::class_<ClosableLive, rp::FrameSource>(m, "LiveSource", "A live sensor's frames; close() ends the stream")
        .def("close", &ClosableLive::close, py::call_guard<py::gil_scoped_release>(),
             "ends the stream (a next() waiting on another thread returns within 20 ms) and frees the sockets")
        .def("__enter__", [](py::object self) { return self; })
        .def("__exit__", [](ClosableLive& s, py::args) {
            py::gil_scoped_release release;
            s.close();
        });

    m.def("open_frames", [](const std::vector<std::string>& inputs, const std::string& meta, const std::string& sensor_model,
                            const std::string& calibration, double cut_angle_deg, int lidar_port, bool skip_bad_packets,
                            int columns, const std::string& beam_calibration, const std::string& roi_config_json,
                            const std::vector<double>& roi_directions) {
        rp::SourceOptions o{meta,        sensor_model,     calibration, cut_angle_deg,
                            lidar_port,  skip_bad_packets, columns,     beam_calibration};
        o.roi_columns = roi_regions(roi_config_json, roi_directions);
        return rp::open_frames(inputs, o);
    });
    bind_stereo(m);
    m.def("open_live", [](const std::string& url, const std::string& meta, const std::string& sensor_model,
                          const std::string& calibration, double cut_angle_deg, bool skip_bad_packets,
                          double timeout_s, double duration_s, const std::string& roi_config_json,
                          const std::vector<double>& roi_directions, bool busy_wait) {
        rp::LiveOptions o;
        o.source.roi_columns = roi_regions(roi_config_json, roi_directions);
        o.source.meta = meta;
        o.source.sensor_model = sensor_model;
        o.source.calibration = calibration;
        o.source.cut_angle_deg = cut_angle_deg;
        o.source.skip_bad_packets = skip_bad_packets;
        o.timeout_s = timeout_s;
        o.duration_s = duration_s;
        o.busy_wait = busy_wait;
        return std::make_unique<ClosableLive>(url, o);
    });
    m.def("replay", [](const std::string& capture, const std::string& to, double rate, int loops, double drop,
                       double reorder, std::uint32_t seed) {
        rp::ReplayOptions o;
        o.rate = rate;
        o.loops = loops;
        o.drop_fraction = drop;
        o.reorder_fraction = reorder;
        o.seed = seed;
        rp::ReplayStats s;
        {
            py::gil_scoped_release release;
            s = rp::replay_pcap(capture, rp::parse_udp_endpoint(to, false), o);
        }
        py::dict d;
        d["sent"] = s.sent;
        d["dropped"] = s.dropped;
        d["reordered"] = s.reordered;
        d["bytes"] = s.bytes;
        d["lidar_port"] = s.lidar_port;
        d["seconds"] = s.seconds;
        d["capture_seconds"] = s.capture_seconds;
        d["clock_jumps"] = s.clock_jumps;
        return d;
    });
    m.def("steady_now_s", &rp::steady_now_s);
    m.def("imu_yaw_rate", [](const rp::Frame& f, const std::string& config_json) {
        return rp::imu_yaw_rate(f.imu, rp::effective_extrinsics(rp::config_from_json(config_json, "config")));
    });
}
