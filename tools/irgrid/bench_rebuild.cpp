// `irgrid bench --rebuild N`: rebuild times over an animation, validated (bench_rebuild.h).
#include "bench_rebuild.h"

#include <algorithm>
#include <chrono>

#include <fmt/format.h>

#include "common.h"
#include "irgrid/io/animation.h"
#include "irgrid/io/rays.h"
#include "irgrid/io/validate.h"
#include "progress.h"

namespace irgrid::cli {
namespace {

double median_of(std::vector<double> values) {
  if (values.empty()) return 0;
  std::sort(values.begin(), values.end());
  const std::size_t n = values.size();
  return n % 2 ? values[n / 2] : 0.5 * (values[n / 2 - 1] + values[n / 2]);
}

}  // namespace

std::vector<RebuildResult> bench_rebuilds(
    const Scene& scene, const std::vector<std::pair<Structure, AcceleratorOptions>>& contenders,
    int frames, const Camera& camera, int width, int height, std::uint64_t validate) {
  Scene frame_scene = scene;  // the animated vertices, same triangles
  std::vector<RebuildResult> results;
  for (const auto& [structure, options] : contenders) {
    auto accelerator = make_structure(scene, structure, options);
    RebuildResult result{to_string(structure),
                         to_string(accelerator->backend()),
                         accelerator->build_stats().build_ms,
                         {},
                         0,
                         0};
    Progress progress(fmt::format("rebuilding {} ({} frames)", result.structure, frames),
                      std::uint64_t(frames));
    for (int frame = 1; frame <= frames; ++frame) {
      animate_vertices(scene, frame, frames + 1, frame_scene.vertices);
      const auto start = std::chrono::steady_clock::now();
      accelerator->rebuild(frame_scene.mesh());
      result.frame_ms.push_back(milliseconds_since(start));
      progress.advance(1);
    }
    progress.done();
    if (validate > 0) {
      const auto rays = primary_rays(camera, width, height);
      std::vector<Hit> hits(rays.size());
      accelerator->trace(rays, hits, Query::closest);
      const auto validation = validate_hits(frame_scene, rays, hits, Query::closest, validate);
      result.checked = validation.checked;
      result.mismatches = validation.mismatches;
      for (const auto& example : validation.examples)
        fmt::print(stderr, "mismatch ({} after frame {}): {}\n", result.structure, frames, example);
    }
    results.push_back(std::move(result));
  }
  return results;
}

void print_rebuild_table(const Scene& scene, const std::vector<RebuildResult>& results) {
  fmt::print("rebuilds of {} ({} triangles), twisting and rippling over {} frames (ms):\n",
             scene.name, scene.triangle_count(), results.front().frame_ms.size());
  fmt::print("{:>6}", "frame");
  for (const auto& r : results)
    fmt::print(" {:>20}", r.structure + "@" + r.backend);
  fmt::print("\n{:>6}", "build");
  for (const auto& r : results)
    fmt::print(" {:>20.2f}", r.first_build_ms);
  for (std::size_t f = 0; f < results.front().frame_ms.size(); ++f) {
    fmt::print("\n{:>6}", f + 1);
    for (const auto& r : results)
      fmt::print(" {:>20.2f}", r.frame_ms[f]);
  }
  const double first = median_of(results.front().frame_ms);
  fmt::print("\n{:>6}", "median");
  for (const auto& r : results) {
    const double m = median_of(r.frame_ms);
    fmt::print(" {:>12.2f} ({:4.2f}x)", m, first > 0 ? m / first : 0.0);
  }
  fmt::print("\n{:>6}", "valid");
  for (const auto& r : results)
    fmt::print(" {:>20}", fmt::format("{}/{} ok", r.checked - r.mismatches, r.checked));
  fmt::print("\n");
}

nlohmann::json rebuild_json(const std::vector<RebuildResult>& results, int frames) {
  nlohmann::json out = {{"frames", frames}, {"structures", nlohmann::json::array()}};
  for (const auto& r : results)
    out["structures"].push_back({{"structure", r.structure},
                                 {"backend", r.backend},
                                 {"first_build_ms", r.first_build_ms},
                                 {"frame_ms", r.frame_ms},
                                 {"median_ms", median_of(r.frame_ms)},
                                 {"checked", r.checked},
                                 {"mismatches", r.mismatches}});
  return out;
}

}  // namespace irgrid::cli
