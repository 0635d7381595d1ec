// Loads the 8 real scenes of the shared scenes folder, checks the counts its README lists, and
// traces every ray kind of every view through the irregular grid against the double reference
// (every ray) and the exact oracle (a sample).
#include <gtest/gtest.h>

#include <chrono>
#include <cstdint>
#include <filesystem>
#include <iostream>
#include <string>
#include <vector>

#include "irgrid/accelerator.h"
#include "irgrid/io/camera.h"
#include "irgrid/io/exact.h"
#include "irgrid/io/rays.h"
#include "irgrid/io/scene.h"
#include "irgrid/io/validate.h"
#include "test_requirements.h"

namespace irgrid {
namespace {

struct SharedScene {
  const char* file;  // relative to the shared scenes folder
  std::uint64_t triangles;
  std::uint64_t vertices;
};

// From the table in shared/scenes/README.md.
constexpr SharedScene kSharedScenes[] = {
    {"crytek-sponza/sponza.obj.xz", 279163, 153635},
    {"conference/conference.obj.xz", 331179, 194399},
    {"crown/crown.obj.xz", 3540202, 1868115},
    {"sibenik/sibenik.obj.xz", 75284, 40981},
    {"dabrovic-sponza/sponza.obj.xz", 66450, 60848},
    {"lost-empire/lost_empire.obj.xz", 224998, 97077},
    {"bunny/bun_zipper.ply.xz", 69451, 35947},
    {"armadillo/Armadillo.ply.xz", 345944, 172974},
};

class SharedScenesTest : public ::testing::TestWithParam<SharedScene> {};

TEST_P(SharedScenesTest, CountsMatchReadme) {
  const SharedScene& expected = GetParam();
  const std::filesystem::path path = std::filesystem::path(IRGRID_SHARED_SCENES) / expected.file;
  if (!std::filesystem::exists(path))
    IRGRID_SKIP_UNLESS_REQUIRED("IRGRID_REQUIRE_SHARED_SCENES",
                                "shared scene not present: " << path);

  const auto start = std::chrono::steady_clock::now();
  const Scene scene = load_scene(path.string());
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();

  const SceneReport& report = scene.report;
  EXPECT_EQ(report.triangles_read, expected.triangles);
  EXPECT_EQ(report.vertices_read, expected.vertices);
  EXPECT_EQ(scene.triangle_count() + report.dropped(), report.triangles_read);
  EXPECT_EQ(scene.input_ids.size(), scene.triangle_count());
  EXPECT_EQ(report.unknown_statements, 0u);
  EXPECT_EQ(scene.name, path.parent_path().filename().string());

  RecordProperty("triangles_read", std::to_string(report.triangles_read));
  RecordProperty("dropped_degenerate", std::to_string(report.dropped_degenerate));
  RecordProperty("dropped_bad_index", std::to_string(report.dropped_bad_index));
  RecordProperty("dropped_nonfinite", std::to_string(report.dropped_nonfinite));
  std::cout << scene.name << ": triangles_read=" << report.triangles_read
            << " vertices_read=" << report.vertices_read << " kept=" << scene.triangle_count()
            << " dropped_degenerate=" << report.dropped_degenerate
            << " dropped_bad_index=" << report.dropped_bad_index
            << " dropped_nonfinite=" << report.dropped_nonfinite << " load_s=" << seconds << "\n";
  for (const auto& warning : report.warnings)
    std::cout << "  warning: " << warning << "\n";
}

TEST_P(SharedScenesTest, IrregularGridEqualsTheReferencesOnEveryViewAndRayKind) {
  const std::filesystem::path path = std::filesystem::path(IRGRID_SHARED_SCENES) / GetParam().file;
  if (!std::filesystem::exists(path))
    IRGRID_SKIP_UNLESS_REQUIRED("IRGRID_REQUIRE_SHARED_SCENES",
                                "shared scene not present: " << path);
  const Scene scene = load_scene(path.string());
  const auto grid = make_accelerator(scene, Structure::irregular);
  const ReferenceTracer reference(scene);
  const ExactTracer oracle(scene);
  // Smaller than bench's sets, every ray checked: `bench --validate` samples bigger ones.
  RayConfig config;
  config.width = 96, config.height = 64, config.spp = 2, config.count = 8192;
  const auto views = scene_views(scene);
  ASSERT_FALSE(views.empty());
  for (std::size_t v = 0; v < views.size(); ++v)
    for (const RayKind kind : {RayKind::primary, RayKind::ao, RayKind::diffuse, RayKind::random}) {
      const std::vector<Ray> rays = generate_rays(scene, views[v], kind, config, grid.get());
      // As bench traces them: ambient occlusion asks whether anything is hit.
      const Query query = kind == RayKind::ao ? Query::any : Query::closest;
      std::vector<Hit> hits(rays.size());
      grid->trace(rays, hits, query);
      const Validation result = validate_hits(reference, scene, rays, hits, query, rays.size());
      EXPECT_EQ(result.checked, rays.size());
      EXPECT_EQ(result.mismatches, 0u)
          << scene.name << " view " << v << " " << to_string(kind) << ": "
          << (result.examples.empty() ? std::string() : result.examples.front());
      const Validation exact = validate_hits(oracle, scene, rays, hits, query, 1500);
      EXPECT_EQ(exact.mismatches, 0u)
          << scene.name << " view " << v << " " << to_string(kind) << " (exact oracle): "
          << (exact.examples.empty() ? std::string() : exact.examples.front());
      if (kind == RayKind::primary) {
        std::size_t hit_count = 0;
        for (const Hit& hit : hits)
          hit_count += hit.hit();
        EXPECT_GT(hit_count, rays.size() / 10) << scene.name << " view " << v << ": few hits";
      }
    }
}

std::string scene_test_name(const ::testing::TestParamInfo<SharedScene>& info) {
  std::string name = std::filesystem::path(info.param.file).parent_path().string();
  for (char& c : name)
    if (c == '-') c = '_';
  return name;
}

INSTANTIATE_TEST_SUITE_P(Readme, SharedScenesTest, ::testing::ValuesIn(kSharedScenes),
                         scene_test_name);

}  // namespace
}  // namespace irgrid
