// tools/irgrid/device_timing.h: timing a CUDA accelerator with its rays and hits on the device.
#pragma once

#include <optional>
#include <span>
#include <vector>

#include "irgrid/accelerator.h"
#include "irgrid/ray.h"

namespace irgrid::cli {

/// Kernel times of Accelerator::trace_device, measured with CUDA events.
struct DeviceTiming {
  std::vector<double> times_ms;  ///< one per repetition, after one untimed warm-up launch
  std::vector<Hit> hits;         ///< the hits of the last launch, downloaded
};

/// Uploads `rays` once, launches trace_device `repeat` times on one stream and times each launch
/// with events, so that the figure is the kernel's alone, as a renderer keeping its rays on the
/// GPU sees it. Empty when `accelerator` is not on the CUDA backend or this build has no CUDA.
/// Throws Error{out_of_memory} when the rays or hits do not fit, Error{internal} when a copy or
/// launch fails.
std::optional<DeviceTiming> time_trace_on_device(const Accelerator& accelerator,
                                                 std::span<const Ray> rays, Query query,
                                                 int repeat);

}  // namespace irgrid::cli
