// Scene helpers shared by every loader and structure: bounds, checking and dropping invalid
// triangles.
#include <fmt/format.h>

#include <cmath>

#include "irgrid/error.h"
#include "irgrid/io/scene.h"
#include "irgrid/kernel/vec.h"
#include "irgrid/mesh.h"

namespace irgrid {

void Box3f::extend(const Vec3f& p) {
  for (int a = 0; a < 3; ++a) {
    lo[a] = std::fmin(lo[a], p[a]);
    hi[a] = std::fmax(hi[a], p[a]);
  }
}

float Box3f::diagonal() const {
  if (empty()) return 0;
  const double dx = hi[0] - lo[0], dy = hi[1] - lo[1], dz = hi[2] - lo[2];
  return float(std::sqrt(dx * dx + dy * dy + dz * dz));
}

Box3f Scene::bounds() const {
  Box3f box;
  for (const auto& tri : triangles)
    for (std::uint32_t index : tri)
      box.extend(vertices[index]);
  return box;
}

namespace {

bool is_finite(const Vec3f& p) {
  return std::isfinite(p[0]) && std::isfinite(p[1]) && std::isfinite(p[2]);
}

}  // namespace

void drop_invalid_triangles(Scene& scene) {
  const auto vertex_count = scene.vertices.size();
  std::vector<bool> finite(vertex_count);
  for (std::size_t i = 0; i < vertex_count; ++i)
    finite[i] = is_finite(scene.vertices[i]);
  scene.input_ids.clear();
  std::size_t kept = 0;
  for (std::size_t i = 0; i < scene.triangles.size(); ++i) {
    const auto tri = scene.triangles[i];
    if (tri[0] >= vertex_count || tri[1] >= vertex_count || tri[2] >= vertex_count) {
      ++scene.report.dropped_bad_index;
      continue;
    }
    if (!finite[tri[0]] || !finite[tri[1]] || !finite[tri[2]]) {
      ++scene.report.dropped_nonfinite;
      continue;
    }
    const auto a = Vec3d::from(scene.vertices[tri[0]]);
    const auto b = Vec3d::from(scene.vertices[tri[1]]);
    const auto c = Vec3d::from(scene.vertices[tri[2]]);
    const auto n = cross(b - a, c - a);
    if (n.x == 0 && n.y == 0 && n.z == 0) {
      ++scene.report.dropped_degenerate;
      continue;
    }
    scene.triangles[kept++] = tri;
    scene.input_ids.push_back(std::uint32_t(i));
  }
  scene.triangles.resize(kept);
  scene.triangles.shrink_to_fit();
}

void check_scene(const Scene& scene) {
  try {
    check_mesh(scene.mesh());
  } catch (const Error& e) {
    throw Error(e.code(), fmt::format("scene '{}': {}", scene.name, e.what()));
  }
}

std::unique_ptr<Accelerator> make_accelerator(const Scene& scene, Structure structure,
                                              const AcceleratorOptions& options) {
  check_scene(scene);
  return make_accelerator(scene.mesh(), structure, options);
}

}  // namespace irgrid
