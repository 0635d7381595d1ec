// Process memory from Linux's /proc (process_memory.h).
#include "process_memory.h"

#include <fstream>
#include <sstream>
#include <string>

namespace irgrid::cli {

ProcessMemory process_memory() {
  ProcessMemory memory;
  std::ifstream status("/proc/self/status");
  std::string line;
  while (std::getline(status, line)) {
    std::istringstream fields(line);
    std::string key;
    std::uint64_t kib = 0;
    fields >> key >> kib;
    if (key == "VmRSS:") memory.resident_bytes = kib << 10;
    if (key == "VmHWM:") memory.peak_bytes = kib << 10;
  }
  return memory;
}

bool reset_peak_memory() {
  std::ofstream clear_refs("/proc/self/clear_refs");
  clear_refs << "5";  // 5: reset the peak resident size (Linux >= 4.0)
  clear_refs.flush();
  return bool(clear_refs);
}

std::uint64_t PhaseMemoryRecorder::whole_peak_bytes() const {
  std::uint64_t peak = process_memory().peak_bytes;
  for (const PhaseMemory& p : phases_)
    peak = p.memory.peak_bytes > peak ? p.memory.peak_bytes : peak;
  return peak;
}

}  // namespace irgrid::cli
