// A user's own mesh, built and traced through the public headers only: exit code 0 when a ray
// down through the second triangle of a unit square hits it at t = 1.
#include <irgrid/accelerator.h>

#include <cstdio>
#include <vector>

int main() {
  irgrid::Scene scene;
  scene.name = "square";
  scene.vertices = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}};
  scene.triangles = {{0, 1, 2}, {0, 2, 3}};
  const auto structure = irgrid::make_accelerator(scene, irgrid::default_structure());
  const std::vector<irgrid::Ray> rays = {{{0.25f, 0.5f, 1}, 0, {0, 0, -1}, 10}};
  std::vector<irgrid::Hit> hits(rays.size());
  structure->trace(rays, hits, irgrid::Query::closest);
  std::printf("%s: triangle %u at t = %g\n", structure->structure().c_str(), hits[0].prim,
              hits[0].t);
  return hits[0].prim == 1 && hits[0].t == 1.f ? 0 : 1;
}
