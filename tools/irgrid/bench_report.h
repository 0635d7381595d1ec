// tools/irgrid/bench_report.h: the results of `irgrid bench` as a table and as JSON.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "irgrid/accelerator.h"
#include "irgrid/io/rays.h"

namespace irgrid::cli {

/// One view and ray kind, traced `repeat` times after a warm-up.
struct BenchRun {
  std::string kind;
  int view = 0;
  std::uint64_t rays = 0, hits = 0;
  /// The timed trace: on the CPU, Accelerator::trace over host arrays; on CUDA, trace_device
  /// with rays and hits already on the device, timed with events (the kernel alone).
  double median_ms = 0, mrays_per_s = 0;
  /// CUDA only: Accelerator::trace over host arrays, the copies of rays and hits included;
  /// negative elsewhere.
  double host_median_ms = -1, host_mrays_per_s = -1;
  /// --hit-arrays: trace over the caller's arrays as Python's cast_rays makes it (rows of origin
  /// and direction read in place; t, triangle, uv and unit normal written to separate arrays);
  /// negative when not measured.
  double arrays_median_ms = -1, arrays_mrays_per_s = -1;
  std::uint64_t checked = 0, mismatches = 0;
  /// The kinds of mismatch, and the accepted cases, of irgrid::Validation.
  std::uint64_t wrong_triangle = 0, wrong_t = 0, wrong_uv = 0, outside_window = 0, fragile = 0,
                unbounded = 0, unlocated = 0;
  /// Mean cells visited and triangles tested per ray (one counted pass, untimed); negative for
  /// structures that do not count their work.
  double cells_per_ray = -1, tests_per_ray = -1;
};

struct BenchResult {
  std::string scene;
  std::uint64_t triangles = 0;
  std::string structure, backend;
  BuildStats build;                 ///< build_ms is the median over the timed builds
  std::optional<BuildConfig> grid;  ///< the grid parameters, for the grid structures only
  std::vector<BenchRun> runs;
};

/// How `bench` made and timed its rays: the JSON's top-level `settings`, so that a result can
/// be reproduced.
struct BenchSettings {
  RayConfig config;  ///< width, height, spp, random rays and seed of the standard rays
  std::string kinds = "primary,ao,diffuse,random", views, views_file, rays_file;
  int repeat = 5;
  int build_repeat = -1;  ///< timed builds; below 0: as many as `repeat`
  std::uint64_t validate = 10000;
  bool exact = false;       ///< validate against the exact oracle instead of the double reference
  bool hit_arrays = false;  ///< also time the trace into separate arrays (BenchRun::arrays_*)
};

/// The machine as bench's JSON names it (CPU, threads, CPU walk, GPU).
nlohmann::json machine_json();

/// Writes `json` to `path`; throws Error{io} naming the path when that fails.
void write_json_file(const nlohmann::json& json, const std::string& path);

/// A table for people on stdout.
void print_bench_table(const BenchResult& result);

/// The kinds of mismatch per run, when any run was validated (print_bench_table calls it).
void print_validation_table(const BenchResult& result);

/// MRays/s of every structure side by side, with the ratio of each to the first.
void print_comparison(const std::vector<BenchResult>& results);

/// The stable JSON of docs/bench-json.md: the first result at the top level, and all of them
/// under "compare" when there are several.
void write_bench_json(const std::vector<BenchResult>& results, const std::string& scene_file,
                      const BenchSettings& settings, const std::string& path);

}  // namespace irgrid::cli
