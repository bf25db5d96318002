// SPDX-License-Identifier: BSD-3-Clause
// The layout of roadside::Track as one translation unit sees it: tests/cpp/track_layout_avx.cpp is built with
// -mavx, the roadside tests without, and the library's Track must be the same struct in both.
#pragma once

#include <cstddef>

#include "roadpreview/roadside/tracking.hpp"

struct TrackLayout {
    std::size_t size, align, x, P, visible_offset, last_box;
    bool operator==(const TrackLayout& o) const {
        return size == o.size && align == o.align && x == o.x && P == o.P && visible_offset == o.visible_offset &&
               last_box == o.last_box;
    }
};

inline TrackLayout track_layout_here() {
    const roadpreview::roadside::Track t;
    const auto at = [&](const void* member) {
        return static_cast<std::size_t>(static_cast<const char*>(member) - reinterpret_cast<const char*>(&t));
    };
    return {sizeof t, alignof(roadpreview::roadside::Track), at(&t.x), at(&t.P), at(&t.visible_offset),
            at(&t.last_box)};
}

/// The layout in the translation unit built with -mavx.
TrackLayout track_layout_avx();
