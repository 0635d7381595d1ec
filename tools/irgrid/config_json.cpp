// The grid parameters in the JSON of `build` and `bench` (docs/bench-json.md).
#include "config_json.h"

#include "irgrid/build_config.h"

namespace irgrid::cli {

void add_grid_config_json(nlohmann::json& out, const std::string& structure, const BuildInfo& info,
                          const BuildConfig& grid) {
  out["config"] = {{"lambda1", grid.lambda1},
                   {"lambda2", grid.lambda2},
                   {"min_cells", grid.min_cells},
                   {"split_refs", grid.split_refs},
                   {"alpha", grid.alpha},
                   {"cost_ratio", grid.cost_ratio},
                   {"empty_aspect", grid.empty_aspect},
                   {"expansion_passes", grid.expansion_passes},
                   {"partial_expansion", grid.partial_expansion},
                   {"skip_empty", grid.skip_empty},
                   {"compress", grid.compress}};
  const auto refs = info.counts.find("top_level_references");
  if (structure == "irregular" && refs != info.counts.end())
    out["lambda2_used"] = effective_lambda2(grid, refs->second);
}

}  // namespace irgrid::cli
