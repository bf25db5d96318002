// SPDX-License-Identifier: BSD-3-Clause
// The output line's profile and roughness objects (docs/output.md), for other outputs that share the schema.
#pragma once

#include <nlohmann/json.hpp>

#include "roadpreview/profile/profile.hpp"

namespace roadpreview::detail {

nlohmann::ordered_json profile_to_json(const Profile& p);
nlohmann::ordered_json roughness_to_json(const Roughness& r);

}  // namespace roadpreview::detail
