// tools/irgrid/config_json.h: the grid parameters in the JSON that `build` and `bench` write.
#pragma once

#include <string>

#include <nlohmann/json.hpp>

#include "irgrid/accelerator.h"

namespace irgrid::cli {

/// Adds `config` (the grid parameters as given) to a structure's JSON object, and for irregular
/// grids `lambda2_used`, the λ2 its octrees used (docs/bench-json.md).
void add_grid_config_json(nlohmann::json& out, const std::string& structure, const BuildInfo& info,
                          const BuildConfig& grid);

}  // namespace irgrid::cli
