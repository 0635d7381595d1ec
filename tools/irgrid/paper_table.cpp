// The paper's table (Pérard-Gayot, Kalojanov, Slusallek, "GPU Ray Tracing using Irregular Grids",
// Eurographics 2017, Table 1) beside this run's figures.
#include "paper_table.h"

#include <array>
#include <string>

#include <fmt/format.h>

namespace irgrid::cli {
namespace {

/// One scene of the paper's Table 1, measured on a 2017 GPU (GTX 1080 Ti class): MRays/s for
/// primary, ao and random rays with the SBVH and the irregular grid, and the grid's build time.
struct PaperScene {
  const char* scene;  ///< irgrid's scene name (the shared scenes' folder)
  const char* name;
  const char* triangles;
  double grid_build_ms;
  std::array<double, 3> sbvh, grid;
};

constexpr std::array kPaperScenes = {
    PaperScene{"crytek-sponza", "Sponza", "262K", 26, {409, 270, 166}, {653, 386, 274}},
    PaperScene{"conference", "Conference", "283K", 22, {583, 303, 295}, {597, 332, 312}},
    PaperScene{"crown", "Crown", "3.5M", 203, {232, 108, 221}, {296, 120, 238}}};

constexpr std::array<const char*, 3> kKinds = {"primary", "ao", "random"};

/// MRays/s of `result`'s run of `kind` on `view`, or negative when it has none.
double mrays(const BenchResult& result, const char* kind, int view) {
  for (const auto& run : result.runs)
    if (run.kind == kind && run.view == view) return run.mrays_per_s;
  return -1;
}

std::string cell(double value, const char* format = "{:.1f}") {
  return value < 0 ? std::string("-") : fmt::format(fmt::runtime(format), value);
}

}  // namespace

void print_paper_table(const std::vector<BenchResult>& results) {
  if (results.empty()) return;
  const BenchResult& first = results.front();
  std::vector<int> views;
  for (const auto& run : first.runs)
    if (views.empty() || views.back() != run.view) views.push_back(run.view);
  fmt::print(
      "\n| scene | view | triangles | structure | build ms | memory MiB | primary | ao | "
      "random |\n| --- | --- | ---: | --- | ---: | ---: | ---: | ---: | ---: |\n");
  for (const int view : views) {
    for (const auto& r : results) {
      fmt::print("| {} | {} | {} | {}@{} | {:.1f} | {:.1f} |", r.scene, view, r.triangles,
                 r.structure, r.backend, r.build.build_ms, r.build.memory_bytes / 1048576.0);
      for (const char* kind : kKinds)
        fmt::print(" {} |", cell(mrays(r, kind, view)));
      fmt::print("\n");
    }
    for (std::size_t k = 1; k < results.size(); ++k) {
      const auto& other = results[k];
      fmt::print("| {} | {} | | {}@{} / {}@{} | {} | {} |", first.scene, view, first.structure,
                 first.backend, other.structure, other.backend,
                 cell(other.build.build_ms > 0 ? first.build.build_ms / other.build.build_ms : -1,
                      "{:.2f}×"),
                 cell(other.build.memory_bytes > 0
                          ? double(first.build.memory_bytes) / double(other.build.memory_bytes)
                          : -1,
                      "{:.2f}×"));
      for (const char* kind : kKinds) {
        const double a = mrays(first, kind, view), b = mrays(other, kind, view);
        fmt::print(" {} |", cell(a >= 0 && b > 0 ? a / b : -1, "{:.2f}×"));
      }
      fmt::print("\n");
    }
  }
  for (const auto& paper : kPaperScenes) {
    if (first.scene != paper.scene) continue;
    fmt::print("| {} (paper, 2017 GPU) | | {} | SBVH | - | - | {:.0f} | {:.0f} | {:.0f} |\n",
               paper.name, paper.triangles, paper.sbvh[0], paper.sbvh[1], paper.sbvh[2]);
    fmt::print(
        "| {} (paper, 2017 GPU) | | {} | irregular grid | {:.0f} | ≈ SBVH | {:.0f} | {:.0f} | "
        "{:.0f} |\n",
        paper.name, paper.triangles, paper.grid_build_ms, paper.grid[0], paper.grid[1],
        paper.grid[2]);
    fmt::print("| {} (paper, 2017 GPU) | | | grid / SBVH | | | {:.2f}× | {:.2f}× | {:.2f}× |\n",
               paper.name, paper.grid[0] / paper.sbvh[0], paper.grid[1] / paper.sbvh[1],
               paper.grid[2] / paper.sbvh[2]);
  }
}

}  // namespace irgrid::cli
