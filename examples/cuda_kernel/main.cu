// A user's CUDA kernel tracing through an irgrid grid (irgrid/kernel.h), and the library's own
// asynchronous trace on device pointers and a stream; both must agree with the host trace.
// Exit code 0 when they do, 77 when no GPU is visible (nothing to run).
#include <irgrid/irgrid.h>

#include <cuda_runtime.h>

#include <cmath>
#include <cstdio>
#include <vector>

namespace {

/// The user's own kernel: one ray per thread, a shading decision from the hit.
__global__ void shade(irgrid::GridView grid, const irgrid::Ray* rays, irgrid::Hit* hits,
                      int count) {
  const int i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i < count) hits[i] = irgrid::closest_hit(grid, rays[i]);
}

#define CHECK(call)                                                        \
  do {                                                                     \
    const cudaError_t result = (call);                                     \
    if (result != cudaSuccess) {                                           \
      std::fprintf(stderr, "%s: %s\n", #call, cudaGetErrorString(result)); \
      return 1;                                                            \
    }                                                                      \
  } while (0)

}  // namespace

int main() {
  if (irgrid::cuda_status().gpus.empty()) {
    std::printf("no usable GPU (%s): nothing to run\n", irgrid::cuda_status().status.c_str());
    return 77;
  }
  // A 16 x 16 height field of 512 triangles.
  constexpr int kN = 16;
  std::vector<float> vertices;
  std::vector<std::uint32_t> indices;
  for (int y = 0; y <= kN; ++y)
    for (int x = 0; x <= kN; ++x)
      vertices.insert(vertices.end(), {float(x), float(y), 0.3f * std::sin(0.7f * x + 0.4f * y)});
  for (int y = 0; y < kN; ++y)
    for (int x = 0; x < kN; ++x) {
      const std::uint32_t a = y * (kN + 1) + x, b = a + 1, c = a + kN + 1, d = c + 1;
      indices.insert(indices.end(), {a, b, d, a, d, c});
    }
  irgrid::TriangleMesh mesh{vertices.data(), vertices.size() / 3, 3 * sizeof(float), indices.data(),
                            indices.size() / 3};
  irgrid::AcceleratorOptions options;
  options.backend = irgrid::Backend::cuda;
  const auto grid = irgrid::make_accelerator(mesh, irgrid::Structure::irregular, options);

  std::vector<irgrid::Ray> rays;
  for (int k = 0; k < 4096; ++k)
    rays.push_back(
        {{0.5f + (k % 64) * 0.24f, 0.5f + (k / 64) * 0.24f, 5}, 0, {0.01f, 0.02f, -1}, INFINITY});
  const int count = int(rays.size());
  std::vector<irgrid::Hit> expected(count), from_kernel(count), from_trace_device(count);
  grid->trace(rays, expected, irgrid::Query::closest);

  irgrid::Ray* d_rays = nullptr;
  irgrid::Hit* d_hits = nullptr;
  CHECK(cudaMalloc(&d_rays, count * sizeof(irgrid::Ray)));
  CHECK(cudaMalloc(&d_hits, count * sizeof(irgrid::Hit)));
  cudaStream_t stream;
  CHECK(cudaStreamCreate(&stream));
  CHECK(cudaMemcpyAsync(d_rays, rays.data(), count * sizeof(irgrid::Ray), cudaMemcpyHostToDevice,
                        stream));
  shade<<<(count + 127) / 128, 128, 0, stream>>>(grid->grid_view(), d_rays, d_hits, count);
  CHECK(cudaGetLastError());
  CHECK(cudaMemcpyAsync(from_kernel.data(), d_hits, count * sizeof(irgrid::Hit),
                        cudaMemcpyDeviceToHost, stream));
  grid->trace_device(d_rays, d_hits, count, irgrid::Query::closest, stream);
  CHECK(cudaMemcpyAsync(from_trace_device.data(), d_hits, count * sizeof(irgrid::Hit),
                        cudaMemcpyDeviceToHost, stream));
  CHECK(cudaStreamSynchronize(stream));
  int differing = 0, hits = 0;
  for (int i = 0; i < count; ++i) {
    hits += expected[i].hit();
    differing += from_kernel[i].prim != expected[i].prim || from_kernel[i].t != expected[i].t ||
                 from_trace_device[i].prim != expected[i].prim ||
                 from_trace_device[i].t != expected[i].t;
  }
  std::printf("%d rays, %d hits; the user kernel and trace_device differ from trace on %d\n", count,
              hits, differing);
  cudaFree(d_rays);
  cudaFree(d_hits);
  cudaStreamDestroy(stream);
  return differing == 0 && hits == count ? 0 : 1;
}
