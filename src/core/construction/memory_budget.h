// core/construction/memory_budget.h: the build's memory check, made before the memory is taken.
#pragma once

#include <cstdint>
#include <string>

#include "irgrid/build_config.h"
#include "irgrid/error.h"
#include "irgrid/kernel/grid_layout.h"

namespace irgrid {

/// MiB, rounded up, for messages.
inline std::string mebibytes_text(std::uint64_t bytes) {
  return std::to_string((bytes >> 20) + ((bytes & ((1u << 20) - 1)) != 0)) + " MiB";
}

/// Throws Error{out_of_memory} when `bytes` (what `what()` names would allocate) exceed
/// `budget`, the memory the build may still take (Exec::memory_budget(); 0: unknown, no check).
/// `advice` says which parameter to change. `what` is called only for the message: the octrees
/// check often, and fail rarely.
template <typename What>
void check_memory_budget(std::uint64_t budget, std::uint64_t bytes, What&& what,
                         const char* advice) {
  if (budget != 0 && bytes > budget)
    throw Error(ErrorCode::out_of_memory, what() + " would need about " + mebibytes_text(bytes) +
                                              ", more than the " + std::to_string(budget >> 20) +
                                              " MiB of memory available (" + advice + ")");
}

/// The construction budget in bytes (BuildConfig::memory_budget): the configured one, or the
/// automatic one for `triangles`, capped at half of `machine_bytes` (Exec::memory_budget(), the
/// memory the build may still take; 0: unknown, no cap).
inline std::uint64_t construction_budget(const BuildConfig& config, std::uint64_t triangles,
                                         std::uint64_t machine_bytes) {
  std::uint64_t budget = config.memory_budget != 0
                             ? config.memory_budget
                             : kBudgetBaseBytes + kBudgetBytesPerTriangle * triangles;
  if (machine_bytes != 0 && budget > machine_bytes / 2) budget = machine_bytes / 2;
  return budget;
}

/// Bytes an initial grid of `entries` map entries, `cells` cells and `refs` references holds at
/// the build's peak: about 3 times its arrays (the octrees' own buffers and the grid's arrays
/// they become, then the old and the new arrays of a merge sweep).
inline std::uint64_t octree_peak_bytes(std::uint64_t entries, std::uint64_t cells,
                                       std::uint64_t refs) {
  return 3 * (entries * sizeof(Entry) + cells * sizeof(Cell) + refs * sizeof(std::uint32_t));
}

/// Whether such an initial grid fits `budget` (construction_budget) and the 30-bit limits of
/// the map and the reference ranges. Both octree builds test the same counts (those of the
/// octrees cut after some level), so they stop at the same level.
inline bool octree_fits_budget(std::uint64_t budget, std::uint64_t entries, std::uint64_t cells,
                               std::uint64_t refs) {
  return entries <= kMaxEntryTarget && refs <= kMaxEntryTarget &&
         octree_peak_bytes(entries, cells, refs) <= budget;
}

/// Bytes of the top-level (top cell, triangle) pairs: 8 each, and as much again while the
/// octrees sort them into top cells.
inline std::uint64_t top_level_pair_bytes(std::uint64_t pairs) {
  return 16 * pairs;
}

}  // namespace irgrid
