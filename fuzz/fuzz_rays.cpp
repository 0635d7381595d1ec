// Fuzzes the ray-file reader (both formats) and traces what it reads through a small grid:
// every ray misses or hits a real triangle, whatever its numbers, and the same rays read in
// place as RayArrays give the same hits in HitArrays.
#include <cstdint>
#include <cstring>
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
        if (rays.empty()) continue;
        irgrid::RayArrays in;  // the records' own fields, 8 floats apart
        in.count = rays.size();
        in.origins = rays[0].org, in.origin_stride = 8;
        in.directions = rays[0].dir, in.direction_stride = 8;
        in.tmin = &rays[0].tmin, in.tmin_stride = 8;
        in.tmax = &rays[0].tmax, in.tmax_stride = 8;
        std::vector<float> t(rays.size()), normals(3 * rays.size());
        std::vector<std::uint32_t> prim(rays.size());
        irgrid::HitArrays out;
        out.t = t.data(), out.prim = prim.data(), out.normal = normals.data();
        grid->trace(in, out, query);
        for (std::size_t i = 0; i < rays.size(); ++i)
          if (prim[i] != hits[i].prim || std::memcmp(&t[i], &hits[i].t, 4) != 0) __builtin_trap();
      }
    } catch (const irgrid::Error&) {
    }
  }
  return 0;
}
