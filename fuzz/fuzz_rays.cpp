// Fuzzes the ray-file reader (both formats) and traces what it reads through a small grid:
// every ray misses or hits a real triangle, whatever its numbers.
#include <cstdint>
#include <memory>
#include <vector>

#include "fuzz_file.h"
#include "irgrid/accelerator.h"
#include "irgrid/error.h"
#include "irgrid/io/rays.h"
#include "irgrid/io/scene.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static const irgrid::Scene scene = irgrid::load_scene("builtin:cornell");
  static const std::unique_ptr<irgrid::Accelerator> grid =
      irgrid::make_accelerator(scene, irgrid::Structure::irregular);
  const std::string path = irgrid::fuzz::write_input(data, size, ".rays");
  for (auto format : {irgrid::RayFormat::irgrid, irgrid::RayFormat::hagrid}) {
    try {
      const std::vector<irgrid::Ray> rays = irgrid::read_rays(path, format);
      std::vector<irgrid::Hit> hits(rays.size());
      for (auto query : {irgrid::Query::closest, irgrid::Query::any}) {
        grid->trace(rays, hits, query);
        for (const auto& hit : hits)
          if (hit.hit() && hit.prim >= scene.triangle_count()) __builtin_trap();
      }
    } catch (const irgrid::Error&) {
    }
  }
  return 0;
}
