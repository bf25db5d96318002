// SPDX-License-Identifier: BSD-3-Clause
#include "roadpreview/io/readers.hpp"

#include "io/cloud_files.hpp"
#include "io/pcap_source.hpp"
#include "roadpreview/calibration/calibration.hpp"
#include "core/text.hpp"

#include <algorithm>
#include <cctype>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <optional>
#include <sstream>
#include <stdexcept>

namespace roadpreview {

namespace fs = std::filesystem;

void fail_file(const std::string& path, const std::string& what) { throw std::runtime_error(path + ": " + what); }

std::uint64_t file_size(const std::string& path) {
    std::error_code ec;
    const auto size = fs::file_size(path, ec);
    if (ec) fail_file(path, "cannot read file (" + ec.message() + ")");
    return size;
}

std::vector<std::string> header_words(const std::string& line) {
    std::istringstream in(line);
    std::vector<std::string> out;
    for (std::string w; in >> w;) out.push_back(w);
    return out;
}

bool holds_control_character(const std::string& line) {
    return std::any_of(line.begin(), line.end(), [](char c) {
        const auto u = static_cast<unsigned char>(c);
        return (u < 0x20 && c != '\t' && c != '\r') || u == 0x7f;
    });
}

std::optional<std::uint64_t> whole_number(const std::string& text, std::uint64_t max) {
    if (text.empty() || text.size() > 19 || text.find_first_not_of("0123456789") != std::string::npos)
        return std::nullopt;
    const std::uint64_t v = std::stoull(text);
    if (v > max) return std::nullopt;
    return v;
}

Frame read_raw_float32(const std::string& path, int columns) {
    if (columns < 3)
        fail_file(path, "a raw float32 file needs at least 3 columns (x, y, z), got " + std::to_string(columns));
    std::ifstream in(path, std::ios::binary);
    if (!in) fail_file(path, "cannot open file");
    const std::uint64_t bytes = file_size(path);
    const std::uint64_t point_bytes = static_cast<std::uint64_t>(columns) * sizeof(float);
    if (bytes % point_bytes != 0)
        fail_file(path, "size " + std::to_string(bytes) + " bytes is not a multiple of " + std::to_string(point_bytes) +
                            " (" + std::to_string(columns) + " float32 values per point); the file is truncated or " +
                            "has another number of columns (--columns)");
    const auto rows = static_cast<Eigen::Index>(bytes / point_bytes);
    Frame f;
    f.source = path;
    const auto read_into = [&](float* data) {
        if (!in.read(reinterpret_cast<char*>(data), static_cast<std::streamsize>(bytes))) fail_file(path, "read error");
    };
    if (columns == 4) {  // KITTI: the file is the frame's layout
        f.points.resize(rows, 4);
        read_into(f.points.data());
        return f;
    }
    Eigen::Matrix<float, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> raw(rows, columns);
    read_into(raw.data());
    f.points.setZero(rows, 4);
    f.points.leftCols(std::min(columns, 4)) = raw.leftCols(std::min(columns, 4));
    return f;
}

namespace {

std::string lower(std::string text) {
    std::transform(text.begin(), text.end(), text.begin(), [](unsigned char c) { return std::tolower(c); });
    return text;
}

std::string extension_of(const fs::path& p) { return lower(p.extension().string()); }

bool is_frame_file(const fs::path& p) {
    const std::string ext = extension_of(p);
    return ext == ".bin" || ext == ".pcd" || ext == ".ply";
}

// nuScenes names its float32 x, y, z, intensity, ring sweeps *.pcd.bin.
bool is_nuscenes_bin(const fs::path& p) {
    const std::string name = lower(p.filename().string());
    return name.size() > 8 && name.compare(name.size() - 8, 8, ".pcd.bin") == 0;
}

}  // namespace

int raw_columns(const std::string& path, int columns) {
    if (columns > 0) return columns;
    return is_nuscenes_bin(fs::path(path)) ? 5 : 4;
}

Frame read_frame(const std::string& path, int columns) {
    const fs::path p(path);
    std::error_code ec;
    if (!fs::exists(p, ec)) fail_file(path, "no such file");
    if (!fs::is_regular_file(p, ec)) fail_file(path, "not a regular file");
    const std::string ext = extension_of(p);
    if (ext == ".bin") return read_raw_float32(path, raw_columns(path, columns));
    if (columns > 0) fail_file(path, "--columns applies to raw float32 .bin files only");
    if (ext == ".pcd") return read_pcd(path);
    if (ext == ".ply") return read_ply(path);
    fail_file(path, "unsupported file type '" + ext + "' (expected .bin, .pcd or .ply)");
}

InputFiles list_inputs(const std::vector<std::string>& inputs) {
    InputFiles out;
    for (const std::string& input : inputs) {
        const fs::path p(input);
        std::error_code ec;
        if (!fs::exists(p, ec)) fail_file(input, "no such file or directory");
        if (!fs::is_directory(p, ec)) {
            if (!is_frame_file(p))
                fail_file(input, "unsupported file type (expected .bin, .pcd, .ply, or .pcap/.pcapng recordings)");
            out.files.push_back(input);
            continue;
        }
        std::vector<std::string> found;
        for (const auto& entry : fs::directory_iterator(p)) {
            if (entry.is_regular_file(ec) && is_frame_file(entry.path())) {  // links to frame files count
                found.push_back(entry.path().string());
                continue;
            }
            const bool broken_link = entry.is_symlink(ec) && !fs::exists(entry.path(), ec);
            out.skipped.push_back(entry.path().string() + (broken_link         ? " (broken link)"
                                                           : entry.is_directory(ec) ? " (folder)"
                                                                                    : ""));
        }
        if (found.empty()) fail_file(input, "directory holds no .bin, .pcd or .ply files");
        std::sort(found.begin(), found.end());
        out.files.insert(out.files.end(), found.begin(), found.end());
    }
    std::sort(out.skipped.begin(), out.skipped.end());
    return out;
}

std::vector<std::string> expand_inputs(const std::vector<std::string>& inputs) { return list_inputs(inputs).files; }

namespace {

// "seq/000123.bin" → folder "seq", prefix "", number 123, suffix "": the name without its extension (and the
// ".pcd" of nuScenes' ".pcd.bin") split at its last run of digits.
struct FileName {
    std::string folder, prefix, suffix;
    std::optional<std::int64_t> number;
};

FileName split_name(const std::string& path) {
    const fs::path p(path);
    std::string stem = p.stem().string();
    if (is_nuscenes_bin(p)) stem.erase(stem.size() - 4);
    FileName n{p.parent_path().string(), stem, extension_of(p), {}};
    const auto last = n.prefix.find_last_of("0123456789");
    if (last == std::string::npos) return n;
    auto first = n.prefix.find_last_not_of("0123456789", last);
    first = first == std::string::npos ? 0 : first + 1;
    if (last - first + 1 > 18) return n;
    n.number = std::stoll(n.prefix.substr(first, last - first + 1));
    n.suffix = n.prefix.substr(last + 1) + n.suffix;
    n.prefix.erase(first);
    return n;
}

}  // namespace

std::string sequence_break(const std::string& previous, const std::string& next, std::int64_t& step) {
    constexpr std::int64_t kMaxStepRatio = 3;  // two dropped frames still continue a sequence
    const FileName a = split_name(previous), b = split_name(next);
    std::string problem;
    if (a.folder != b.folder) problem = "another folder";
    else if (a.prefix != b.prefix || a.suffix != b.suffix || a.number.has_value() != b.number.has_value())
        problem = "another file name pattern";
    else if (a.number && (*b.number <= *a.number || (step > 0 && *b.number - *a.number > kMaxStepRatio * step)))
        problem = "frame number " + std::to_string(*a.number) + " → " + std::to_string(*b.number);
    if (!problem.empty() || !a.number) step = 0;
    else step = step > 0 ? std::min<std::int64_t>(step, *b.number - *a.number) : *b.number - *a.number;
    return problem;
}

namespace {

// .bin, .pcd and .ply files, one frame each; frame_id is the position in the list.
// With a beams file, each point's beam is found by its place in the scan or its elevation and its offsets applied.
class FileListSource : public FrameSource {
public:
    FileListSource(InputFiles inputs, const SourceOptions& o) : inputs_(std::move(inputs)), columns_(o.columns) {
        if (o.beam_calibration.empty()) return;
        beams_file_ = read_beam_calibration(o.beam_calibration);
        if (beams_file_->index == BeamIndexMethod::Decoder)
            fail_file(o.beam_calibration, "indexes beams by the decoder's beam number; .bin/.pcd points need a "
                                          "beams file that indexes them by scan order or elevation (made by "
                                          "`roadpreview calibrate` from such files)");
        check_beam_calibration(*beams_file_, beams_file_->beam_count, o.sensor_model, "");
    }

    std::optional<Frame> next() override {
        const auto& files = inputs_.files;
        if (next_ == files.size()) return std::nullopt;
        Frame f = read_frame(files[next_], columns_);
        if (next_ > 0) f.sequence_break = sequence_break(files[next_ - 1], files[next_], step_);
        f.frame_id = static_cast<std::int64_t>(next_++);
        if (beams_file_) {
            f.beams = beams_of_points(points_view(f.points.data(), f.points.rows(), 4), *beams_file_,
                                      files[next_ - 1]);
            apply_beam_calibration(f.points.data(), f.points.rows(), 4, f.beams, *beams_file_);
        }
        return f;
    }

    SourceInfo info() const override {
        SourceInfo i;
        i.format = "files";
        if (!inputs_.skipped.empty()) i.notes.push_back(skipped_note(inputs_.skipped));
        return i;
    }

private:
    static std::string skipped_note(const std::vector<std::string>& skipped) {
        constexpr std::size_t kNamed = 5;
        std::string note = "skipped " + std::to_string(skipped.size()) + " director" +
                           (skipped.size() == 1 ? "y entry" : "y entries") + " that are not frame files:";
        for (std::size_t i = 0; i < std::min(kNamed, skipped.size()); ++i) note += (i ? ", " : " ") + skipped[i];
        if (skipped.size() > kNamed) note += ", ...";
        return note;
    }

    InputFiles inputs_;
    int columns_;
    std::size_t next_ = 0;
    std::int64_t step_ = 0;  // of the name numbers in the current sequence
    std::optional<BeamCalibration> beams_file_;
};

std::unique_ptr<FrameSource> open_pcap(const std::string& path, const SourceOptions& o) {
    std::error_code ec;
    if (!fs::is_regular_file(path, ec)) fail_file(path, "no such file");
    const bool velodyne_asked = !o.sensor_model.empty() || !o.calibration.empty();
    if (!o.meta.empty()) {
        if (velodyne_asked) fail_file(path, "Ouster metadata and Velodyne options given together");
        return open_ouster_pcap(path, o.meta, o);
    }
    if (velodyne_asked) return open_velodyne_pcap(path, o);
    const std::string meta = find_ouster_metadata(path);
    if (!meta.empty()) return open_ouster_pcap(path, meta, o);
    if (looks_like_velodyne(path)) return open_velodyne_pcap(path, o);
    if (!holds_lidar_sized_datagrams(path))
        fail_file(path, "holds no LiDAR packets: no UDP datagram of " + std::to_string(kMinLidarPacketBytes) +
                        " bytes or more (a SICK scanner's telegrams travel over TCP: `roadpreview roadside` reads "
                        "those)");
    fail_file(path, "holds no Velodyne data packets and no Ouster metadata JSON was found next to it (looked for " +
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

namespace {

// "ouster OS-1-128", or the format alone while the model is not known (a Velodyne's, before its first packet).
std::string kind_of(const SourceInfo& info) {
    return info.sensor_model.empty() ? info.format : info.format + " " + info.sensor_model;
}

// Split recordings of one drive, read in the order given as one stream of frames. A sweep cut by the split
// comes out as two partial frames; a recording that starts before the previous one ended is an error.
class PcapSequenceSource : public FrameSource {
public:
    PcapSequenceSource(std::vector<std::string> paths, const SourceOptions& options)
        : paths_(std::move(paths)), options_(options), current_(open_pcap(paths_[0], options)) {
        info_ = current_->info();
        info_.notes.push_back(std::to_string(paths_.size()) + " recordings read as one drive, in the order given");
    }

    std::optional<Frame> next() override {
        for (;;) {
            std::optional<Frame> f = current_->next();
            if (f) return checked(std::move(*f));
            if (++index_ == paths_.size()) return std::nullopt;
            current_ = open_pcap(paths_[index_], options_);
            const SourceInfo next_info = current_->info();
            if (next_info.format != info_.format || next_info.sensor_model != info_.sensor_model)
                fail_file(paths_[index_], "holds " + kind_of(next_info) + " data but " + paths_[0] + " holds " +
                                              kind_of(info_));
        }
    }

    SourceInfo info() const override { return info_; }

private:
    Frame checked(Frame f) {
        if (f.timestamp && last_time_ && *f.timestamp < *last_time_ && last_file_ != index_)
            fail_file(paths_[index_], "starts at " + number_text(*f.timestamp, 15) + " s, before the end of " +
                                          paths_[last_file_] + " (" + number_text(*last_time_, 15) +
                                          " s): give split recordings in time order");
        if (f.timestamp) last_time_ = f.timestamp, last_file_ = index_;
        return f;
    }

    std::vector<std::string> paths_;
    SourceOptions options_;
    std::unique_ptr<FrameSource> current_;
    SourceInfo info_;
    std::size_t index_ = 0, last_file_ = 0;
    std::optional<double> last_time_;
};

}  // namespace

std::unique_ptr<FrameSource> open_frames(const std::vector<std::string>& inputs, const SourceOptions& options) {
    if (inputs.empty()) throw std::invalid_argument("open_frames: no inputs given (files, folders or recordings)");
    if (options.columns < 0)
        fail_file(inputs[0], "columns must be 0 (read by the file's kind) or the float32 values per point, at least 3; "
                             "got " + std::to_string(options.columns));
    const auto pcaps = std::count_if(inputs.begin(), inputs.end(), is_pcap_path);
    if (pcaps == 0) {
        if (!options.roi_columns.empty())
            fail_file(inputs[0], "frames limited to the region of interest's columns need an Ouster or Velodyne recording");
        return std::make_unique<FileListSource>(list_inputs(inputs), options);
    }
    if (pcaps != static_cast<std::ptrdiff_t>(inputs.size()))
        fail_file(inputs[0], "give .pcap/.pcapng recordings or frame files, not both in one run");
    if (options.columns > 0) fail_file(inputs[0], "--columns applies to raw float32 .bin files only");
    if (inputs.size() == 1) return open_pcap(inputs[0], options);
    return std::make_unique<PcapSequenceSource>(inputs, options);
}

}  // namespace roadpreview
