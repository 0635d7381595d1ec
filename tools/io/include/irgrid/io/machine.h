// irgrid/io/machine.h: the machine as benchmarks name it (CPU, threads, GPU, CPU walk).
#pragma once

#include <string>

#include "irgrid/accelerator.h"

namespace irgrid {

/// The machine as benchmarks name it.
struct MachineInfo {
  std::string cpu_model;     ///< from /proc/cpuinfo
  int hardware_threads = 0;  ///< std::thread::hardware_concurrency()
  int tbb_threads = 0;       ///< threads oneTBB uses in this process
  std::string gpu;           ///< name of the first GPU, empty when none
  /// How the CPU backend walks rays through grids with `walk` (cpu_walk_in_use).
  std::string cpu_walk;
  /// The Linux kernel's state of Intel's Gather Data Sampling mitigation (CVE-2022-40982), as
  /// /sys/devices/system/cpu/vulnerabilities/gather_data_sampling words it; empty where that
  /// file is missing. Where it begins "Mitigation", gather instructions, on which the SIMD walks
  /// rely, run slower.
  std::string gather_data_sampling;
};
MachineInfo machine_info(CpuWalk walk = CpuWalk::automatic);

}  // namespace irgrid
