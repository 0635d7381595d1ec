// irgrid/system.h: what this build and this machine offer (backends, CPU, GPUs).
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

/// The machine as benchmarks name it.
struct MachineInfo {
  std::string cpu_model;     ///< from /proc/cpuinfo
  int hardware_threads = 0;  ///< std::thread::hardware_concurrency()
  int tbb_threads = 0;       ///< threads oneTBB uses in this process
  std::string gpu;           ///< name of the first GPU, empty when none
  /// How the CPU backend walks rays through grids (those that fit its 32-bit gathers):
  /// "avx512" (16 lanes), "avx2" (8 lanes), "single" or "interleaved" (IRGRID_CPU_WALK),
  /// or "scalar" (one ray at a time or interleaved, by the rays' coherence, on CPUs without AVX2).
  std::string cpu_walk;
  /// The Linux kernel's state of Intel's Gather Data Sampling mitigation (CVE-2022-40982), as
  /// /sys/devices/system/cpu/vulnerabilities/gather_data_sampling words it; empty where that
  /// file is missing. Where it begins "Mitigation", gather instructions, on which the SIMD walks
  /// rely, run slower.
  std::string gather_data_sampling;
};
MachineInfo machine_info();

}  // namespace irgrid
