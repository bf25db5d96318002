// SPDX-License-Identifier: BSD-3-Clause
// What every reader yields: one frame of points at a time, with its time, id and decode diagnostics.
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>

namespace roadpreview {

using PointMatrix = Eigen::Matrix<float, Eigen::Dynamic, 4, Eigen::RowMajor>;

struct FrameDiagnostics {
    std::int64_t missing_columns = 0;  ///< Ouster: columns of the column window never received
    std::int64_t cut_columns = 0;      ///< Ouster: of those, the ones before the input's first packet (in its first
                                       ///< frame) or after its last (in the frame finish() returns): the input
                                       ///< began or ended within the frame, no packet was lost
    std::int64_t invalid_columns = 0;  ///< Ouster: columns received with the status bit clear (skipped)
    std::int64_t skipped_packets = 0;  ///< lidar packets of the wrong size skipped (only with skip_bad_packets)
    std::int64_t lost_packets = 0;      ///< lidar packets of the frame that never arrived (Ouster: from its missing
                                        ///< columns but the cut ones; Velodyne: from gaps in the packets' sensor time)
    std::int64_t late_packets = 0;      ///< packets that arrived after their frame was closed, or out of time order
                                        ///< (Velodyne): dropped
    std::int64_t duplicate_packets = 0; ///< packets received twice (the copy adds nothing)
    bool complete = true;  ///< false: columns are missing, or a Velodyne sweep was cut short by the file's ends
};

/// One IMU reading in the sensor frame (Ouster IMU packets).
struct ImuSample {
    double timestamp = 0.0;                      ///< s, capture time of the packet
    std::array<double, 3> angular_velocity{};    ///< rad/s about the sensor frame's x, y, z
    std::array<double, 3> linear_acceleration{}; ///< m/s²
};

struct Frame {
    PointMatrix points;  ///< sensor frame x, y, z (m) and an intensity-like channel (0 when there is none)
    std::string source;  ///< the file it came from
    std::optional<double> timestamp;  ///< s; pcaps: capture time (UNIX epoch) of the frame's first packet
    std::int64_t frame_id = -1;       ///< Ouster: the packets' frame id; Velodyne: sweep count; files: index
    std::vector<float> point_times;   ///< s after `timestamp`, one per point; empty when unknown
    std::vector<std::int32_t> beams;  ///< beam (Ouster row from the top, Velodyne laser id) per point; empty: unknown
    std::vector<ImuSample> imu;       ///< IMU readings received with this frame's packets
    /// m², one per point: variance of its distance from the sensor along its line of sight (stereo cameras);
    /// empty when unknown (LiDAR). Estimator::process takes it to rate the profiles' and the map's noise.
    std::vector<float> range_variances;
    /// one per point: points with the same id share their range error (a stereo matcher's errors, correlated
    /// over neighbouring pixels), so a bin counts them as one measurement; empty: every point's error its own
    std::vector<std::int32_t> error_groups;
    FrameDiagnostics diagnostics;
    std::string sequence_break;       ///< files: why this frame does not continue the previous one; empty if it does
    /// live: steady-clock time (s) the datagram that completed the frame arrived; 0 from files, and for a frame
    /// that the end of the stream completed
    double arrival_s = 0.0;
    /// live: steady-clock time (s) the decoder had completed the frame (that datagram decoded, the frame built);
    /// 0 whenever arrival_s is
    double completed_s = 0.0;
};

/// What a reader knows about its input (`roadpreview info`).
struct SourceInfo {
    std::string format;        ///< "ouster pcap", "velodyne pcap", "ouster udp", "velodyne udp" or "files"
    std::string sensor_model;  ///< e.g. "OS-1-128", "VLP-16"; empty when unknown
    std::string profile;       ///< Ouster UDP lidar profile or Velodyne return mode
    std::string metadata;      ///< metadata or calibration file used, if any
    int lidar_port = 0;        ///< UDP destination port of the lidar packets (0: not a pcap or none seen)
    std::string lidar_port_origin;  ///< "metadata", "option", "detected" or "default"
    double frame_rate_hz = 0.0;     ///< nominal sweep rate; 0 when unknown
    int beams = 0;                  ///< beams (Ouster rows, Velodyne lasers); 0 when unknown
    std::string serial;             ///< sensor serial number; empty when unknown
    std::vector<std::string> notes; ///< anything worth a user's attention (model choice, ID mismatches)
    std::int64_t datagrams_received = 0;  ///< live: UDP datagrams received so far
    std::int64_t datagrams_dropped = 0;   ///< live: datagrams dropped because the receive queue was full
};

/// Streams frames one at a time; memory does not grow with the input's size.
class FrameSource {
public:
    virtual ~FrameSource() = default;
    /// The next frame, or nullopt at the end. Throws std::runtime_error naming the file on bad input;
    /// frames returned before the error stay valid.
    virtual std::optional<Frame> next() = 0;
    /// What the source is. Some of it is known only once packets have been read: a Velodyne source's model, beams,
    /// calibration and frame rate come from its first packets, so they are empty (0) until the first next().
    virtual SourceInfo info() const = 0;
};

}  // namespace roadpreview
