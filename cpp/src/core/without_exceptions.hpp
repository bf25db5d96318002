// SPDX-License-Identifier: BSD-3-Clause
// Internal: the error path of the library's noexcept entry points (try_process, check_config).
#pragma once

#include <exception>
#include <new>
#include <stdexcept>

#include "roadpreview/core/status.hpp"

namespace roadpreview {

/// Runs `step`, turning what it throws into a Status: std::invalid_argument → InvalidArgument, std::bad_alloc →
/// OutOfMemory, anything else → Internal; each with its text.
template <class Step>
Status without_exceptions(Step&& step) noexcept {
    try {
        step();
        return {};
    } catch (const std::invalid_argument& e) {
        return Status::error(StatusCode::InvalidArgument, "%s", e.what());
    } catch (const std::bad_alloc& e) {
        return Status::error(StatusCode::OutOfMemory, "%s", e.what());
    } catch (const std::exception& e) {
        return Status::error(StatusCode::Internal, "%s", e.what());
    } catch (...) {
        return Status::error(StatusCode::Internal, "unknown exception");
    }
}

}  // namespace roadpreview
