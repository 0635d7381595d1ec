// Fuzzes the construction and the traversal: a small triangle soup and rays decoded from the
// input (coordinates on a coarse lattice, so that coincident vertices, shared edges and
// axis-aligned rays are common), an irregular grid built over it with a small budget, every
// ray traced and checked against the double-precision reference. A robust mismatch traps.
#include <cstdint>
#include <cstring>
#include <vector>

#include "irgrid/accelerator.h"
#include "irgrid/error.h"
#include "irgrid/io/scene.h"
#include "irgrid/io/validate.h"

namespace {

/// Reads inputs byte by byte; zeros once they run out.
struct Reader {
  const std::uint8_t* data;
  std::size_t size, at = 0;
  std::uint8_t byte() { return at < size ? data[at++] : 0; }
  /// A coordinate on the lattice k / 16, k in [-128, 127].
  float coordinate() { return float(std::int8_t(byte())) / 16.f; }
};

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  Reader in{data, size};
  const std::uint8_t header = in.byte();
  const std::size_t triangles = 1 + header % 24, rays = 1 + in.byte() % 32;
  irgrid::Scene scene;
  for (std::size_t i = 0; i < triangles; ++i) {
    for (int k = 0; k < 3; ++k)
      scene.vertices.push_back({in.coordinate(), in.coordinate(), in.coordinate()});
    const auto base = std::uint32_t(3 * i);
    scene.triangles.push_back({base, base + 1, base + 2});
  }
  irgrid::drop_invalid_triangles(scene);
  if (scene.triangles.empty()) return 0;
  irgrid::AcceleratorOptions options;
  options.grid.memory_budget = (header & 0x80) ? (std::uint64_t(1) << 16) : 0;  // tiny budget too
  options.grid.min_cells = (header & 0x40) ? 0 : 4096;
  std::vector<irgrid::Ray> ray_list;
  for (std::size_t i = 0; i < rays; ++i) {
    irgrid::Ray ray{{in.coordinate(), in.coordinate(), in.coordinate()},
                    0,
                    {in.coordinate(), in.coordinate(), in.coordinate()},
                    1e30f};
    if (ray.dir[0] == 0 && ray.dir[1] == 0 && ray.dir[2] == 0) ray.dir[2] = 1;
    ray_list.push_back(ray);
  }
  try {
    const auto grid = irgrid::make_accelerator(scene, irgrid::Structure::irregular, options);
    for (auto query : {irgrid::Query::closest, irgrid::Query::any}) {
      std::vector<irgrid::Hit> hits(ray_list.size());
      grid->trace(ray_list, hits, query);
      const auto result = irgrid::validate_hits(scene, ray_list, hits, query, ray_list.size());
      if (result.mismatches != 0) __builtin_trap();
    }
  } catch (const irgrid::Error&) {
  }
  return 0;
}
