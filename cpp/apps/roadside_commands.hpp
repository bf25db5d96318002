// SPDX-License-Identifier: BSD-3-Clause
// `roadpreview roadside run|detect|info|extrinsics`: roadside perception from 2-D laser scanners (and a camera).
#pragma once

#include <functional>

#include <CLI/CLI.hpp>

/// Adds the `roadside` subcommand; returns the action to run when it was parsed (exit status).
std::function<int()> add_roadside_commands(CLI::App& app);
