// device_kernels.h in an extension built without CUDA: no GPU arrays; every call throws.
#include <string>

#include "device_kernels.h"
#include "irgrid/error.h"

namespace irgrid::python::gpu {
namespace {

[[noreturn]] void no_cuda() {
  throw Error(ErrorCode::no_device,
              "this irgrid was built without CUDA: GPU arrays need a build with the CUDA "
              "toolkit (nvcc); pass numpy arrays");
}

}  // namespace

bool available() noexcept {
  return false;
}
void FreeDevice::operator()(void*) const noexcept {}
DeviceMemory allocate(std::size_t, const char*) {
  no_cuda();
}
void upload(void*, const void*, std::size_t) {
  no_cuda();
}
int current_device() {
  no_cuda();
}
int device_of(const void*) {
  no_cuda();
}
void wait_for(Stream, Stream) {
  no_cuda();
}
Scratch::Scratch(std::size_t, Stream stream) : stream_(stream) {
  no_cuda();
}
Scratch::~Scratch() = default;
void pack_rays(const float*, std::size_t, const float*, float, const float*, float, Ray*, Stream) {
  no_cuda();
}
void split_hits(const Hit*, std::size_t, const float*, float*, std::uint32_t*, float*, float*,
                Stream) {
  no_cuda();
}
void occlusions(const Hit*, std::size_t, bool*, Stream) {
  no_cuda();
}

}  // namespace irgrid::python::gpu
