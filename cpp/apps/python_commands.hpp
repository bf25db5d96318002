// SPDX-License-Identifier: BSD-3-Clause
// Commands that live in the Python package (`roadpreview-drives`): `roadpreview batch ...`, and `run` / `info`
// of ROS bags and MCAP files or with --topic / --motion-from. The C++ CLI hands them over unchanged.
#pragma once

#include <optional>

/// When argv names a Python command, replaces this process with `roadpreview-drives` (beside this executable,
/// else on PATH) and returns only when that fails (the exit status to return); std::nullopt otherwise.
std::optional<int> delegate_to_python(int argc, char** argv);
