// tests/test_requirements.h: skipping a test whose input or device is missing, unless the
// environment requires that input (then the test fails instead of passing as skipped).
#pragma once

#include <gtest/gtest.h>

#include <cstdlib>
#include <string>

#include "irgrid/system.h"

namespace irgrid::testing {

/// Whether the environment variable `name` is set to a value other than "" and "0".
inline bool required(const char* name) {
  const char* value = std::getenv(name);
  return value != nullptr && *value != '\0' && std::string(value) != "0";
}

/// Whether no CUDA device is usable (no driver, a driver too old, a build without CUDA).
inline bool gpu_missing() {
  static const CudaStatus cuda = cuda_status();
  return cuda.gpus.empty();
}

}  // namespace irgrid::testing

/// Skips the current test with `message` (a stream expression), or fails it when the environment
/// variable `variable` is set: .ci/run sets IRGRID_REQUIRE_SHARED_SCENES so that CI cannot pass
/// without ../shared/scenes, and the GPU bundle's run.sh sets IRGRID_REQUIRE_GPU on a machine
/// with an NVIDIA device so that a driver too old for the toolkit fails instead of skipping.
#define IRGRID_SKIP_UNLESS_REQUIRED(variable, message)               \
  do {                                                               \
    if (::irgrid::testing::required(variable))                       \
      GTEST_FAIL() << message << " (and " << variable << " is set)"; \
    else                                                             \
      GTEST_SKIP() << message;                                       \
  } while (0)

/// Skips (or, with IRGRID_REQUIRE_GPU set, fails) the current test when no GPU is usable.
#define IRGRID_SKIP_WITHOUT_GPU()       \
  if (::irgrid::testing::gpu_missing()) \
  IRGRID_SKIP_UNLESS_REQUIRED("IRGRID_REQUIRE_GPU", "no GPU: " << ::irgrid::cuda_status().status)
