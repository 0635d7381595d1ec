// cuda_status() for builds without the CUDA backend.
#include "irgrid/system.h"

namespace irgrid {

CudaStatus cuda_status() {
  CudaStatus status;
  status.status = "CUDA backend not compiled in (configure with nvcc on PATH)";
  return status;
}

}  // namespace irgrid
