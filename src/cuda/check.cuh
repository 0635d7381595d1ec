// cuda/check.cuh: every CUDA call and launch is checked; failures become irgrid::Error.
// Host-only declarations: the messages are formatted in device_info.cpp, away from nvcc.
#pragma once

#include <cuda_runtime.h>

#include <cstddef>
#include <string>

#include "irgrid/error.h"

namespace irgrid::cuda {

/// Throws Error naming the call, file and line when `result` is not cudaSuccess.
void check(cudaError_t result, const char* call, const char* file, int line);

/// Device memory in use / total, for messages about allocations that do not fit.
std::string memory_summary();

/// Throws Error{out_of_memory} saying how much `what` needed and how much is free.
[[noreturn]] void throw_allocation_error(std::size_t bytes, const char* what);

}  // namespace irgrid::cuda

#define IRGRID_CUDA_CHECK(call) ::irgrid::cuda::check((call), #call, __FILE__, __LINE__)
/// After a kernel launch: the launch error, then (synchronously) the kernel's own error.
#define IRGRID_CUDA_CHECK_LAUNCH(name)                                        \
  do {                                                                        \
    IRGRID_CUDA_CHECK(cudaGetLastError());                                    \
    ::irgrid::cuda::check(cudaDeviceSynchronize(), name, __FILE__, __LINE__); \
  } while (0)
/// Before a launch queued for the caller (trace_device): an error that one of the caller's own
/// earlier calls left pending (a failed cudaMalloc, a bad launch) is reported as theirs, and
/// cleared, instead of being read after the launch and blamed on it.
#define IRGRID_CUDA_CHECK_NONE_PENDING(name)                                                   \
  ::irgrid::cuda::check(cudaGetLastError(),                                                    \
                        "an earlier CUDA call of the caller (its error was pending when " name \
                        " began)",                                                             \
                        __FILE__, __LINE__)
/// After a kernel launch queued for the caller (trace_device): the launch error only, without
/// waiting for the kernel; its own errors surface at the caller's next synchronisation.
#define IRGRID_CUDA_CHECK_ASYNC_LAUNCH(name) \
  ::irgrid::cuda::check(cudaGetLastError(), name, __FILE__, __LINE__)
