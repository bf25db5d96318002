// SPDX-License-Identifier: BSD-3-Clause
// Frame readers: KITTI .bin (float32 x, y, z, intensity) and PCD files, or directories of them; Ouster and
// Velodyne pcap/pcapng recordings, streamed frame by frame (io/ouster.hpp, io/velodyne.hpp, io/pcap.hpp).
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "roadpreview/io/frame_source.hpp"

namespace roadpreview {

/// Reads one .bin or .pcd file. Throws std::runtime_error naming the file on any problem.
Frame read_frame(const std::string& path);

/// Expands INPUT arguments: files are kept in order, directories contribute their .bin/.pcd files
/// sorted by name. Throws std::runtime_error for a missing path, an unsupported extension or an empty dir.
std::vector<std::string> expand_inputs(const std::vector<std::string>& inputs);

/// How to read a recording. Every field is optional.
struct SourceOptions {
    std::string meta;           ///< Ouster metadata JSON; default: found next to the pcap by name
    std::string sensor_model;   ///< Velodyne "VLP-16", "VLP-32C", "HDL-32E", "HDL-64E"; default: from the packets
    std::string calibration;    ///< Velodyne calibration YAML (ROS velodyne_pointcloud format); HDL-64E needs one
    double cut_angle_deg = 0.0; ///< Velodyne: a sweep ends where the azimuth crosses this angle (0 = straight ahead)
    int lidar_port = 0;         ///< UDP port of the lidar packets; 0: the metadata's, else detected by packet size
    bool skip_bad_packets = false;  ///< skip and count lidar packets that do not decode, instead of an error
    /// Beams file (beams.yaml, `roadpreview calibrate`) applied while decoding: Ouster and Velodyne by beam,
    /// .bin/.pcd files by each point's elevation angle. A file for another sensor is an error naming it.
    std::string beam_calibration;
};

/// A reader for the inputs: one .pcap/.pcapng file (Ouster when metadata is given or found, Velodyne when
/// its data packets are there or a Velodyne option is set), or .bin/.pcd files and directories.
/// Throws std::runtime_error naming the input when it cannot be read (e.g. no Ouster metadata found).
std::unique_ptr<FrameSource> open_frames(const std::vector<std::string>& inputs, const SourceOptions& options = {});

/// The Ouster metadata next to a pcap: the .json whose name is the pcap's name, or the longest
/// '_'-separated prefix of it (`OS-1-128_v2.3.0_1024x10_lb_n3.pcap` → `OS-1-128_v2.3.0_1024x10.json`).
/// Empty when there is none.
std::string find_ouster_metadata(const std::string& pcap_path);

/// True for a .pcap or .pcapng name.
bool is_pcap_path(const std::string& path);

}  // namespace roadpreview
