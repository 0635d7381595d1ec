// python/src/result_memory.h: memory for the numpy arrays that cast_rays and its kin return.
#pragma once

#include <cstddef>

namespace irgrid::python {

/// `bytes` of memory for a result array, freed with release_result_memory(p, bytes).
///
/// Large blocks (2 MiB or more) are 2 MiB-aligned huge-page candidates, and freed ones are kept
/// (up to kResultCacheBytes in all, the oldest given back first) for the next call of the same
/// size: a loop of cast_rays over batches of equal size then writes into memory whose pages
/// are already mapped. Fresh pages cost the kernel a zeroing pass and a fault each, about 5% of
/// a trace of 1M random rays on Sponza. Thread-safe.
void* acquire_result_memory(std::size_t bytes);
void release_result_memory(void* pointer, std::size_t bytes) noexcept;

/// What the cache may hold (freed blocks only; arrays alive are not counted).
inline constexpr std::size_t kResultCacheBytes = std::size_t(256) << 20;

}  // namespace irgrid::python
