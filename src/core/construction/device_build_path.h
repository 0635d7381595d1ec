// core/construction/device_build_path.h: how the build's templates run on a device executor.
//
// The construction phases are templates over an executor, and a few of them choose between two
// ways of doing the same work (the CPU's and the GPU's) by the executor's flags. CudaExecutor
// takes its flags from here, and tests/test_device_build_path.cpp runs the whole build with these
// same flags on the CPU, so the GPU's template path is checked against the CPU's grid bit for bit
// even where no GPU is present.
#pragma once

#include <cstdint>

namespace irgrid {

/// The flags of the build's device path (see CpuExecutor for what each one chooses). A member
/// added here must be added to the executor of tests/test_device_build_path.cpp as well.
struct DeviceBuildPath {
  /// One cell per thread: warps hide the latency of voxel-map walks (CpuExecutor::kLookupBatch).
  static constexpr std::uint32_t kLookupBatch = 1;

  /// Octrees level by level: a few wide passes per level (CpuExecutor::kDepthFirstOctrees).
  static constexpr bool kDepthFirstOctrees = false;
  /// Masks one (node, triangle) pair per thread (CpuExecutor::kOctreeMasksInLanes).
  static constexpr bool kOctreeMasksInLanes = false;
  /// Triangle planes one triangle per thread (CpuExecutor::kTrianglePlanesInLanes).
  static constexpr bool kTrianglePlanesInLanes = false;
  /// Proposals one cell per thread (CpuExecutor::kProposesInLanes; the lanes' calls sit in
  /// branches this flag discards).
  static constexpr bool kProposesInLanes = false;

  /// Merge chains by pointer jumping: a serial walk of a long chain would hold up its warp
  /// (CpuExecutor::kSerialMergeChains).
  static constexpr bool kSerialMergeChains = false;

  /// Merged cells go to new arrays (CpuExecutor::kCompactsInPlace).
  static constexpr bool kCompactsInPlace = false;

  /// No host-memory estimate for the build (CpuExecutor::memory_budget): the build's arrays
  /// live on the device, whose allocations fail with an error when it is full.
  static std::uint64_t memory_budget() { return 0; }
};

}  // namespace irgrid
