// irgrid/kernel/platform.h: the one host/device macro header; everything in src/core includes it.
#pragma once

#if defined(__CUDACC__)
#define IRGRID_HD __host__ __device__
#define IRGRID_DEVICE __device__
#else
#define IRGRID_HD
#define IRGRID_DEVICE
#endif

// Inlining the compiler must not decline: per-triangle and per-step helpers of hot loops.
#if defined(__CUDACC__)
#define IRGRID_ALWAYS_INLINE __forceinline__
#elif defined(__GNUC__)
#define IRGRID_ALWAYS_INLINE inline __attribute__((always_inline))
#else
#define IRGRID_ALWAYS_INLINE inline
#endif

#if defined(__CUDA_ARCH__)
#define IRGRID_ON_DEVICE 1
#else
#define IRGRID_ON_DEVICE 0
#endif

#include <cstdint>
#if !defined(__CUDA_ARCH__)
#include <atomic>
#endif

namespace irgrid {

/// min(a, b) and max(a, b) as one instruction on every target (minss/maxss, fmnmx), where
/// fminf/fmaxf become library calls on x86 without -ffast-math. NaN rule: when either argument is
/// NaN they return `b`, so hot loops pass the running value second to skip a NaN candidate.
IRGRID_HD inline float min_fast(float a, float b) {
  return a < b ? a : b;
}
IRGRID_HD inline float max_fast(float a, float b) {
  return a > b ? a : b;
}

/// Adds `value` to *target atomically and returns the old value (relaxed order: counters only).
IRGRID_HD inline std::uint32_t atomic_add(std::uint32_t* target, std::uint32_t value) {
#if IRGRID_ON_DEVICE
  return atomicAdd(target, value);
#else
  return std::atomic_ref<std::uint32_t>(*target).fetch_add(value, std::memory_order_relaxed);
#endif
}

/// Sets *target to *target & value atomically.
IRGRID_HD inline void atomic_and(std::uint32_t* target, std::uint32_t value) {
#if IRGRID_ON_DEVICE
  atomicAnd(target, value);
#else
  std::atomic_ref<std::uint32_t>(*target).fetch_and(value, std::memory_order_relaxed);
#endif
}

/// Sets *target to max(*target, value) atomically.
IRGRID_HD inline void atomic_max(std::uint32_t* target, std::uint32_t value) {
#if IRGRID_ON_DEVICE
  atomicMax(target, value);
#else
  std::atomic_ref<std::uint32_t> ref(*target);
  std::uint32_t seen = ref.load(std::memory_order_relaxed);
  while (seen < value && !ref.compare_exchange_weak(seen, value, std::memory_order_relaxed)) {
  }
#endif
}

}  // namespace irgrid
