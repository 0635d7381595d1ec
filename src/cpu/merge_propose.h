// cpu/merge_propose.h: a merge sweep's proposals, many cells at once.
//
// propose_merges (core/construction/merge_pairs.h) asks of every cell whether it merges with the
// owner of the voxel past its upper face: a walk down the voxel map, the partner's box and a
// surface-area comparison, then the size of the two lists' union where the comparison leaves it
// open. Here one lane holds one cell (16 with AVX-512, 8 with AVX2): the map's levels are read
// with gathers for all lanes together, the checks are lane-wise, and only the lanes that pass
// them count their lists' union, the shorter list held in lanes and compared against each value
// of the other. Every lane repeats the scalar proposal's operations, so the proposals and union
// sizes are the same (tests/test_grid_merge.cpp, GridMergeLanes, and the grids' fingerprints).
#pragma once

#include <cstdint>

#include "cpu/simd_walk.h"

namespace irgrid {

struct GridInfo;
namespace merge_detail {
struct ProposeInputs;
}

/// Whether propose_merges_in_lanes runs on this CPU for this grid: the CPU has AVX2 and the
/// cells' 4-byte words fit 32-bit gather indices.
bool proposes_in_lanes(const GridInfo& info);

/// The proposals of narrow cells [first, first + count) (propose_merges' batch body, the same
/// writes), in the widest lanes this CPU runs. Requires proposes_in_lanes(in.info).
void propose_merges_in_lanes(const merge_detail::ProposeInputs& in, std::uint32_t first,
                             std::uint32_t count);

/// propose_merges_in_lanes in the lanes of kIsa. Requires cpu_has(kIsa).
template <SimdIsa kIsa>
void propose_merges_with(const merge_detail::ProposeInputs& in, std::uint32_t first,
                         std::uint32_t count);

}  // namespace irgrid
