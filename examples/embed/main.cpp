// Embedding irgrid: a mesh in the program's own arrays, one build, closest and any-hit traces
// from several threads, a rebuild after the mesh moved. Exit code 0 when every answer is right.
#include <irgrid/irgrid.h>

#include <cmath>
#include <cstdio>
#include <thread>
#include <vector>

namespace {

/// A vertex as a renderer might store it: position padded to 16 bytes.
struct Vertex {
  float x, y, z, pad;
};

bool check(bool ok, const char* what) {
  std::printf("%s: %s\n", ok ? "ok" : "FAILED", what);
  return ok;
}

}  // namespace

int main() {
  // Two squares facing +z: one at z = 0 (triangles 0, 1), one at z = -1 (triangles 2, 3).
  std::vector<Vertex> vertices = {{0, 0, 0, 0},  {1, 0, 0, 0},  {1, 1, 0, 0},  {0, 1, 0, 0},
                                  {0, 0, -1, 0}, {1, 0, -1, 0}, {1, 1, -1, 0}, {0, 1, -1, 0}};
  const std::vector<std::uint32_t> indices = {0, 1, 2, 0, 2, 3, 4, 5, 6, 4, 6, 7};
  irgrid::TriangleMesh mesh;
  mesh.vertices = &vertices[0].x;
  mesh.vertex_count = vertices.size();
  mesh.vertex_stride = sizeof(Vertex);
  mesh.indices = indices.data();
  mesh.triangle_count = indices.size() / 3;

  irgrid::AcceleratorOptions options;
  options.backend = irgrid::Backend::automatic;  // the GPU when one is visible
  std::unique_ptr<irgrid::Accelerator> grid;
  try {
    grid = irgrid::make_accelerator(mesh, irgrid::Structure::irregular, options);
  } catch (const irgrid::Error& e) {
    std::fprintf(stderr, "irgrid: %s (%s)\n", e.what(), irgrid::to_string(e.code()));
    return 2;
  }
  const irgrid::BuildStats& stats = grid->build_stats();
  std::printf("irgrid %s: %s grid on %s, %llu cells, %llu bytes, built in %.2f ms\n",
              irgrid::version(), irgrid::to_string(grid->structure()),
              irgrid::to_string(grid->backend()),
              static_cast<unsigned long long>(stats.grid->cells),
              static_cast<unsigned long long>(stats.memory_bytes), stats.build_ms);

  // Rays down -z through (0.25, 0.75): the first square's triangle 1 at t = 1, then triangle 3.
  const irgrid::Ray down{{0.25f, 0.75f, 1}, 0, {0, 0, -1}, INFINITY};
  const irgrid::Ray short_ray{{0.25f, 0.75f, 1}, 0, {0, 0, -1}, 0.5f};
  const irgrid::Ray beside{{2, 2, 1}, 0, {0, 0, -1}, INFINITY};
  const std::vector<irgrid::Ray> rays = {down, short_ray, beside};
  std::vector<irgrid::Hit> closest(rays.size()), any(rays.size());
  grid->trace(rays, closest, irgrid::Query::closest);
  grid->trace(rays, any, irgrid::Query::any);
  bool ok = check(closest[0].prim == 1 && closest[0].t == 1.f, "closest hit: triangle 1 at t = 1");
  ok &= check(!closest[1].hit() && !closest[2].hit(), "misses: too short, and beside the mesh");
  ok &= check(any[0].hit() && !any[1].hit() && !any[2].hit(), "any hit: occlusion");
  // p = (1 - u - v) v0 + u v1 + v v2 on triangle 1 = (0, 2, 3): (0.25, 0.75) has u = 0.25,
  // v = 0.5.
  ok &= check(std::fabs(closest[0].u - 0.25f) < 1e-6f && std::fabs(closest[0].v - 0.5f) < 1e-6f,
              "barycentrics u = 0.25, v = 0.5");

  // One accelerator, eight threads tracing at once.
  std::vector<std::thread> threads;
  std::vector<int> agreed(8, 0);
  for (int t = 0; t < 8; ++t)
    threads.emplace_back([&, t] {
      std::vector<irgrid::Hit> hits(rays.size());
      grid->trace(rays, hits, irgrid::Query::closest);
      agreed[t] = hits[0].prim == closest[0].prim && hits[0].t == closest[0].t;
    });
  for (auto& thread : threads)
    thread.join();
  int agreeing = 0;
  for (int a : agreed)
    agreeing += a;
  ok &= check(agreeing == 8, "8 threads, same hits");

  // The mesh moves (an animation frame): the first square drops below the second.
  for (int k = 0; k < 4; ++k)
    vertices[k].z = -2;
  grid->rebuild(mesh);
  grid->trace(rays, closest, irgrid::Query::closest);
  ok &= check(closest[0].prim == 3 && closest[0].t == 2.f, "after rebuild: triangle 3 at t = 2");
  return ok ? 0 : 1;
}
