// SPDX-License-Identifier: BSD-3-Clause
// PNG files read with libpng: the stereo input's only image format, without OpenCV's image codecs (which load
// GDAL and ~100 other shared libraries into every program that links the core).
#pragma once

#include <string>

#include <opencv2/core.hpp>

namespace roadpreview {

/// The PNG as it is stored: 1 (grey), 3 (RGB) or 4 (RGBA) channels of 8 or 16 bits; palettes become RGB(A),
/// grey below 8 bits 8 bits, grey + alpha loses its alpha. Errors (missing, truncated, not a PNG, more than
/// 2^15 px a side, a size its data cannot hold) name the file.
cv::Mat read_png(const std::string& path);

}  // namespace roadpreview
