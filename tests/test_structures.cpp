// Every structure built into this binary agrees with the double-precision brute force.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

#include "irgrid/accelerator.h"
#include "irgrid/error.h"
#include "irgrid/io/rays.h"
#include "irgrid/io/validate.h"

namespace irgrid {
namespace {

struct Workload {
  std::vector<Ray> rays;
  Query query;
  std::string what;
};

std::vector<Workload> standard_workloads(const Scene& scene) {
  RayConfig config;
  config.width = 40, config.height = 30, config.spp = 2, config.count = 1500;
  const auto brute = make_accelerator(scene, Structure::brute);
  std::vector<Workload> loads;
  const auto views = scene_views(scene);
  for (std::size_t v = 0; v < views.size(); ++v)
    for (RayKind kind : {RayKind::primary, RayKind::ao, RayKind::diffuse, RayKind::random})
      loads.push_back({generate_rays(scene, views[v], kind, config, brute.get()),
                       kind == RayKind::ao ? Query::any : Query::closest,
                       std::string(to_string(kind)) + " view " + std::to_string(v)});
  return loads;
}

class EveryStructure : public ::testing::TestWithParam<Structure> {};

TEST_P(EveryStructure, AgreesWithTheReferenceOnStandardRays) {
  for (const char* spec : {"builtin:cornell", "builtin:teapot-stadium:3000", "builtin:soup:3000"}) {
    const Scene scene = load_scene(spec);
    const auto structure = make_accelerator(scene, GetParam());
    for (const auto& load : standard_workloads(scene)) {
      std::vector<Hit> hits(load.rays.size());
      structure->trace(load.rays, hits, load.query);
      const auto result = validate_hits(scene, load.rays, hits, load.query, load.rays.size());
      EXPECT_EQ(result.checked, load.rays.size());
      EXPECT_EQ(result.mismatches, 0u) << spec << " " << load.what << ": "
                                       << (result.examples.empty() ? "" : result.examples[0]);
    }
  }
}

TEST_P(EveryStructure, RespectsTminAndTmax) {
  const Scene scene = load_scene("builtin:cube");
  const auto structure = make_accelerator(scene, GetParam());
  // Along +z through the cube's centre: entry at t = 4, exit at t = 6.
  const std::vector<Ray> rays = {{{0.1f, 0.2f, -5}, 0, {0, 0, 1}, 100},
                                 {{0.1f, 0.2f, -5}, 4.5f, {0, 0, 1}, 100},
                                 {{0.1f, 0.2f, -5}, 0, {0, 0, 1}, 3.9f},
                                 {{0.1f, 0.2f, -5}, 6.1f, {0, 0, 1}, 100}};
  std::vector<Hit> hits(rays.size());
  structure->trace(rays, hits, Query::closest);
  EXPECT_FLOAT_EQ(hits[0].t, 4.f);
  EXPECT_FLOAT_EQ(hits[1].t, 6.f);
  EXPECT_FALSE(hits[2].hit());
  EXPECT_FALSE(hits[3].hit());
  structure->trace(rays, hits, Query::any);
  EXPECT_TRUE(hits[0].hit());
  EXPECT_TRUE(hits[1].hit());
  EXPECT_FALSE(hits[2].hit());
  EXPECT_FALSE(hits[3].hit());
}

TEST_P(EveryStructure, ANegativeTminFindsHitsBehindTheOrigin) {
  // Embree asserts on tnear < 0 (Debian's build aborted `trace --structure embree`); its rays
  // now start at org + tmin dir instead, and every structure finds the same hits.
  const Scene scene = load_scene("builtin:cube");
  const auto structure = make_accelerator(scene, GetParam());
  const float inf = std::numeric_limits<float>::infinity();
  const std::vector<Ray> rays = {{{0.1f, 0.2f, 0}, -10, {0, 0, 1}, 100},
                                 {{0.1f, 0.2f, 0}, -10, {0, 0, 1}, -2},
                                 {{0.1f, 0.2f, 0}, -inf, {0, 0, 1}, 0.5f},
                                 {{0.1f, 0.2f, 3}, -0.5f, {0, 0, 1}, inf}};
  for (Query query : {Query::closest, Query::any}) {
    std::vector<Hit> hits(rays.size());
    structure->trace(rays, hits, query);
    EXPECT_TRUE(hits[0].hit());
    EXPECT_FALSE(hits[1].hit());
    EXPECT_FALSE(hits[3].hit());
    if (query == Query::closest) EXPECT_NEAR(hits[0].t, -1.f, 1e-5f);
    (void)hits[2];  // -inf: the grids clip it to the box; Embree cannot start it anywhere
  }
}

TEST_P(EveryStructure, RejectsMismatchedSpans) {
  const Scene scene = load_scene("builtin:cube");
  const auto structure = make_accelerator(scene, GetParam());
  std::vector<Ray> rays(3);
  std::vector<Hit> hits(2);
  EXPECT_THROW(structure->trace(rays, hits, Query::closest), Error);
}

/// A unit square in z = 0 made of two triangles, built by hand as a library user would.
Scene hand_made_square() {
  Scene scene;
  scene.name = "hand-made";
  scene.vertices = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}};
  scene.triangles = {{0, 1, 2}, {0, 2, 3}};
  return scene;
}

/// The message of the Error that building `structure` over `scene` throws ("" if none).
std::string build_error(const Scene& scene, Structure structure) {
  try {
    make_accelerator(scene, structure);
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), ErrorCode::invalid_argument);
    return e.what();
  }
  return "";
}

TEST_P(EveryStructure, RejectsHandMadeScenesWithBadIndicesOrVertices) {
  Scene bad_index = hand_made_square();
  bad_index.triangles.push_back({0, 1, 1000000});
  const std::string index_error = build_error(bad_index, GetParam());
  EXPECT_NE(index_error.find("triangle 2 names vertex 1000000"), std::string::npos) << index_error;
  Scene not_finite = hand_made_square();
  not_finite.vertices.push_back({std::nanf(""), 0, 0});
  not_finite.triangles.push_back({0, 1, 4});
  const std::string vertex_error = build_error(not_finite, GetParam());
  EXPECT_NE(vertex_error.find("triangle 2 uses vertex 4"), std::string::npos) << vertex_error;
  EXPECT_NE(vertex_error.find("not finite"), std::string::npos) << vertex_error;
  // What drop_invalid_triangles leaves builds, and rays down through the square hit it.
  drop_invalid_triangles(not_finite);
  const auto structure = make_accelerator(not_finite, GetParam());
  const std::vector<Ray> rays = {{{0.25f, 0.5f, 1}, 0, {0, 0, -1}, 10},
                                 {{0.75f, 0.5f, 1}, 0, {0, 0, -1}, 10}};
  std::vector<Hit> hits(rays.size());
  structure->trace(rays, hits, Query::closest);
  EXPECT_TRUE(hits[0].hit() && hits[1].hit());
}

TEST_P(EveryStructure, EmptyScenesBuildAndMissEverything) {
  Scene empty;
  empty.name = "empty";
  const auto structure = make_accelerator(empty, GetParam());
  const std::vector<Ray> rays = {{{0, 0, 0}, 0, {1, 0, 0}, 1e30f}};
  std::vector<Hit> hits(rays.size());
  for (Query query : {Query::closest, Query::any}) {
    structure->trace(rays, hits, query);
    EXPECT_FALSE(hits[0].hit());
  }
}

TEST_P(EveryStructure, MalformedRaysMissInsteadOfFailing) {
  // Rays a ray file may hold. Embree asserts on the first four kinds (Debian's build aborted
  // `irgrid trace --structure embree` on them); the grids and the brute force always missed.
  const float nan = std::nanf(""), inf = std::numeric_limits<float>::infinity();
  const std::vector<Ray> rays = {
      {{nan, 0.5f, 5}, 0, {0, 0, -1}, inf},
      {{0.5f, 0.5f, 5}, 0, {nan, 0, -1}, inf},
      {{inf, 0.5f, 5}, 0, {-1, 0, 0}, inf},
      {{0.5f, 0.5f, 5}, 0, {0, 1e30f, -1e30f}, inf},
      {{0.5f, 0.5f, 5}, nan, {0, 0, -1}, inf},
      {{0.5f, 0.5f, 5}, 0, {0, 0, -1}, nan},
      {{0.5f, 0.5f, 5}, 8, {0, 0, -1}, 1},
      {{0.5f, 0.5f, 5}, 0, {0, 0, -1}, -inf},
      {{0.5f, 0.5f, 5}, 0, {0, 0, 0}, inf},
      // An infinite direction once hit at t = 0 on the grids and the brute force.
      {{0.5f, 0.5f, 5}, 0, {0, 0, -inf}, inf},
      {{0.5f, 0.5f, 5}, 0, {0.1f, inf, -inf}, inf},
      {{0.5f, 0.5f, 5}, 0, {-inf, 0, -1}, inf}};
  const Scene scene = hand_made_square();
  const auto structure = make_accelerator(scene, GetParam());
  for (Query query : {Query::closest, Query::any}) {
    std::vector<Hit> hits(rays.size());
    structure->trace(rays, hits, query);
    for (std::size_t i = 0; i < rays.size(); ++i)
      EXPECT_FALSE(hits[i].hit()) << "ray " << i << (query == Query::any ? ", any" : ", closest");
  }
  // The same square is hit by a well-formed ray.
  std::vector<Hit> hit(1);
  structure->trace(std::vector<Ray>{{{0.5f, 0.25f, 5}, 0, {0, 0, -1}, inf}}, hit, Query::closest);
  EXPECT_TRUE(hit[0].hit());
}

INSTANTIATE_TEST_SUITE_P(Cpu, EveryStructure, ::testing::ValuesIn(available_structures()),
                         [](const auto& info) {
                           std::string name = to_string(info.param);
                           std::replace(name.begin(), name.end(), '-', '_');
                           return name;
                         });

TEST(Validation, CountsWrongHits) {
  const Scene scene = load_scene("builtin:cube");
  const std::vector<Ray> rays = {{{0.1f, 0.2f, -5}, 0, {0, 0, 1}, 100},
                                 {{0.1f, 0.2f, -5}, 0, {0, 0, -1}, 100}};
  std::vector<Hit> hits(2);
  trace_reference_double(scene, rays, hits, Query::closest);
  EXPECT_EQ(validate_hits(scene, rays, hits, Query::closest, 10).mismatches, 0u);
  std::swap(hits[0], hits[1]);  // a hit reported as a miss and a miss as a hit
  const auto result = validate_hits(scene, rays, hits, Query::closest, 10);
  EXPECT_EQ(result.checked, 2u);
  EXPECT_EQ(result.mismatches, 2u);
  EXPECT_FALSE(result.examples.empty());
}

TEST(Validation, FragileDisagreementsAreNotMismatchesButRobustOnesAre) {
  const Scene scene = load_scene("builtin:cube");
  // Starts exactly on the face z = -1: whether t = 0 counts depends on rounding.
  const std::vector<Ray> rays = {{{0.1f, 0.2f, -1}, 0, {0, 0.3f, 1}, 100}};
  Hit reference;
  trace_reference_double(scene, rays, {&reference, 1}, Query::closest);
  Hit at_start = reference;
  at_start.t = 0;  // a hit on the starting face, as a float test may report
  EXPECT_EQ(validate_hits(scene, rays, {&at_start, 1}, Query::closest, 1).mismatches, 0u);
  // The real hit on the far face (validation checks t, u, v against the reported triangle), as
  // a structure that skipped the near one would report it.
  std::vector<Ray> beyond = rays;
  beyond[0].tmin = reference.t + 0.5f;
  Hit far_face;
  trace_reference_double(scene, beyond, {&far_face, 1}, Query::closest);
  ASSERT_TRUE(far_face.hit());
  EXPECT_EQ(validate_hits(scene, rays, {&far_face, 1}, Query::closest, 1).mismatches,
            reference.t > 0.5f ? 1u : 0u);
  const Hit miss;
  const std::vector<Ray> through = {{{0.1f, 0.2f, -5}, 0, {0, 0, 1}, 100}};
  EXPECT_EQ(validate_hits(scene, through, {&miss, 1}, Query::closest, 1).mismatches, 1u);
  EXPECT_EQ(validate_hits(scene, through, {&miss, 1}, Query::any, 1).mismatches, 1u);
}

TEST(Factory, UnknownStructureOrBackendNamesTheValue) {
  const Scene scene = load_scene("builtin:cube");
  try {
    parse_structure("kd-tree");
    FAIL();
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), ErrorCode::invalid_argument);
    EXPECT_NE(std::string(e.what()).find("kd-tree"), std::string::npos);
  }
  AcceleratorOptions options;
  EXPECT_THROW(parse_backend("opencl"), Error);
}

}  // namespace
}  // namespace irgrid
