// SPDX-License-Identifier: BSD-3-Clause
// Point range preview sensors (docs/method.md §11): downward-looking ultrasonic or laser displacement sensors
// ahead of the wheels, their calibration (distance d = a1·c + a2, sample position x = b1·v + b2) and the
// profiles they give along the distance driven, through the same roughness and IRI stages as the LiDAR.
#pragma once

#include <cstdint>
#include <cstdio>
#include <limits>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "roadpreview/core/config.hpp"
#include "roadpreview/paths/motion.hpp"
#include "roadpreview/paths/path.hpp"
#include "roadpreview/profile/profile.hpp"
#include "roadpreview/roughness/roughness.hpp"

namespace roadpreview {

enum class RangeKind { Ultrasonic, Laser };

/// One sensor of a layout file. Base frame (x forward, y left, z up) with the origin on the road below the
/// rear axle's centre; pitch tilts the beam from straight down towards +x (positive: looking ahead).
struct RangeSensor {
    std::string id;
    RangeKind kind = RangeKind::Laser;
    Wheel wheel = Wheel::Left;
    double x_m = 0.0;        ///< mounting point ahead of the axle
    double y_m = 0.0;        ///< mounting point, positive left
    double height_m = 0.0;   ///< mounting point above the road at rest
    double pitch_deg = 0.0;  ///< beam from straight down towards +x
    double beam_half_angle_deg = 0.0;  ///< ultrasonic cone half angle (informative: the first echo comes from it)
    double min_count = 0.0;            ///< readings in counts outside [min_count, max_count] are errors
    double max_count = std::numeric_limits<double>::infinity();
    double max_distance_m = std::numeric_limits<double>::infinity();  ///< longer distances are errors
};

/// The sensors of a layout file (YAML: `sensors:` a list of the fields above, kind/wheel as words).
/// Throws std::runtime_error naming the file and the sensor for a missing or invalid field.
std::vector<RangeSensor> read_range_layout(const std::string& path);

/// Speed of sound in air, m/s, at temperature_c: 331.3·√(1 + T/273.15).
double speed_of_sound_mps(double temperature_c);

/// d = a1·c·v_sound(T)/v_sound(T_cal) + a2 (eq. 3 of the paper, scaled by the speed of sound when a reading
/// has a temperature); the fit's statistics beside it.
struct DistanceCalibration {
    double a1 = 1.0;            ///< m per count
    double a2 = 0.0;            ///< m
    double temperature_c = 20.0;  ///< bench temperature the fit holds at
    double rms_m = 0.0;         ///< residual RMS of the kept readings
    double r_squared = 0.0;
    std::int64_t used = 0;      ///< readings kept
    std::int64_t rejected = 0;  ///< outliers left out (|residual| > 3.5 robust σ)
    double a1_sigma = 0.0, a2_sigma = 0.0;  ///< standard errors
};

/// Why a distance calibration cannot be a sensor's (a1 not a finite number of metres per count > 0 — a later echo
/// is a farther road — or a2 not within ±kMaxRangeOffsetM), or empty when it can.
std::string implausible(const DistanceCalibration& cal);
constexpr double kMaxRangeOffsetM = 100.0;

/// Distance of a count (temperature NaN: the bench temperature).
double distance_of_count(const DistanceCalibration& cal, double count, double temperature_c);

/// Least squares of d = a1·c + a2, refitted without outliers until none is left (at most 10 rounds).
/// Throws std::invalid_argument for fewer than 3 finite pairs or a single count value.
DistanceCalibration calibrate_distance(const std::vector<double>& counts, const std::vector<double>& distances);

/// A bench CSV with header `count,distance` (other columns ignored); throws std::runtime_error naming file and line.
void read_bench_csv(const std::string& path, std::vector<double>& counts, std::vector<double>& distances);

/// One run's registration onto the reference profile.
struct RunShift {
    std::string source;          ///< the readings file (or a label)
    double speed_mps = 0.0;      ///< mean speed of the run's samples
    double shift_m = 0.0;        ///< ICP: x shift that registers the samples onto the reference
    double shift_sigma_m = 0.0;  ///< its standard error (height residual over the slopes' leverage)
    double z_offset_m = 0.0;     ///< ICP: height offset between samples and reference (nuisance)
    double rms_m = 0.0;          ///< height residual RMS after registration
    double xcorr_shift_m = 0.0;  ///< cross-correlation estimate of the same shift (independent check)
    std::int64_t samples = 0;
};

/// x = b1·v + b2 (eq. 4): where a sample lies ahead of the axle, at speed v.
struct OffsetCalibration {
    double b1_s = 0.0;   ///< latency, s (negative: the sample lies behind where the sensor points)
    double b2_m = 0.0;   ///< geometric offset, m (the beam's foot at rest, ahead of the axle)
    double b1_sigma_s = 0.0, b2_sigma_m = 0.0;
    double b1_xcorr_s = 0.0, b2_xcorr_m = 0.0;  ///< the same line through the cross-correlation shifts
    std::vector<RunShift> runs;
};

/// Calibration of one sensor; each part optional (none: the layout's geometry, identity distance).
struct SensorCalibration {
    std::optional<DistanceCalibration> distance;
    std::optional<OffsetCalibration> offset;
};

/// A calibration file: a distance calibration for every counting sensor and per-sensor entries.
struct RangeCalibration {
    std::optional<DistanceCalibration> distance;       ///< default for sensors without their own
    std::map<std::string, SensorCalibration> sensors;  ///< by sensor id
    /// The distance calibration in force for a sensor (its own, else the default), nullopt: none.
    const DistanceCalibration* distance_for(const std::string& id) const;
    const OffsetCalibration* offset_for(const std::string& id) const;
};

RangeCalibration read_range_calibration(const std::string& path);  ///< YAML; throws std::runtime_error
void write_range_calibration(const RangeCalibration& cal, const std::string& path);
std::string range_calibration_to_yaml(const RangeCalibration& cal);

/// Constant speed and yaw rate, or a motion table; distance and heading integrated from the start time.
class RangeMotion {
public:
    RangeMotion(double speed_mps, double yaw_rate_rps);  ///< throws std::invalid_argument as check_motion refuses
    explicit RangeMotion(MotionTable table);
    /// Start of the integration: the table's first time, or (constant motion) set by the first reading.
    void start_at(double t_s);
    bool started() const { return start_.has_value(); }
    /// Motion at t; throws std::runtime_error (the table's span) like MotionTable::at.
    Motion at(double t_s) const;
    /// Distance (m) and heading change (rad) from the start to t.
    double distance_m(double t_s) const;
    double heading_rad(double t_s) const;
    const std::string& source() const;

private:
    std::optional<MotionTable> table_;
    double speed_ = 0.0, yaw_rate_ = 0.0;
    std::optional<double> start_;
    double start_distance_ = 0.0, start_heading_ = 0.0;
    std::string label_;
};

/// One reading turned into a height sample on a wheel's track.
struct RangeSample {
    double t_s = 0.0;
    std::int32_t sensor = 0;   ///< index into the layout
    double s_m = 0.0;          ///< position along the wheel's track (distance driven by that wheel, from the start)
    double z_m = 0.0;          ///< height above the road at rest (mounting height − d·cos pitch)
    double ahead_m = 0.0;      ///< x = b1·v + b2 (+ the pitch's share of d's change): ahead of the axle
    double speed_mps = 0.0;
    double time_to_wheel_s = std::numeric_limits<double>::quiet_NaN();  ///< ahead / speed; NaN when stopped
};

/// Readings streamed from a CSV file: header `t,sensor,count` or `t,sensor,distance` (m), optional
/// `temperature_c`; any column order, '#' comments. Constant memory: one buffer of the file at a time.
class RangeReadingReader {
public:
    struct Reading {
        double t_s = 0.0;
        std::int32_t sensor = 0;  ///< index into the layout
        double value = 0.0;       ///< count or metres
        double temperature_c = std::numeric_limits<double>::quiet_NaN();
        std::int64_t line = 0;
    };
    /// Throws std::runtime_error naming the file (and line) for an unreadable file or a bad header.
    RangeReadingReader(const std::string& path, const std::vector<RangeSensor>& layout);
    RangeReadingReader(const RangeReadingReader&) = delete;
    RangeReadingReader& operator=(const RangeReadingReader&) = delete;
    /// The next reading; throws std::runtime_error "file:line: ..." for a malformed line, an unknown sensor,
    /// NaN or non-finite values, time going backwards, and counts or distances outside the layout's range.
    bool next(Reading& out);
    bool counts() const { return counts_; }  ///< true for a `count` column, false for `distance`
    const std::string& path() const { return path_; }

private:
    bool next_line(const char*& begin, const char*& end);
    [[noreturn]] void fail(const std::string& what) const;

    struct CloseFile {
        void operator()(std::FILE* f) const { std::fclose(f); }
    };

    std::string path_;
    const std::vector<RangeSensor>& layout_;
    std::unique_ptr<std::FILE, CloseFile> file_;  // closed however the reader ends, a constructor's throw too
    std::vector<char> buffer_;
    std::size_t begin_ = 0, end_ = 0;
    bool eof_ = false;
    std::int64_t line_ = 0;
    bool counts_ = true;
    int columns_ = 0, t_col_ = -1, sensor_col_ = -1, value_col_ = -1, temperature_col_ = -1;
    double last_t_ = -std::numeric_limits<double>::infinity();
};

/// Turns readings into samples: distance calibration, height, position along the wheel's track.
class SamplePlacer {
public:
    SamplePlacer(const std::vector<RangeSensor>& layout, const RangeCalibration& cal, RangeMotion motion,
                 bool counts);
    /// Throws std::runtime_error naming `path` and the reading's line for a counting sensor without a distance
    /// calibration or a time outside the motion table.
    RangeSample place(const RangeReadingReader::Reading& r, const std::string& path);
    const std::vector<RangeSensor>& layout() const { return layout_; }

private:
    std::vector<RangeSensor> layout_;
    std::vector<std::optional<DistanceCalibration>> distance_;
    std::vector<OffsetCalibration> offset_;  // b1 = 0, b2 = geometric foot without a calibration
    RangeMotion motion_;
    bool counts_;
};

/// Every sample of a readings file (for calibration runs; memory grows with the file).
std::vector<RangeSample> read_range_samples(const std::string& readings_path, const std::vector<RangeSensor>& layout,
                                            const RangeCalibration& cal, RangeMotion motion);

/// A known profile along the track: x increasing (m, where the axle is at the motion's start = 0), z (m).
struct ReferenceProfile {
    std::vector<double> x_m, z_m;
    /// The profile's heights may lean against the sensor's (a fused LiDAR map, levelled by its own datum): the
    /// registration then fits a height tilt too, so the lean is not taken for a shift.
    bool leaning_datum = false;
};

/// Offset calibration of one sensor from runs over a known profile: per run the ICP shift (PCL, translation
/// along x plus a height offset, and a height tilt for a leaning_datum) and the cross-correlation shift, then
/// the weighted least-squares line shift = b1·v + b2. `runs[i]` are that sensor's samples placed with b1 = b2 = 0 (s_m: where the axle was,
/// plus the pitch's share of d's change); `references` holds one profile for all runs or one per run.
/// Shifts are searched within guess_m ± search_m (guess: the layout's geometric foot, x_m + h·tan pitch).
/// Throws std::invalid_argument for fewer than two distinct speeds (they must differ by 10 % of the larger),
/// an empty run or a run off the reference.
OffsetCalibration calibrate_offset(const std::vector<std::vector<RangeSample>>& runs,
                                   const std::vector<std::string>& run_names,
                                   const std::vector<ReferenceProfile>& references, double guess_m,
                                   double search_m = 0.5);

/// Every sensor of the layout calibrated from readings files (one motion per run): `cal` with an offset entry
/// added per sensor. `references[k]` are sensor k's (one entry: the same for every sensor), each as in
/// calibrate_offset. Throws std::runtime_error naming the sensor and run.
RangeCalibration calibrate_offsets(const std::vector<RangeSensor>& layout, RangeCalibration cal,
                                   const std::vector<std::string>& run_paths, const std::vector<RangeMotion>& motions,
                                   const std::vector<std::vector<ReferenceProfile>>& references, double search_m = 0.5);

/// The layout's geometric foot of a sensor's beam on the road at rest, ahead of the axle: x_m + h·tan(pitch).
double geometric_foot_m(const RangeSensor& s);

/// One run's shift by ICP and by cross-correlation (see calibrate_offset); speed_mps is left 0.
RunShift register_run(const std::vector<double>& x_m, const std::vector<double>& z_m,
                      const std::vector<double>& ref_x_m, const std::vector<double>& ref_z_m, double guess_m,
                      double search_m, bool fit_tilt = false);

struct RangeProfilerConfig {
    double frame_length_m = 40.0;  ///< a window's length along the track
    double ds_m = 0.1;             ///< bin width
    double max_gap_m = 1.0;        ///< interior gaps up to this are interpolated
    RoughnessConfig roughness;
    IriConfig iri;
};

/// One window of the drive: both wheels' profiles, roughness and the samples behind them.
struct RangeWindow {
    std::int64_t index = 0;
    double s_start_m = 0.0, s_end_m = 0.0;  ///< along the track
    double t_first_s = 0.0, t_last_s = 0.0;
    double mean_speed_mps = 0.0;
    Profile left, right;
    Roughness vehicle;
    std::vector<RangeSample> samples;  ///< in reading order
    std::string reason;                ///< why a wheel has no data, empty otherwise
};

/// Streams readings into windows of frame_length_m: samples are binned per wheel at ds (median, count,
/// spread) and go through the roughness (noise-aware) and IRI stages. Memory: the samples of the open window.
class RangeProfiler {
public:
    RangeProfiler(std::vector<RangeSensor> layout, RangeCalibration cal, RangeProfilerConfig cfg = {});
    /// Processes a whole readings file, calling `emit` for every window. Returns the readings processed.
    template <typename Emit>
    std::int64_t run(const std::string& readings_path, RangeMotion motion, Emit&& emit);
    /// Feeds one sample; returns a finished window when this sample lies beyond the open one's end.
    std::optional<RangeWindow> add(const RangeSample& sample);
    /// The open window (after the last sample), if it holds any samples.
    std::optional<RangeWindow> finish();

    const std::vector<RangeSensor>& layout() const { return layout_; }
    const RangeCalibration& calibration() const { return cal_; }
    const RangeProfilerConfig& config() const { return cfg_; }
    /// Samples that fell behind their window's start (reversing: the track runs back over closed windows), dropped.
    std::int64_t dropped_behind() const { return dropped_behind_; }

private:
    RangeWindow close_window();

    std::vector<RangeSensor> layout_;
    RangeCalibration cal_;
    RangeProfilerConfig cfg_;
    std::int64_t index_ = 0, dropped_behind_ = 0;
    std::vector<RangeSample> open_, next_;
    std::vector<double> latest_;  // per sensor, the furthest s_m so far
};

/// Profile of samples s_m ∈ [s0, s0 + length) binned at ds: median, count, spread, gaps filled (max_gap_m).
Profile bin_samples(const std::vector<RangeSample>& samples, const std::vector<std::uint8_t>& take, double s0_m,
                    double length_m, double ds_m, double max_gap_m);

/// One output line (JSON, no newline) for a window, docs/output.md "Range sensors".
std::string range_window_to_json(const RangeWindow& w, const std::vector<RangeSensor>& layout,
                                 const std::string& source);

template <typename Emit>
std::int64_t RangeProfiler::run(const std::string& readings_path, RangeMotion motion, Emit&& emit) {
    RangeReadingReader reader(readings_path, layout_);
    SamplePlacer placer(layout_, cal_, std::move(motion), reader.counts());
    RangeReadingReader::Reading r;
    std::int64_t n = 0;
    while (reader.next(r)) {
        ++n;
        if (auto w = add(placer.place(r, readings_path))) emit(*w);
    }
    if (auto w = finish()) emit(*w);
    return n;
}

}  // namespace roadpreview
