// cpu/merge_propose.cpp: which lanes a merge sweep's proposals run in. Compiled for the baseline
// target; the lanes live in build_lanes_avx2.cpp and build_lanes_avx512.cpp.
#include "cpu/merge_propose.h"

#include <cstdint>

#include "core/construction/merge_pairs.h"

namespace irgrid {

bool proposes_in_lanes(const GridInfo& info) {
  return cpu_has(SimdIsa::avx2) && std::uint64_t(info.num_cells) * 5 < (std::uint64_t(1) << 31);
}

void propose_merges_in_lanes(const merge_detail::ProposeInputs& in, std::uint32_t first,
                             std::uint32_t count) {
  if (cpu_has(SimdIsa::avx512)) return propose_merges_with<SimdIsa::avx512>(in, first, count);
  propose_merges_with<SimdIsa::avx2>(in, first, count);
}

}  // namespace irgrid
