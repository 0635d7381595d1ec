// core/construction/memory_budget.h: the build's memory check, made before the memory is taken.
#pragma once

#include <cstdint>
#include <string>

#include "irgrid/error.h"

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

}  // namespace irgrid
