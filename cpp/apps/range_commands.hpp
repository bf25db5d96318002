// SPDX-License-Identifier: BSD-3-Clause
// `roadpreview range calibrate-distance|calibrate-offset|run`: point range preview sensors.
#pragma once

#include <functional>

#include <CLI/CLI.hpp>

/// Adds the `range` subcommand; returns the action to run when it was parsed (exit status).
std::function<int()> add_range_commands(CLI::App& app);
