// irgrid/system.h: what this build offers: its version and the CUDA devices it can use.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

namespace irgrid {

/// irgrid's version, "MAJOR.MINOR.PATCH".
const char* version() noexcept;

/// One visible CUDA device.
struct GpuInfo {
  int index = 0;
  std::string name;
  std::uint64_t memory_bytes = 0;
  std::uint64_t free_bytes = 0;
  int compute_major = 0, compute_minor = 0;
  int multiprocessors = 0;
};

/// The CUDA devices this process can use. `status` says why the list is empty ("CUDA backend
/// not compiled in", "no CUDA device: ...", "driver too old: ...") or names driver and runtime.
struct CudaStatus {
  bool compiled = false;
  std::vector<GpuInfo> gpus;
  std::string status;
};
CudaStatus cuda_status();

}  // namespace irgrid
