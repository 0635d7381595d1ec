// Tests of the built-in procedural scenes and of the deterministic random numbers they use.
#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include <cmath>
#include <cstring>
#include <map>
#include <string>
#include <utility>
#include <vector>

#include "irgrid/error.h"
#include "irgrid/io/random.h"
#include "irgrid/io/scene.h"

namespace irgrid {
namespace {

/// Describes the first flaw that keeps the mesh from being a closed, consistently oriented
/// surface: every edge must lie in exactly two triangles that traverse it in opposite
/// directions. Returns "" for a closed mesh.
std::string closedness_problem(const Scene& scene) {
  std::map<std::pair<std::uint32_t, std::uint32_t>, int> directed_edges;
  for (const auto& tri : scene.triangles) {
    for (int k = 0; k < 3; ++k)
      ++directed_edges[{tri[k], tri[(k + 1) % 3]}];
  }
  for (const auto& [edge, count] : directed_edges) {
    const std::string name = std::to_string(edge.first) + "->" + std::to_string(edge.second);
    if (count != 1) return "edge " + name + " used " + std::to_string(count) + " times";
    if (!directed_edges.contains({edge.second, edge.first})) return "boundary edge " + name;
  }
  return "";
}

/// Six times the signed volume enclosed by a closed mesh: positive when normals point out.
double signed_volume6(const Scene& scene) {
  double sum = 0;
  for (const auto& tri : scene.triangles) {
    const auto& a = scene.vertices[tri[0]];
    const auto& b = scene.vertices[tri[1]];
    const auto& c = scene.vertices[tri[2]];
    sum += double(a[0]) * (double(b[1]) * c[2] - double(b[2]) * c[1]) -
           double(a[1]) * (double(b[0]) * c[2] - double(b[2]) * c[0]) +
           double(a[2]) * (double(b[0]) * c[1] - double(b[1]) * c[0]);
  }
  return sum;
}

bool bitwise_equal(const Scene& a, const Scene& b) {
  return a.vertices.size() == b.vertices.size() && a.triangles.size() == b.triangles.size() &&
         std::memcmp(a.vertices.data(), b.vertices.data(), a.vertices.size() * sizeof(Vec3f)) ==
             0 &&
         a.triangles == b.triangles && a.input_ids == b.input_ids;
}

void expect_clean(const Scene& scene) {
  EXPECT_GT(scene.triangle_count(), 0u) << scene.source;
  EXPECT_EQ(scene.report.dropped(), 0u) << scene.source;
  EXPECT_EQ(scene.report.triangles_read, scene.triangle_count()) << scene.source;
  EXPECT_EQ(scene.report.vertices_read, scene.vertices.size()) << scene.source;
  EXPECT_EQ(scene.input_ids.size(), scene.triangle_count()) << scene.source;
  EXPECT_FALSE(scene.bounds().empty()) << scene.source;
}

void expect_inside_box(const Scene& scene, const Vec3f& lo, const Vec3f& hi) {
  const Box3f box = scene.bounds();
  for (int a = 0; a < 3; ++a) {
    EXPECT_GE(box.lo[a], lo[a]) << scene.source << " axis " << a;
    EXPECT_LE(box.hi[a], hi[a]) << scene.source << " axis " << a;
  }
}

TEST(Pcg32, MatchesTheReferenceSequence) {
  Pcg32 rng;  // pcg32-demo: pcg32_srandom_r(&rng, 42u, 54u)
  rng.seed(42u, 54u);
  const std::uint32_t expected[] = {0xa15c02b7, 0x7b47f409, 0xba1d3330,
                                    0x83d2f293, 0xbfa4784b, 0xcbed606e};
  for (std::uint32_t value : expected)
    EXPECT_EQ(rng.next_u32(), value);
}

TEST(Pcg32, FloatsLieInTheHalfOpenUnitInterval) {
  Pcg32 rng;
  rng.seed(hash64(7), 1);
  double sum = 0;
  for (int i = 0; i < 100000; ++i) {
    const float x = rng.next_float();
    ASSERT_GE(x, 0.0f);
    ASSERT_LT(x, 1.0f);
    sum += x;
  }
  EXPECT_NEAR(sum / 100000, 0.5, 0.01);
  EXPECT_NE(hash64(1), hash64(2));
}

TEST(BuiltinScenes, EveryListedSceneGeneratesCleanly) {
  const auto names = builtin_scene_names();
  EXPECT_GE(names.size(), 6u);
  for (const auto& [usage, description] : names) {
    EXPECT_FALSE(description.empty()) << usage;
    const std::string name = usage.substr(0, usage.find(':'));
    const Scene scene = make_builtin_scene(name);
    expect_clean(scene);
    EXPECT_EQ(scene.name, "builtin:" + name);
    EXPECT_EQ(scene.source, "builtin:" + name);
  }
}

TEST(BuiltinScenes, SizeParameterGivesTheTriangleCount) {
  for (std::uint64_t n : {1u, 7u, 1000u}) {
    const Scene soup = make_builtin_scene("soup:" + std::to_string(n));
    EXPECT_EQ(soup.triangle_count(), n);
    EXPECT_EQ(soup.report.dropped(), 0u);
  }
  for (std::uint64_t n : {1u, 2u, 399u, 400u, 401u, 12345u}) {
    const Scene hairball = make_builtin_scene("hairball:" + std::to_string(n));
    EXPECT_EQ(hairball.triangle_count(), n);
    EXPECT_EQ(hairball.report.dropped(), 0u);
  }
  EXPECT_EQ(make_builtin_scene("soup").triangle_count(), 10000u);
  EXPECT_EQ(make_builtin_scene("sphere:20").triangle_count(), 20u);
  EXPECT_EQ(make_builtin_scene("sphere:21").triangle_count(), 80u);
  EXPECT_EQ(make_builtin_scene("sphere").triangle_count(), 1280u);
  const Scene cube = make_builtin_scene("cube");
  EXPECT_EQ(cube.triangle_count(), 12u);
  EXPECT_EQ(cube.vertices.size(), 8u);
}

TEST(BuiltinScenes, TeapotSizeFollowsN) {
  const auto small = make_builtin_scene("teapot-stadium").triangle_count();
  const auto large = make_builtin_scene("teapot-stadium:150000").triangle_count();
  EXPECT_NEAR(double(large - small), 100000.0, 5000.0);
  const auto tiny = make_builtin_scene("teapot-stadium:1");
  expect_clean(tiny);
}

TEST(BuiltinScenes, BoundsAreAsDocumented) {
  expect_inside_box(make_builtin_scene("soup:5000"), {0, 0, 0}, {1, 1, 1});
  expect_inside_box(make_builtin_scene("cube"), {-1, -1, -1}, {1, 1, 1});
  EXPECT_FLOAT_EQ(make_builtin_scene("cube").bounds().diagonal(), 2 * std::sqrt(3.0f));
  const Scene cornell = make_builtin_scene("cornell");
  expect_inside_box(cornell, {-1, 0, -1}, {1, 2, 1});
  EXPECT_FLOAT_EQ(cornell.bounds().diagonal(), 2 * std::sqrt(3.0f));
  for (const char* spec : {"hairball:20000", "sphere:5000"}) {
    const Scene scene = make_builtin_scene(spec);
    float max_radius = 0;
    for (const auto& v : scene.vertices) {
      max_radius = std::fmax(max_radius, std::sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]));
    }
    EXPECT_LE(max_radius, 1.0f + 1e-6f) << spec;
    EXPECT_GT(max_radius, 0.5f) << spec;
  }
  const Scene stadium = make_builtin_scene("teapot-stadium:2000");
  EXPECT_GT(stadium.bounds().diagonal(), 1000.0f);
}

TEST(BuiltinScenes, TeapotIsSmallAndCentred) {
  const Scene scene = make_builtin_scene("teapot-stadium:3000");
  // Triangles lying wholly within 2 units of the origin are the teapot's.
  Box3f teapot;
  for (const auto& tri : scene.triangles) {
    bool near = true;
    for (std::uint32_t index : tri) {
      const auto& v = scene.vertices[index];
      near = near && std::fabs(v[0]) < 2 && std::fabs(v[2]) < 2 && v[1] < 2;
    }
    if (near) {
      for (std::uint32_t index : tri)
        teapot.extend(scene.vertices[index]);
    }
  }
  EXPECT_GT(teapot.diagonal(), 0.8f);
  EXPECT_LT(teapot.diagonal(), 2.5f);
  EXPECT_GT(teapot.lo[1], 0.0f);  // floats above the floor: no coplanar overlap
}

TEST(BuiltinScenes, SameSpecGivesBitIdenticalScenes) {
  for (const char* spec :
       {"cornell", "teapot-stadium:5000", "soup:3000", "hairball:5000", "sphere:500", "cube"}) {
    EXPECT_TRUE(bitwise_equal(make_builtin_scene(spec), make_builtin_scene(spec))) << spec;
  }
  EXPECT_FALSE(bitwise_equal(make_builtin_scene("soup:3000"), make_builtin_scene("soup:3001")));
}

TEST(BuiltinScenes, HairballDoesNotDependOnTheThreadCount) {
  Scene one_thread;
  {
    tbb::global_control limit(tbb::global_control::max_allowed_parallelism, 1);
    one_thread = make_builtin_scene("hairball:200000");
  }
  const Scene all_threads = make_builtin_scene("hairball:200000");
  EXPECT_EQ(all_threads.triangle_count(), 200000u);
  EXPECT_EQ(all_threads.report.dropped(), 0u);
  EXPECT_TRUE(bitwise_equal(one_thread, all_threads));
  Scene soup_one_thread;
  {
    tbb::global_control limit(tbb::global_control::max_allowed_parallelism, 1);
    soup_one_thread = make_builtin_scene("soup:50000");
  }
  EXPECT_TRUE(bitwise_equal(soup_one_thread, make_builtin_scene("soup:50000")));
}

TEST(BuiltinScenes, InvalidSpecsThrowNamingTheSpec) {
  for (const std::string spec :
       {"nosuch", "soup:abc", "soup:0", "soup:-5", "soup:", "soup:+5", "soup: 5", "soup:12x",
        "soup:2147483649", "hairball:99999999999999999999999", "cube:3", "cornell:10", ""}) {
    try {
      make_builtin_scene(spec);
      ADD_FAILURE() << "no error for '" << spec << "'";
    } catch (const Error& error) {
      EXPECT_EQ(error.code(), ErrorCode::invalid_argument) << spec;
      EXPECT_NE(std::string(error.what()).find("'" + spec), std::string::npos)
          << spec << ": " << error.what();
    }
  }
}

TEST(BuiltinScenes, AcceptsThePrefixedSpec) {
  EXPECT_EQ(make_builtin_scene("builtin:cube").source, "builtin:cube");
  EXPECT_EQ(make_builtin_scene("soup:2").source, "builtin:soup:2");
}

TEST(BuiltinScenes, SoupBeyond32BitVertexIndicesIsRefusedBeforeAllocating) {
  try {
    make_builtin_scene("soup:2147483648");  // 3 vertices each: more than 2^32
    ADD_FAILURE() << "no error";
  } catch (const Error& error) {
    EXPECT_EQ(error.code(), ErrorCode::limit_exceeded);
    EXPECT_NE(std::string(error.what()).find("soup:2147483648"), std::string::npos);
  }
}

TEST(BuiltinScenes, ClosedScenesAreEdgeManifold) {
  for (const char* spec : {"cube", "sphere:20", "sphere", "sphere:3000", "cornell"}) {
    const Scene scene = make_builtin_scene(spec);
    EXPECT_EQ(closedness_problem(scene), "") << spec;
  }
  // Outward normals for the solids; the room's walls face inward, so the Cornell volume is
  // that of the boxes minus the room.
  EXPECT_NEAR(signed_volume6(make_builtin_scene("cube")), 6 * 8.0, 1e-9);
  EXPECT_NEAR(signed_volume6(make_builtin_scene("sphere:20000")), 6 * 4.18879, 6 * 0.01);
  EXPECT_LT(signed_volume6(make_builtin_scene("cornell")), 0.0);
  // A watertight sphere shares vertices: V - E + F = 2 with E = 3F/2.
  const Scene sphere = make_builtin_scene("sphere:1280");
  EXPECT_EQ(sphere.vertices.size(), sphere.triangle_count() / 2 + 2);
}

TEST(BuiltinScenes, ViewsLookFromInsideTheRoom) {
  const Scene cornell = make_builtin_scene("cornell");
  ASSERT_GE(cornell.views.size(), 2u);
  for (const auto& view : cornell.views) {
    EXPECT_GT(view.eye[0], -1.0f);
    EXPECT_LT(view.eye[0], 1.0f);
    EXPECT_GT(view.eye[1], 0.0f);
    EXPECT_LT(view.eye[1], 1.9f);  // below the light panel
    EXPECT_GT(view.eye[2], -1.0f);
    EXPECT_LT(view.eye[2], 1.0f);
    EXPECT_GT(view.fov_deg, 30.0f);
    EXPECT_LT(view.fov_deg, 90.0f);
  }
  const Scene stadium = make_builtin_scene("teapot-stadium:1000");
  ASSERT_EQ(stadium.views.size(), 2u);
  const auto distance = [](const Camera& c) {
    return std::hypot(c.eye[0] - c.target[0], c.eye[1] - c.target[1], c.eye[2] - c.target[2]);
  };
  EXPECT_LT(distance(stadium.views[0]), 5.0f);
  EXPECT_GT(distance(stadium.views[1]), 300.0f);
}

}  // namespace
}  // namespace irgrid
