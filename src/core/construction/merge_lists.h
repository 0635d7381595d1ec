// core/construction/merge_lists.h: sorted unions of two cells' reference lists, for cell merging.
//
// Pérard-Gayot et al. 2017, §3.2: the cost of a merged cell needs |R(A ∪ B)|, the number of
// distinct triangles of both cells, and the merged cell needs that list. Both lists are sorted
// ascending and free of duplicates (cells.h guarantees it, and merging keeps it), so one
// two-pointer walk gives either, in O(|A| + |B|) and without scratch memory; one device thread
// runs one walk.
#pragma once

#include <cstdint>

#include "irgrid/kernel/platform.h"

namespace irgrid {

/// Number of distinct values in a[0, na) ∪ b[0, nb).
/// Requires: both ranges sorted strictly ascending.
IRGRID_HD inline std::uint32_t sorted_union_size(const std::uint32_t* a, std::uint32_t na,
                                                 const std::uint32_t* b, std::uint32_t nb) {
  std::uint32_t i = 0, j = 0, shared = 0;
  while (i < na && j < nb) {
    const std::uint32_t x = a[i], y = b[j];
    shared += x == y;
    i += x <= y;
    j += y <= x;
  }
  return na + nb - shared;
}

/// Writes a[0, na) ∪ b[0, nb) to out, sorted strictly ascending, and returns how many values it
/// wrote (sorted_union_size of the same lists).
/// Requires: both ranges sorted strictly ascending; out has room for that many values and
/// overlaps neither input.
IRGRID_HD inline std::uint32_t write_sorted_union(const std::uint32_t* a, std::uint32_t na,
                                                  const std::uint32_t* b, std::uint32_t nb,
                                                  std::uint32_t* out) {
  std::uint32_t i = 0, j = 0, k = 0;
  while (i < na && j < nb) {
    const std::uint32_t x = a[i], y = b[j];
    out[k++] = x <= y ? x : y;
    i += x <= y;
    j += y <= x;
  }
  while (i < na)
    out[k++] = a[i++];
  while (j < nb)
    out[k++] = b[j++];
  return k;
}

/// Copies in[0, n) to out.
IRGRID_HD inline void copy_list(const std::uint32_t* in, std::uint32_t n, std::uint32_t* out) {
  for (std::uint32_t i = 0; i < n; ++i)
    out[i] = in[i];
}

}  // namespace irgrid
