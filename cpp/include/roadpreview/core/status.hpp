// SPDX-License-Identifier: BSD-3-Clause
// Errors as values, for callers built without exceptions (Estimator::try_process): a code and the message the
// throwing API would have thrown, in a fixed buffer so that reporting an error allocates nothing and cannot throw.
#pragma once

#include <cstddef>

namespace roadpreview {

enum class StatusCode {
    Ok,
    InvalidArgument,  ///< bad input (non-finite speed, wrong range variances, ...): std::invalid_argument
    OutOfMemory,      ///< std::bad_alloc
    Internal,         ///< any other exception from inside the library (a bug: please report it)
};

const char* to_string(StatusCode code) noexcept;

class Status {
public:
    /// Longer messages are cut to this many bytes less one (the terminating zero).
    static constexpr std::size_t kMessageCapacity = 512;

    Status() noexcept = default;  ///< Ok, empty message
    /// printf-style message; never throws, never allocates.
    [[gnu::format(printf, 2, 3)]] static Status error(StatusCode code, const char* format, ...) noexcept;

    StatusCode code() const noexcept { return code_; }
    bool ok() const noexcept { return code_ == StatusCode::Ok; }
    explicit operator bool() const noexcept { return ok(); }
    const char* message() const noexcept { return message_; }  ///< "" when ok

private:
    StatusCode code_ = StatusCode::Ok;
    char message_[kMessageCapacity] = {};
};

}  // namespace roadpreview
