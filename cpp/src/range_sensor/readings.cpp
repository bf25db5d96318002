// SPDX-License-Identifier: BSD-3-Clause
// Readings CSV streamed in constant memory, the vehicle's motion, and readings placed as height samples on the
// wheels' tracks (docs/method.md §11.1, §11.3).
#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstring>
#include <sstream>
#include <stdexcept>
#include <string_view>

#include "core/csv.hpp"
#include "core/input_file.hpp"
#include "core/text.hpp"
#include "roadpreview/paths/path.hpp"
#include "roadpreview/range_sensor/range_sensor.hpp"

namespace roadpreview {
namespace {

constexpr std::size_t kBufferBytes = 1 << 20;
constexpr std::size_t kMaxLineBytes = 4096;
constexpr double kDegToRad = 3.14159265358979323846 / 180.0;

std::string_view trimmed(std::string_view s) {
    while (!s.empty() && (s.front() == ' ' || s.front() == '\t')) s.remove_prefix(1);
    while (!s.empty() && (s.back() == ' ' || s.back() == '\t' || s.back() == '\r')) s.remove_suffix(1);
    return s;
}

// Splits [begin, end) at commas into at most `max` trimmed cells; returns the number of cells.
int split_cells(const char* begin, const char* end, std::string_view* cells, int max) {
    int n = 0;
    const char* cell = begin;
    for (const char* p = begin;; ++p) {
        if (p == end || *p == ',') {
            if (n < max) cells[n] = trimmed(std::string_view(cell, static_cast<std::size_t>(p - cell)));
            ++n;
            if (p == end) break;
            cell = p + 1;
        }
    }
    return n;
}

bool parse_double(std::string_view s, double& v) {
    const auto r = std::from_chars(s.data(), s.data() + s.size(), v);
    return r.ec == std::errc() && r.ptr == s.data() + s.size();
}

}  // namespace

// --- RangeReadingReader ------------------------------------------------------------------------------------

RangeReadingReader::RangeReadingReader(const std::string& path, const std::vector<RangeSensor>& layout)
    : path_(path), layout_(layout), buffer_(kBufferBytes) {
    require_input_file<std::runtime_error>(path, "readings file");
    file_.reset(std::fopen(path.c_str(), "rb"));
    if (!file_) throw std::runtime_error(path + ": cannot open the readings file");
    const char *b = nullptr, *e = nullptr;
    while (next_line(b, e)) {
        b = csv::without_byte_order_mark(std::string_view(b, static_cast<std::size_t>(e - b))).data();
        const std::string_view line = trimmed(std::string_view(b, static_cast<std::size_t>(e - b)));
        if (line.empty() || line.front() == '#') continue;
        std::string_view cells[16];
        columns_ = split_cells(b, e, cells, 16);
        for (int i = 0; i < std::min(columns_, 16); ++i) {
            if (cells[i] == "t") t_col_ = i;
            else if (cells[i] == "sensor") sensor_col_ = i;
            else if (cells[i] == "count" || cells[i] == "distance") {
                if (value_col_ >= 0) fail("the header has both 'count' and 'distance'");
                value_col_ = i;
                counts_ = cells[i] == "count";
            } else if (cells[i] == "temperature_c") temperature_col_ = i;
        }
        if (t_col_ < 0 || sensor_col_ < 0 || value_col_ < 0)
            fail("the header must name t, sensor and count or distance (optional temperature_c), got \"" +
                 std::string(line) + "\"");
        return;
    }
    fail("empty file, expected a header t,sensor,count or t,sensor,distance");
}

void RangeReadingReader::fail(const std::string& what) const {
    throw std::runtime_error(path_ + ":" + std::to_string(line_) + ": " + what);
}

// The next line without its newline, [begin, end) inside the buffer (valid until the next call).
bool RangeReadingReader::next_line(const char*& begin, const char*& end) {
    for (;;) {
        const char* start = buffer_.data() + begin_;
        const void* nl = std::memchr(start, '\n', end_ - begin_);
        if (nl || (eof_ && end_ > begin_)) {
            const char* stop = nl ? static_cast<const char*>(nl) : buffer_.data() + end_;
            begin = start;
            end = stop;
            begin_ = nl ? static_cast<std::size_t>(stop - buffer_.data()) + 1 : end_;
            ++line_;
            return true;
        }
        if (eof_) return false;
        if (end_ - begin_ > kMaxLineBytes) {
            ++line_;
            fail("line longer than " + std::to_string(kMaxLineBytes) + " bytes");
        }
        std::memmove(buffer_.data(), start, end_ - begin_);  // keep the partial line, refill behind it
        end_ -= begin_;
        begin_ = 0;
        const std::size_t got = std::fread(buffer_.data() + end_, 1, buffer_.size() - end_, file_.get());
        if (std::ferror(file_.get())) fail("read error");
        end_ += got;
        eof_ = got == 0;
    }
}

bool RangeReadingReader::next(Reading& out) {
    const char *b = nullptr, *e = nullptr;
    std::string_view cells[16];
    for (;;) {
        if (!next_line(b, e)) return false;
        const std::string_view line = trimmed(std::string_view(b, static_cast<std::size_t>(e - b)));
        if (line.empty() || line.front() == '#') continue;
        break;
    }
    if (split_cells(b, e, cells, 16) != columns_)
        fail("expected " + std::to_string(columns_) + " columns like the header, got \"" + std::string(b, e) + "\"");
    out.line = line_;
    if (!parse_double(cells[t_col_], out.t_s) || !std::isfinite(out.t_s)) fail("t is not a finite number");
    if (out.t_s < last_t_) fail("time goes backwards (t = " + number_text(out.t_s, 12) + " s after "
        + number_text(last_t_, 12) + " s)");
    last_t_ = out.t_s;
    const std::string_view id = cells[sensor_col_];
    if (out.sensor < 0 || out.sensor >= static_cast<std::int32_t>(layout_.size()) ||
        layout_[static_cast<std::size_t>(out.sensor)].id != id) {  // usually the same sensor as last time's guess
        const auto it = std::find_if(layout_.begin(), layout_.end(), [&](const RangeSensor& s) { return s.id == id; });
        if (it == layout_.end()) fail("unknown sensor id '" + std::string(id) + "' (not in the layout)");
        out.sensor = static_cast<std::int32_t>(it - layout_.begin());
    }
    const RangeSensor& s = layout_[static_cast<std::size_t>(out.sensor)];
    const char* what = counts_ ? "count" : "distance";
    if (!parse_double(cells[value_col_], out.value) || !std::isfinite(out.value))
        fail(std::string(what) + " is not a finite number: \"" + std::string(cells[value_col_]) + "\"");
    if (counts_ && (out.value < s.min_count || out.value > s.max_count))
        fail("count " + number_text(out.value, 12) + " outside the layout's range [" +
             number_text(s.min_count, 12) + ", " + number_text(s.max_count, 12) + "] of sensor '" + s.id + "'");
    if (!counts_ && (out.value < 0 || out.value > s.max_distance_m))
        fail("distance " + number_text(out.value, 12) + " m outside the layout's range [0, "
            + number_text(s.max_distance_m, 12) +
             "] m of sensor '" + s.id + "'");
    out.temperature_c = std::numeric_limits<double>::quiet_NaN();
    if (temperature_col_ >= 0 && !cells[temperature_col_].empty() &&
        (!parse_double(cells[temperature_col_], out.temperature_c) || !(out.temperature_c > -273.15)))
        fail("temperature_c is not a temperature above absolute zero");
    return true;
}

// --- RangeMotion -------------------------------------------------------------------------------------------

RangeMotion::RangeMotion(double speed_mps, double yaw_rate_rps)
    : speed_(speed_mps), yaw_rate_(yaw_rate_rps), label_("--speed") {
    if (const Status s = check_motion(speed_mps, yaw_rate_rps); !s) throw std::invalid_argument(s.message());
}

RangeMotion::RangeMotion(MotionTable table) : table_(std::move(table)) {
    start_at(table_->first_time());
}

void RangeMotion::start_at(double t_s) {
    start_ = t_s;
    start_distance_ = table_ ? table_->distance_m(t_s) : 0.0;
    start_heading_ = table_ ? table_->heading_rad(t_s) : 0.0;
}

Motion RangeMotion::at(double t_s) const { return table_ ? table_->at(t_s) : Motion{speed_, yaw_rate_}; }

double RangeMotion::distance_m(double t_s) const {
    return table_ ? table_->distance_m(t_s) - start_distance_ : speed_ * (t_s - start_.value_or(t_s));
}

double RangeMotion::heading_rad(double t_s) const {
    return table_ ? table_->heading_rad(t_s) - start_heading_ : yaw_rate_ * (t_s - start_.value_or(t_s));
}

const std::string& RangeMotion::source() const { return table_ ? table_->source() : label_; }

// --- SamplePlacer ------------------------------------------------------------------------------------------

SamplePlacer::SamplePlacer(const std::vector<RangeSensor>& layout, const RangeCalibration& cal, RangeMotion motion,
                           bool counts)
    : layout_(layout), motion_(std::move(motion)), counts_(counts) {
    for (const RangeSensor& s : layout_) {
        const DistanceCalibration* d = cal.distance_for(s.id);
        distance_.push_back(d ? std::optional(*d) : std::nullopt);
        const OffsetCalibration* o = cal.offset_for(s.id);
        OffsetCalibration geometric;
        geometric.b2_m = geometric_foot_m(s);
        offset_.push_back(o ? *o : geometric);
    }
}

RangeSample SamplePlacer::place(const RangeReadingReader::Reading& r, const std::string& path) {
    const auto where = [&] { return path + ":" + std::to_string(r.line); };
    const auto k = static_cast<std::size_t>(r.sensor);
    const RangeSensor& s = layout_[k];
    double d = r.value;
    if (counts_) {
        if (!distance_[k]) throw std::runtime_error(where() + ": sensor '" + s.id
            + "' reads counts but the calibration "
                                                    "has no distance calibration for it (range calibrate-distance)");
        d = distance_of_count(*distance_[k], r.value, r.temperature_c);
    }
    if (!motion_.started()) motion_.start_at(r.t_s);
    RangeSample out;
    try {
        const Motion m = motion_.at(r.t_s);
        out.speed_mps = m.speed_mps;
        // A wheel at lateral offset y rolls (v − ω·y) per second: its track is D − y·Θ.
        out.s_m = motion_.distance_m(r.t_s) - s.y_m * motion_.heading_rad(r.t_s);
    } catch (const std::runtime_error& e) {
        throw std::runtime_error(where() + ": reading at t = " + number_text(r.t_s, 12) + " s: " + e.what());
    }
    const double pitch = s.pitch_deg * kDegToRad;
    const OffsetCalibration& o = offset_[k];
    out.t_s = r.t_s;
    out.sensor = r.sensor;
    out.z_m = s.height_m - d * std::cos(pitch);
    out.ahead_m = o.b1_s * out.speed_mps + o.b2_m + (d - s.height_m / std::cos(pitch)) * std::sin(pitch);
    out.s_m += out.ahead_m;
    if (out.speed_mps > 0) out.time_to_wheel_s = out.ahead_m / out.speed_mps;
    return out;
}

std::vector<RangeSample> read_range_samples(const std::string& readings_path, const std::vector<RangeSensor>& layout,
                                            const RangeCalibration& cal, RangeMotion motion) {
    RangeReadingReader reader(readings_path, layout);
    SamplePlacer placer(layout, cal, std::move(motion), reader.counts());
    std::vector<RangeSample> samples;
    RangeReadingReader::Reading r;
    while (reader.next(r)) samples.push_back(placer.place(r, readings_path));
    return samples;
}

}  // namespace roadpreview
