// A small cache of freed result arrays (result_memory.h).
#include "result_memory.h"

#include <deque>
#include <mutex>
#include <new>
#include <utility>

#if defined(__linux__)
#include <sys/mman.h>
#endif

namespace irgrid::python {
namespace {

constexpr std::size_t kLargeBytes = std::size_t(2) << 20;

struct Block {
  void* pointer;
  std::size_t bytes;
};

/// Freed large blocks, oldest first.
struct Cache {
  std::mutex mutex;
  std::deque<Block> blocks;
  std::size_t bytes = 0;
};

Cache& cache() {
  static Cache* instance = new Cache;  // never destroyed: arrays may outlive static destruction
  return *instance;
}

void free_large(void* pointer) noexcept {
  ::operator delete(pointer, std::align_val_t(kLargeBytes));
}

}  // namespace

void* acquire_result_memory(std::size_t bytes) {
  if (bytes == 0) bytes = 1;
  if (bytes < kLargeBytes) return ::operator new(bytes);
  {
    Cache& c = cache();
    const std::lock_guard lock(c.mutex);
    for (auto it = c.blocks.rbegin(); it != c.blocks.rend(); ++it)
      if (it->bytes == bytes) {
        void* pointer = it->pointer;
        c.bytes -= bytes;
        c.blocks.erase(std::next(it).base());
        return pointer;
      }
  }
  void* pointer = ::operator new(bytes, std::align_val_t(kLargeBytes));
#if defined(__linux__) && defined(MADV_HUGEPAGE)
  madvise(pointer, (bytes + kLargeBytes - 1) & ~(kLargeBytes - 1), MADV_HUGEPAGE);
#endif
  return pointer;
}

void release_result_memory(void* pointer, std::size_t bytes) noexcept {
  if (bytes == 0) bytes = 1;
  if (bytes < kLargeBytes) return ::operator delete(pointer);
  if (bytes > kResultCacheBytes) return free_large(pointer);
  Cache& c = cache();
  const std::lock_guard lock(c.mutex);
  while (!c.blocks.empty() && c.bytes + bytes > kResultCacheBytes) {
    free_large(c.blocks.front().pointer);
    c.bytes -= c.blocks.front().bytes;
    c.blocks.pop_front();
  }
  try {
    c.blocks.push_back({pointer, bytes});
    c.bytes += bytes;
  } catch (...) {
    free_large(pointer);
  }
}

}  // namespace irgrid::python
