// irgrid/build_config.h: the parameters of the irregular grid's construction.
#pragma once

#include <cstdint>

namespace irgrid {

/// Construction parameters (Pérard-Gayot et al. 2017, §3-§5; defaults of ../shared/design).
/// Denser settings build slower and trace faster.
struct BuildConfig {
  /// Top-level density λ1: about λ1 x triangles top cells (Cleary et al. 1983). > 0.
  float lambda1 = 0.12f;
  /// Second-level density λ2: the octree depth of each top cell follows λ2 x its references. >= 0.
  float lambda2 = 2.4f;
  /// Our rule for small scenes, not the paper's: λ2 aims the octrees at λ2 x (top-level
  /// references) cells in all; where that is fewer than min_cells, λ2 is raised until it is
  /// min_cells (effective_lambda2). A grid of that size builds in milliseconds, and its finer
  /// cells trace small scenes up to 2.3 times as fast (docs/benchmarks.md). 0: the paper's λ2.
  unsigned min_cells = 32768;
  /// An octree node holding more than this many references splits further than its top cell's
  /// λ2 depth, down to the finest depth at which cells still compress to 16 bytes, while the
  /// split separates its triangles (its children hold at most 2 x its references). The
  /// paper's one depth per top cell leaves a small dense object beside large triangles (a
  /// teapot in a stadium) with hundreds of triangles per cell. 0 disables it (the paper's rule).
  unsigned split_refs = 64;
  /// Merging stops when a sweep keeps at least alpha x the cells; <= 0 (or NaN) disables
  /// merging.
  float alpha = 0.995f;
  /// Cost of a traversal step in triangle tests (the SAH's C_t / C_i) for merging. >= 0.
  float cost_ratio = 1.0f;
  /// Two empty cells merge only while the result's length along the merge axis stays within
  /// this many times its thinnest side, so empty space stays in block-like cells instead of the
  /// long slabs the SAH alone makes (Crown: 20 → 13 cells per primary ray). 0: no bound (the
  /// paper); otherwise >= 1.
  float empty_aspect = 4.0f;
  /// Exit-box expansion passes (3 for static scenes, 1 for dynamic ones, 0 disables).
  int expansion_passes = 3;
  /// Let a cell grow part-way into a neighbour holding extra triangles.
  bool partial_expansion = true;
  /// Rays in empty space leap across the cube of empty top cells ahead of them (the chessboard
  /// distance to the nearest top cell with triangles in the ray's octant, 8 bytes per top cell),
  /// not just across their cell. Irregular grids only: the baselines stay as published.
  bool skip_empty = true;
  /// 16-byte cells when the virtual grid fits 16 bits per axis.
  bool compress = true;
  /// CPU on Linux: move the finished grid's arrays onto huge pages at the end of the build, so
  /// that incoherent rays miss the TLB less. The move copies the arrays into fresh huge pages,
  /// which some VMs give slowly (seconds for a large grid: docs/benchmarks.md, "huge pages: what
  /// the move costs"). Off: a one-off build that traces few rays is done sooner. The grid and its
  /// hits are the same either way; the CUDA backend ignores it.
  bool huge_pages = true;
  /// Bytes the construction may spend on the grid's cells, map entries and references, as
  /// counted at the build's peak (about 3 times the final arrays). A build that would pass it
  /// degrades instead of failing: first a coarser top grid (λ1 divided by 8 until its
  /// references fit), then octrees cut at the last level that fits; GridStats::budget_limited
  /// reports it. 0: automatic, kBudgetBytesPerTriangle x triangles + kBudgetBaseBytes, at most
  /// half the host memory available to a CPU build (docs/robustness.md).
  std::uint64_t memory_budget = 0;
  /// Baselines built from the same phases: split every top cell fully to its depth (two-level
  /// grid, Kalojanov et al. 2011) or not at all (uniform grid); merging and expansion off.
  enum class Shape { irregular, two_level, uniform } shape = Shape::irregular;

  friend bool operator==(const BuildConfig&, const BuildConfig&) = default;
};

/// The automatic BuildConfig::memory_budget: this many bytes per triangle, ...
inline constexpr std::uint64_t kBudgetBytesPerTriangle = 1024;
/// ... plus this many, so that small scenes keep the fine grids of BuildConfig::min_cells.
inline constexpr std::uint64_t kBudgetBaseBytes = std::uint64_t(96) << 20;

/// The λ2 the octrees use over `top_level_refs` references: config.lambda2, raised to
/// config.min_cells / top_level_refs where that is larger (BuildConfig::min_cells).
inline double effective_lambda2(const BuildConfig& config, std::uint64_t top_level_refs) {
  const double lambda2 = config.lambda2;
  if (top_level_refs == 0 || lambda2 * double(top_level_refs) >= double(config.min_cells))
    return lambda2;
  return double(config.min_cells) / double(top_level_refs);
}

}  // namespace irgrid
