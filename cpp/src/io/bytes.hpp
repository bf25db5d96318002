// SPDX-License-Identifier: BSD-3-Clause
// Little-endian field reads from packet buffers (both vendors send little-endian; so is every target).
#pragma once

#include <cstdint>
#include <cstring>

namespace roadpreview {

template <typename T>
T read_le(const std::uint8_t* p) {
    T v;
    std::memcpy(&v, p, sizeof(T));
    return v;
}

}  // namespace roadpreview
