// tools/irgrid/bench_rebuild.h: `irgrid bench --rebuild N`: per-frame rebuild times of an
// animated scene, structure beside structure, each rebuilt grid validated before it counts.
#pragma once

#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

#include "irgrid/accelerator.h"
#include "irgrid/io/camera.h"
#include "irgrid/io/scene.h"

namespace irgrid::cli {

/// One structure rebuilt over every frame.
struct RebuildResult {
  std::string structure, backend;
  double first_build_ms = 0;
  std::vector<double> frame_ms;               ///< wall time of each rebuild call, frames 1..N
  std::uint64_t checked = 0, mismatches = 0;  ///< primary rays of the last frame vs the reference
};

/// Builds each (structure, options) over the rest pose, then rebuilds it over frames 1..frames
/// of animate_vertices; after the last frame traces width x height primary rays from `camera`
/// and validates `validate` of them against the double reference of that frame.
std::vector<RebuildResult> bench_rebuilds(
    const Scene& scene, const std::vector<std::pair<Structure, AcceleratorOptions>>& contenders,
    int frames, const Camera& camera, int width, int height, std::uint64_t validate);

/// Per-frame times side by side, then the median of each and its ratio to the first.
void print_rebuild_table(const Scene& scene, const std::vector<RebuildResult>& results);

/// The "rebuild" object of bench's JSON (docs/bench-json.md).
nlohmann::json rebuild_json(const std::vector<RebuildResult>& results, int frames);

}  // namespace irgrid::cli
