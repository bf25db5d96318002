// SPDX-License-Identifier: BSD-3-Clause
#include "roadpreview/io/readers.hpp"

#include "io/pcap_source.hpp"
#include "roadpreview/calibration/calibration.hpp"

#include <algorithm>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <stdexcept>

#include <pcl/common/io.h>
#include <pcl/console/print.h>
#include <pcl/io/pcd_io.h>
#include <pcl/point_types.h>

namespace roadpreview {
namespace {

namespace fs = std::filesystem;

std::string extension_of(const fs::path& p) {
    std::string ext = p.extension().string();
    std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return std::tolower(c); });
    return ext;
}

bool is_frame_file(const fs::path& p) {
    const std::string ext = extension_of(p);
    return ext == ".bin" || ext == ".pcd";
}

[[noreturn]] void fail(const std::string& path, const std::string& what) {
    throw std::runtime_error(path + ": " + what);
}

Frame read_kitti_bin(const std::string& path) {
    std::ifstream in(path, std::ios::binary | std::ios::ate);
    if (!in) fail(path, "cannot open file");
    const auto bytes = static_cast<std::size_t>(in.tellg());
    constexpr std::size_t kPointBytes = 4 * sizeof(float);
    if (bytes % kPointBytes != 0)
        fail(path, "size " + std::to_string(bytes) +
                       " bytes is not a multiple of 16 (KITTI .bin holds float32 x, y, z, intensity per point); "
                       "the file is truncated or not a KITTI scan");
    Frame f;
    f.source = path;
    f.points.resize(static_cast<Eigen::Index>(bytes / kPointBytes), 4);
    in.seekg(0);
    if (!in.read(reinterpret_cast<char*>(f.points.data()), static_cast<std::streamsize>(bytes)))
        fail(path, "read error");
    return f;
}

Frame read_pcd(const std::string& path) {
    pcl::console::setVerbosityLevel(pcl::console::L_ALWAYS);  // errors are reported by our exception
    pcl::PCLPointCloud2 blob;
    pcl::PCDReader reader;
    // PCL 1.13 accepts a header without FIELDS or DATA and then crashes while reading: check it first.
    Eigen::Vector4f origin;
    Eigen::Quaternionf orientation;
    int version = 0, data_type = 0;
    unsigned int data_start = 0;
    if (reader.readHeader(path, blob, origin, orientation, version, data_type, data_start) < 0 || blob.fields.empty() ||
        data_start == 0)
        fail(path, "not a PCD file (no valid header with FIELDS and DATA)");
    if (reader.read(path, blob) < 0) fail(path, "not a readable PCD file (corrupt header or data)");
    for (const char* axis : {"x", "y", "z"})
        if (pcl::getFieldIndex(blob, axis) < 0) fail(path, std::string("PCD file has no '") + axis + "' field");
    const std::size_t expected = static_cast<std::size_t>(blob.width) * blob.height * blob.point_step;
    if (blob.data.size() < expected) fail(path, "PCD data is shorter than its header declares");
    pcl::PointCloud<pcl::PointXYZI> cloud;
    pcl::fromPCLPointCloud2(blob, cloud);
    const bool has_intensity = pcl::getFieldIndex(blob, "intensity") >= 0;
    Frame f;
    f.source = path;
    f.points.resize(static_cast<Eigen::Index>(cloud.size()), 4);
    for (std::size_t i = 0; i < cloud.size(); ++i) {
        const auto& p = cloud[i];
        f.points.row(static_cast<Eigen::Index>(i)) << p.x, p.y, p.z, has_intensity ? p.intensity : 0.0f;
    }
    return f;
}

}  // namespace

Frame read_frame(const std::string& path) {
    const fs::path p(path);
    std::error_code ec;
    if (!fs::exists(p, ec)) fail(path, "no such file");
    if (!fs::is_regular_file(p, ec)) fail(path, "not a regular file");
    const std::string ext = extension_of(p);
    if (ext == ".bin") return read_kitti_bin(path);
    if (ext == ".pcd") return read_pcd(path);
    fail(path, "unsupported file type '" + ext + "' (expected .bin or .pcd)");
}

std::vector<std::string> expand_inputs(const std::vector<std::string>& inputs) {
    std::vector<std::string> files;
    for (const std::string& input : inputs) {
        const fs::path p(input);
        std::error_code ec;
        if (!fs::exists(p, ec)) fail(input, "no such file or directory");
        if (!fs::is_directory(p, ec)) {
            if (!is_frame_file(p))
                fail(input, "unsupported file type (expected .bin, .pcd, or a single .pcap/.pcapng recording)");
            files.push_back(input);
            continue;
        }
        std::vector<std::string> found;
        for (const auto& entry : fs::directory_iterator(p))
            if (entry.is_regular_file() && is_frame_file(entry.path())) found.push_back(entry.path().string());
        if (found.empty()) fail(input, "directory holds no .bin or .pcd files");
        std::sort(found.begin(), found.end());
        files.insert(files.end(), found.begin(), found.end());
    }
    return files;
}

namespace {

// .bin and .pcd files, one frame each; frame_id is the position in the list.
// With a beams file, each point's beam is found by its elevation angle and its offsets applied.
class FileListSource : public FrameSource {
public:
    FileListSource(std::vector<std::string> files, const SourceOptions& o) : files_(std::move(files)) {
        if (o.beam_calibration.empty()) return;
        beams_file_ = read_beam_calibration(o.beam_calibration);
        if (beams_file_->index != BeamIndexMethod::Elevation)
            fail(o.beam_calibration, "indexes beams by the decoder's beam number; .bin/.pcd points need a beams file "
                                     "that indexes them by elevation (made by `roadpreview calibrate` from such files)");
        check_beam_calibration(*beams_file_, beams_file_->beam_count, o.sensor_model, "");
    }

    std::optional<Frame> next() override {
        if (next_ == files_.size()) return std::nullopt;
        Frame f = read_frame(files_[next_]);
        f.frame_id = static_cast<std::int64_t>(next_++);
        if (beams_file_) {
            f.beams = beams_by_elevation(points_view(f.points.data(), f.points.rows(), 4), *beams_file_);
            apply_beam_calibration(f.points.data(), f.points.rows(), 4, f.beams, *beams_file_);
        }
        return f;
    }

    SourceInfo info() const override {
        SourceInfo i;
        i.format = "files";
        return i;
    }

private:
    std::vector<std::string> files_;
    std::size_t next_ = 0;
    std::optional<BeamCalibration> beams_file_;
};

std::unique_ptr<FrameSource> open_pcap(const std::string& path, const SourceOptions& o) {
    std::error_code ec;
    if (!fs::is_regular_file(path, ec)) fail(path, "no such file");
    const bool velodyne_asked = !o.sensor_model.empty() || !o.calibration.empty();
    if (!o.meta.empty()) {
        if (velodyne_asked) fail(path, "Ouster metadata and Velodyne options given together");
        return open_ouster_pcap(path, o.meta, o);
    }
    if (velodyne_asked) return open_velodyne_pcap(path, o);
    const std::string meta = find_ouster_metadata(path);
    if (!meta.empty()) return open_ouster_pcap(path, meta, o);
    if (looks_like_velodyne(path)) return open_velodyne_pcap(path, o);
    fail(path, "holds no Velodyne data packets and no Ouster metadata JSON was found next to it (looked for " +
                   fs::path(path).stem().string() + ".json and the names its '_'-separated prefixes give); "
                   "pass the metadata with --meta");
}

}  // namespace

bool is_pcap_path(const std::string& path) {
    const std::string ext = extension_of(fs::path(path));
    return ext == ".pcap" || ext == ".pcapng";
}

std::string find_ouster_metadata(const std::string& pcap_path) {
    const fs::path p(pcap_path);
    std::string stem = p.stem().string();
    for (;;) {
        const fs::path candidate = p.parent_path() / (stem + ".json");
        std::error_code ec;
        if (fs::is_regular_file(candidate, ec)) return candidate.string();
        const auto cut = stem.find_last_of('_');
        if (cut == std::string::npos || cut == 0) return {};
        stem.erase(cut);
    }
}

std::unique_ptr<FrameSource> open_frames(const std::vector<std::string>& inputs, const SourceOptions& options) {
    const auto pcaps = std::count_if(inputs.begin(), inputs.end(), is_pcap_path);
    if (pcaps == 0) return std::make_unique<FileListSource>(expand_inputs(inputs), options);
    if (inputs.size() > 1) fail(inputs[0], "give one .pcap/.pcapng recording at a time, without other inputs");
    return open_pcap(inputs[0], options);
}

}  // namespace roadpreview
