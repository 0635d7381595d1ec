// tests/ray_test_support.h: small sets of the standard ray kinds for the API tests.
#pragma once

#include <cstdint>
#include <vector>

#include "irgrid/io/random.h"
#include "irgrid/io/rays.h"
#include "irgrid/io/scene.h"
#include "irgrid/irgrid.h"

namespace irgrid::testing {

/// Primary (width x height), diffuse and random (`count`) rays of the scene's first view, one
/// sample per pixel, in that order; brute force finds the hits the secondary rays start from.
inline std::vector<Ray> mixed_rays(const Scene& scene, int width, int height, std::uint64_t count) {
  RayConfig config;
  config.width = width, config.height = height, config.spp = 1, config.count = count;
  const auto brute = make_accelerator(scene, Structure::brute);
  std::vector<Ray> rays;
  for (RayKind kind : {RayKind::primary, RayKind::diffuse, RayKind::random}) {
    const auto some = generate_rays(scene, scene_views(scene).front(), kind, config, brute.get());
    rays.insert(rays.end(), some.begin(), some.end());
  }
  return rays;
}

}  // namespace irgrid::testing
