// core/release_buffer.h: gives a buffer's memory back at once, on every executor.
#pragma once

namespace irgrid {

/// Frees `buffer`'s memory now (back to the executor's pool, or to the system), leaving it
/// empty. `buffer = {}` does not do that for the CPU executor's buffers and other std::vectors:
/// the braces pick vector's initializer-list assignment, which empties the vector and keeps its
/// capacity (the CUDA executor's buffers have no such overload, and were freed).
template <typename Buffer>
void release_buffer(Buffer& buffer) {
  buffer = Buffer();
}

}  // namespace irgrid
