// Checking a caller's mesh before any structure copies it.
#include <fmt/format.h>

#include <cmath>
#include <cstdint>
#include <limits>

#include "irgrid/error.h"
#include "irgrid/mesh.h"

namespace irgrid {

void check_mesh(const TriangleMesh& mesh) {
  constexpr std::size_t kMaxCount = std::numeric_limits<std::uint32_t>::max();
  if (mesh.triangle_count > kMaxCount || mesh.vertex_count > kMaxCount)
    throw Error(ErrorCode::limit_exceeded,
                fmt::format("mesh: {} triangles and {} vertices; at most {} of each fit the "
                            "32-bit triangle and vertex ids",
                            mesh.triangle_count, mesh.vertex_count, kMaxCount));
  if ((mesh.vertex_count > 0 && mesh.vertices == nullptr) ||
      (mesh.triangle_count > 0 && mesh.indices == nullptr))
    throw Error(ErrorCode::invalid_argument,
                fmt::format("mesh: {} vertices at {} and {} triangles at {}: a null array with a "
                            "non-zero count",
                            mesh.vertex_count, fmt::ptr(mesh.vertices), mesh.triangle_count,
                            fmt::ptr(mesh.indices)));
  if (mesh.vertex_stride < 3 * sizeof(float) || mesh.vertex_stride % sizeof(float) != 0)
    throw Error(ErrorCode::invalid_argument,
                fmt::format("mesh: vertex_stride {} bytes; it must be a multiple of 4 and at "
                            "least 12 (float3)",
                            mesh.vertex_stride));
  // Past these the watertight test's products of three coordinates leave the float range, and
  // hits went wrong without a word (a cube at 1e19 hit the wrong face with NaN barycentrics,
  // one at 1e-15 missed); docs/robustness.md.
  constexpr float kMaxCoordinate = 0x1p60f, kMinExtent = 0x1p-40f;
  float lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
  for (std::size_t i = 0; i < mesh.triangle_count; ++i)
    for (int k = 0; k < 3; ++k) {
      const std::uint32_t index = mesh.indices[3 * i + k];
      if (index >= mesh.vertex_count)
        throw Error(ErrorCode::invalid_argument,
                    fmt::format("mesh: triangle {} names vertex {}, but the mesh has {} vertices",
                                i, index, mesh.vertex_count));
      const float* p = mesh.vertex(index);
      if (!std::isfinite(p[0]) || !std::isfinite(p[1]) || !std::isfinite(p[2]))
        throw Error(ErrorCode::invalid_argument,
                    fmt::format("mesh: triangle {} uses vertex {} = ({}, {}, {}), which is not "
                                "finite",
                                i, index, p[0], p[1], p[2]));
      for (int a = 0; a < 3; ++a) {
        if (std::fabs(p[a]) > kMaxCoordinate)
          throw Error(ErrorCode::limit_exceeded,
                      fmt::format("mesh: triangle {} uses vertex {} = ({}, {}, {}); coordinates "
                                  "beyond 2^60 (1.15e18) in magnitude overflow the watertight "
                                  "test's float products: scale the scene down",
                                  i, index, p[0], p[1], p[2]));
        lo[a] = std::fmin(lo[a], p[a]);
        hi[a] = std::fmax(hi[a], p[a]);
      }
    }
  const float extent = std::fmax(hi[0] - lo[0], std::fmax(hi[1] - lo[1], hi[2] - lo[2]));
  if (extent > 0 && extent < kMinExtent)
    throw Error(ErrorCode::limit_exceeded,
                fmt::format("mesh: the triangles span only {} units; scenes narrower than 2^-40 "
                            "(9.1e-13) underflow the watertight test's float products: scale the "
                            "scene up",
                            extent));
}

}  // namespace irgrid
