// cpu/host_memory.h: how much host memory a build may still take.
#pragma once

#include <cstdint>

namespace irgrid {

/// Bytes of host memory this process may still allocate, 0 when unknown: the smallest of the
/// system's available memory (MemAvailable), the room left under the process's cgroup limit
/// as /sys/fs/cgroup shows it (v2 memory.max, or v1 memory.limit_in_bytes; inside a container,
/// the container's own) and the physical memory. Read anew each call.
std::uint64_t host_memory_available();

}  // namespace irgrid
