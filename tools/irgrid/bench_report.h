// tools/irgrid/bench_report.h: the results of `irgrid bench` as a table and as JSON.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "irgrid/accelerator.h"

namespace irgrid::cli {

/// One view and ray kind, traced `repeat` times after a warm-up.
struct BenchRun {
  std::string kind;
  int view = 0;
  std::uint64_t rays = 0, hits = 0;
  double median_ms = 0, mrays_per_s = 0;
  std::uint64_t checked = 0, mismatches = 0;
  /// Mean cells visited and triangles tested per ray (one counted pass, untimed); negative for
  /// structures that do not count their work.
  double cells_per_ray = -1, tests_per_ray = -1;
};

struct BenchResult {
  std::string scene;
  std::uint64_t triangles = 0;
  std::string structure, backend;
  BuildInfo build;  ///< build_ms is the median over the timed builds
  std::vector<BenchRun> runs;
};

/// A table for people on stdout.
void print_bench_table(const BenchResult& result);

/// MRays/s of every structure side by side, with the ratio of each to the first.
void print_comparison(const std::vector<BenchResult>& results);

/// The stable JSON of docs/bench-json.md: the first result at the top level, and all of them
/// under "compare" when there are several.
void write_bench_json(const std::vector<BenchResult>& results, const std::string& scene_file,
                      const std::string& path);

}  // namespace irgrid::cli
