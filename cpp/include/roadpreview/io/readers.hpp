// SPDX-License-Identifier: BSD-3-Clause
// Frame readers: raw float32 .bin (KITTI, nuScenes, --columns), PCD and PLY files, or directories of them; Ouster and
// Velodyne pcap/pcapng recordings, streamed frame by frame (io/ouster.hpp, io/velodyne.hpp, io/pcap.hpp).
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "roadpreview/core/frames.hpp"
#include "roadpreview/io/frame_source.hpp"

namespace roadpreview {

/// Reads one frame file: raw float32 `.bin` (`columns` values per point: x, y, z, intensity, ...; 0 means 5 for
/// nuScenes `*.pcd.bin`, else 4 as KITTI), `.pcd` or `.ply`. Throws std::runtime_error naming the file on any
/// problem (a header declaring more data than the file holds fails before anything is allocated).
Frame read_frame(const std::string& path, int columns = 0);

/// Values per point of a raw float32 file: `columns` when > 0, else 5 for `*.pcd.bin` (nuScenes), else 4.
int raw_columns(const std::string& path, int columns = 0);

/// The frame files of INPUT arguments, and what their directories hold besides (sub-folders, links, other
/// types, broken links), each as "path", "path (folder)" or "path (broken link)".
struct InputFiles {
    std::vector<std::string> files;
    std::vector<std::string> skipped;
};

/// Expands INPUT arguments: files are kept in order, directories contribute their .bin/.pcd/.ply files sorted
/// by name (links to frame files included). Throws std::runtime_error for a missing path, an unsupported extension
/// or a directory without frame files.
InputFiles list_inputs(const std::vector<std::string>& inputs);

/// list_inputs(inputs).files.
std::vector<std::string> expand_inputs(const std::vector<std::string>& inputs);

/// Why the frame file `next` does not continue the sequence of `previous`, or empty when it does (docs/method.md,
/// "Inputs"): another folder; another name pattern (the name without its last run of digits and extensions);
/// a number not above the previous one, or more than 3 × `step` above it. `step` is the smallest step of the
/// numbers so far in this sequence (0: none yet); it is updated, and reset to 0 at a break.
std::string sequence_break(const std::string& previous, const std::string& next, std::int64_t& step);

/// How to read a recording. Every field is optional.
struct SourceOptions {
    std::string meta;           ///< Ouster metadata JSON; default: found next to the pcap by name
    std::string sensor_model;   ///< Velodyne "VLP-16", "VLP-32C", "HDL-32E", "HDL-64E"; default: from the packets
    std::string calibration;    ///< Velodyne calibration YAML (ROS velodyne_pointcloud format); HDL-64E needs one
    double cut_angle_deg = 0.0; ///< Velodyne: a sweep ends where the azimuth crosses this angle (0 = straight ahead)
    int lidar_port = 0;         ///< UDP port of the lidar packets; 0: the metadata's, else detected by packet size
    bool skip_bad_packets = false;  ///< skip and count lidar packets that do not decode, instead of an error
    int columns = 0;  ///< raw float32 .bin files: values per point; 0: 5 for *.pcd.bin (nuScenes), else 4 (KITTI)
    /// Beams file (beams.yaml, `roadpreview calibrate`) applied while decoding: Ouster and Velodyne by beam,
    /// .bin/.pcd files by their scan order or each point's elevation angle (as the beams file says). A file for
    /// another sensor is an error naming it.
    std::string beam_calibration;
    int imu_port = 0;  ///< Ouster: UDP port of the IMU packets; 0: the metadata's, else told by packet size
    /// Frames that end as soon as these regions (sensor_roi) have been scanned, not a rotation's rest later.
    /// Ouster: only the columns with a beam that can reach one of them are decoded, and the frame ends at the last
    /// (a narrower column window, as the sensor's own azimuth window would give). Velodyne: the sweep ends at the
    /// cut angle after them (velodyne_cut_after; cut_angle_deg is not used). Frame files: an error. Empty: neither.
    std::vector<SensorRoi> roi_columns;
};

/// A reader for the inputs: .pcap/.pcapng recordings (Ouster when metadata is given or found, Velodyne when its
/// data packets are there or a Velodyne option is set; several: split recordings of one drive, read in the
/// order given), or .bin/.pcd/.ply files and directories (each frame's `sequence_break` set).
/// Throws std::runtime_error naming the input when it cannot be read (e.g. no Ouster metadata found).
std::unique_ptr<FrameSource> open_frames(const std::vector<std::string>& inputs, const SourceOptions& options = {});

/// The Ouster metadata next to a pcap: the .json whose name is the pcap's name, or the longest
/// '_'-separated prefix of it (`OS-1-128_v2.3.0_1024x10_lb_n3.pcap` → `OS-1-128_v2.3.0_1024x10.json`).
/// Empty when there is none.
std::string find_ouster_metadata(const std::string& pcap_path);

/// True for a .pcap or .pcapng name.
bool is_pcap_path(const std::string& path);

}  // namespace roadpreview
