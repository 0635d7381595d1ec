// The compressed wide BVH equals the brute force bit for bit on the shared benchmark scenes
// (label scenes: skips without ../shared/scenes unless IRGRID_REQUIRE_SHARED_SCENES is set).
#include <gtest/gtest.h>

#include <filesystem>
#include <string>

#include "cwbvh_test_support.h"
#include "irgrid/accelerator.h"
#include "irgrid/io/rays.h"
#include "test_requirements.h"

namespace irgrid {
namespace {

TEST(CwbvhSharedScenes, SponzaEqualsTheBruteForce) {
#if !IRGRID_HAS_EMBREE
  GTEST_SKIP() << "cwbvh needs Embree";
#else
  const std::filesystem::path path =
      std::filesystem::path(IRGRID_SHARED_SCENES) / "crytek-sponza/sponza.obj.xz";
  if (!std::filesystem::exists(path))
    IRGRID_SKIP_UNLESS_REQUIRED("IRGRID_REQUIRE_SHARED_SCENES", "no scene " << path);
  const Scene scene = load_scene(path.string());
  const auto brute = make_accelerator(scene, Structure::brute);
  const auto bvh = make_accelerator(scene, Structure::cwbvh);
  // Few rays: the brute force tests all 262k triangles per ray.
  for (const auto& load : testing::cwbvh_workloads(scene, *bvh, 12, 8))
    testing::expect_same_hits(testing::trace_all(*brute, load.rays, load.query),
                              testing::trace_all(*bvh, load.rays, load.query), load.query,
                              "sponza " + load.what);
#endif
}

}  // namespace
}  // namespace irgrid
