// SPDX-License-Identifier: BSD-3-Clause
// Programs the CLI hands work to: the Python package's `roadpreview-drives` and `roadpreview-video`, each installed
// beside this executable (same venv or prefix), so that the CLI does not load what only they need.
#pragma once

#include <string>
#include <vector>

/// The program `name` beside this executable if it is there, else `name` (found on PATH when run).
std::string program_beside_self(const std::string& name);

/// Runs args[0] with args (stdin, stdout and stderr shared) and returns its exit status (128 + signal when
/// killed). Throws std::runtime_error naming the program when it cannot be started.
int run_program(const std::vector<std::string>& args);
