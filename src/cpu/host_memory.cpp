// How much host memory a build may still take: the system's and the cgroup's view (a container's
// limit is often far below the machine's memory, and going past it gets the process killed).
#include "cpu/host_memory.h"

#include <algorithm>
#include <fstream>
#include <limits>
#include <sstream>
#include <string>

#if defined(__linux__)
#include <unistd.h>
#endif

namespace irgrid {
namespace {

constexpr std::uint64_t kUnknown = std::numeric_limits<std::uint64_t>::max();

/// The first number in `path` (a cgroup file), kUnknown when missing or "max".
std::uint64_t number_in(const char* path) {
  std::ifstream file(path);
  std::uint64_t value = 0;
  if (!(file >> value)) return kUnknown;
  return value;
}

/// limit - usage of one cgroup version's pair of files, kUnknown without a limit.
std::uint64_t cgroup_room(const char* limit_path, const char* usage_path) {
  const std::uint64_t limit = number_in(limit_path);
  // cgroup v1 reports "no limit" as a huge number near 2^63.
  if (limit == kUnknown || limit >= (std::uint64_t(1) << 62)) return kUnknown;
  const std::uint64_t usage = number_in(usage_path);
  if (usage == kUnknown) return limit;
  return usage < limit ? limit - usage : 0;
}

std::uint64_t mem_available() {
  std::ifstream meminfo("/proc/meminfo");
  std::string line;
  while (std::getline(meminfo, line)) {
    if (line.rfind("MemAvailable:", 0) != 0) continue;
    std::istringstream fields(line.substr(13));
    std::uint64_t kib = 0;
    if (fields >> kib) return kib * 1024;
  }
  return kUnknown;
}

}  // namespace

std::uint64_t host_memory_available() {
  std::uint64_t bytes = kUnknown;
#if defined(__linux__)
  const long pages = sysconf(_SC_PHYS_PAGES), page_size = sysconf(_SC_PAGE_SIZE);
  if (pages > 0 && page_size > 0) bytes = std::uint64_t(pages) * std::uint64_t(page_size);
  bytes = std::min(bytes, mem_available());
  bytes =
      std::min(bytes, cgroup_room("/sys/fs/cgroup/memory.max", "/sys/fs/cgroup/memory.current"));
  bytes = std::min(bytes, cgroup_room("/sys/fs/cgroup/memory/memory.limit_in_bytes",
                                      "/sys/fs/cgroup/memory/memory.usage_in_bytes"));
#endif
  return bytes == kUnknown ? 0 : bytes;
}

}  // namespace irgrid
