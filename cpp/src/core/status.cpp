// SPDX-License-Identifier: BSD-3-Clause
#include "roadpreview/core/status.hpp"

#include <cstdarg>
#include <cstdio>

namespace roadpreview {

const char* to_string(StatusCode code) noexcept {
    switch (code) {
        case StatusCode::Ok: return "ok";
        case StatusCode::InvalidArgument: return "invalid argument";
        case StatusCode::OutOfMemory: return "out of memory";
        case StatusCode::Internal: return "internal error";
    }
    return "?";
}

Status Status::error(StatusCode code, const char* format, ...) noexcept {
    Status s;
    s.code_ = code;
    std::va_list args;
    va_start(args, format);
    std::vsnprintf(s.message_, kMessageCapacity, format, args);
    va_end(args);
    return s;
}

}  // namespace roadpreview
