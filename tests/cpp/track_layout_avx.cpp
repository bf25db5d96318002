// SPDX-License-Identifier: BSD-3-Clause
// Built with -mavx (tests/CMakeLists.txt): Eigen then aligns 32-byte fixed-size matrices to 32 bytes.
#include "track_layout.hpp"

TrackLayout track_layout_avx() { return track_layout_here(); }
