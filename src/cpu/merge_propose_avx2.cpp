// cpu/merge_propose_avx2.cpp: a merge sweep's proposals (cpu/merge_propose.h) in the 8 lanes of
// AVX2. Only the code below the pragma is compiled for avx2, and it runs only where cpu_has() says
// the CPU has it; the headers it uses are included above the pragma, so that their inline
// functions stay baseline code.
#include <immintrin.h>

#include <cmath>
#include <cstddef>
#include <cstdint>

#include "core/construction/merge_lists.h"
#include "core/construction/merge_pairs.h"
#include "core/construction/narrow_cell.h"
#include "cpu/merge_propose.h"
#include "irgrid/kernel/grid_layout.h"

#pragma GCC push_options
#pragma GCC target("avx2")
#pragma GCC diagnostic ignored "-Wpsabi"

#include "cpu/merge_propose_lanes.h"
#include "cpu/simd_lanes_avx2.h"

namespace irgrid {

template <>
void propose_merges_with<SimdIsa::avx2>(const merge_detail::ProposeInputs& in, std::uint32_t first,
                                        std::uint32_t count) {
  simd::ProposeLanes<simd::Avx2Lanes>::propose(in, first, count);
}

}  // namespace irgrid

#pragma GCC pop_options
