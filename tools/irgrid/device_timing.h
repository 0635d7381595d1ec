// tools/irgrid/device_timing.h: bench's timing of CUDA structures on rays already in device
// memory, so that MRays/s measure the traversal and not the PCIe copies.
#pragma once

#include <span>
#include <vector>

#include "irgrid/accelerator.h"

namespace irgrid::cli {

/// Traces `rays` with `accelerator` (Backend::cuda) `repeat` times from device memory: the rays
/// are uploaded once and the hits of the last trace downloaded into `hits` (rays.size() of
/// them); each timed trace is trace_device and a wait for the device, after one untimed warm-up.
/// Returns each trace's milliseconds. Throws Error{invalid_argument} in builds without CUDA.
std::vector<double> time_device_traces(const Accelerator& accelerator, std::span<const Ray> rays,
                                       std::span<Hit> hits, Query query, int repeat);

}  // namespace irgrid::cli
