// core/platform.h: the one host/device macro header; everything in src/core includes it.
#pragma once

#if defined(__CUDACC__)
#define IRGRID_HD __host__ __device__
#define IRGRID_DEVICE __device__
#else
#define IRGRID_HD
#define IRGRID_DEVICE
#endif

#if defined(__CUDA_ARCH__)
#define IRGRID_ON_DEVICE 1
#else
#define IRGRID_ON_DEVICE 0
#endif
