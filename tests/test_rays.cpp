// Standard rays: determinism, counts and layout; ray and hit files in both formats.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>

#include "irgrid/error.h"
#include "irgrid/io/camera.h"
#include "irgrid/io/rays.h"

namespace irgrid {
namespace {

namespace fs = std::filesystem;

bool same_bits(const std::vector<Ray>& a, const std::vector<Ray>& b) {
  return a.size() == b.size() && std::memcmp(a.data(), b.data(), a.size() * sizeof(Ray)) == 0;
}

fs::path temp_file(const std::string& name) {
  return fs::temp_directory_path() /
         ("irgrid_test_rays_" + std::to_string(::getpid()) + "_" + name);
}

class RaysTest : public ::testing::Test {
 protected:
  Scene scene = load_scene("builtin:cornell");
  std::unique_ptr<Accelerator> tracer = make_accelerator(scene, Structure::brute);
  RayConfig config = [] {
    RayConfig c;
    c.width = 48, c.height = 32, c.spp = 3, c.count = 1000;
    return c;
  }();
};

TEST_F(RaysTest, EveryKindIsDeterministic) {
  const Camera camera = scene_views(scene).at(0);
  for (RayKind kind : {RayKind::primary, RayKind::ao, RayKind::diffuse, RayKind::random}) {
    const auto a = generate_rays(scene, camera, kind, config, tracer.get());
    const auto b = generate_rays(scene, camera, kind, config, tracer.get());
    EXPECT_FALSE(a.empty()) << to_string(kind);
    EXPECT_TRUE(same_bits(a, b)) << to_string(kind);
  }
}

TEST_F(RaysTest, SeedChangesRandomAndSecondaryRays) {
  const Camera camera = scene_views(scene).at(0);
  RayConfig other = config;
  other.seed += 1;
  for (RayKind kind : {RayKind::ao, RayKind::random})
    EXPECT_FALSE(same_bits(generate_rays(scene, camera, kind, config, tracer.get()),
                           generate_rays(scene, camera, kind, other, tracer.get())));
}

TEST_F(RaysTest, PrimaryRaysCoverTheImageThroughPixelCentres) {
  const Camera camera{{0, 0, 0}, {0, 0, -1}, {0, 1, 0}, 90};
  const auto rays = primary_rays(camera, 2, 2);
  ASSERT_EQ(rays.size(), 4u);
  // fov 90: tan(45 deg) = 1, so pixel centres sit at +-0.5 on the image plane z = -1.
  const float expected = 0.5f / std::sqrt(1.5f);
  EXPECT_NEAR(rays[0].dir[0], -expected, 1e-6);  // top-left
  EXPECT_NEAR(rays[0].dir[1], expected, 1e-6);
  EXPECT_NEAR(rays[3].dir[0], expected, 1e-6);  // bottom-right
  EXPECT_NEAR(rays[3].dir[1], -expected, 1e-6);
  for (const Ray& ray : rays) {
    EXPECT_EQ(ray.tmin, 0.f);
    EXPECT_TRUE(std::isinf(ray.tmax));
  }
}

TEST_F(RaysTest, SecondaryRaysLeaveTheSurfaceOnTheCameraSide) {
  const Camera camera = scene_views(scene).at(0);
  const auto primary = primary_rays(camera, config.width, config.height);
  std::vector<Hit> hits(primary.size());
  tracer->trace(primary, hits, Query::closest);
  std::size_t hit_count = 0;
  for (const Hit& h : hits)
    hit_count += h.hit();
  const auto ao = secondary_rays(scene, primary, hits, RayKind::ao, 3, 1);
  ASSERT_EQ(ao.size(), hit_count * 3);
  const float diagonal = scene.bounds().diagonal();
  for (const Ray& ray : ao) {
    EXPECT_NEAR(ray.tmax, 0.1f * diagonal, 1e-5f * diagonal);
    EXPECT_NEAR(
        std::sqrt(ray.dir[0] * ray.dir[0] + ray.dir[1] * ray.dir[1] + ray.dir[2] * ray.dir[2]), 1.f,
        1e-5f);
  }
  const auto diffuse = secondary_rays(scene, primary, hits, RayKind::diffuse, 3, 1);
  ASSERT_EQ(diffuse.size(), ao.size());
  EXPECT_TRUE(std::isinf(diffuse[0].tmax));
  // Inside the closed room, every diffuse ray hits a wall, never the triangle it left through.
  std::vector<Hit> bounce(diffuse.size());
  tracer->trace(diffuse, bounce, Query::closest);
  for (const Hit& h : bounce)
    ASSERT_TRUE(h.hit());
}

TEST_F(RaysTest, RandomRaysStartInsideTheBox) {
  const Box3f box = scene.bounds();
  for (const Ray& ray : random_rays(box, 500, 3))
    for (int a = 0; a < 3; ++a) {
      EXPECT_GE(ray.org[a], box.lo[a]);
      EXPECT_LE(ray.org[a], box.hi[a]);
    }
}

TEST_F(RaysTest, InvalidParametersAreRejected) {
  EXPECT_THROW(primary_rays(Camera{}, 0, 10), Error);
  EXPECT_THROW(primary_rays(Camera{{0, 0, 0}, {0, 0, 0}, {0, 1, 0}, 60}, 4, 4), Error);
  // A field of view of 0 or 180 degrees, or not a number, made every ray alike or NaN.
  for (float fov : {0.f, 180.f, -10.f, std::nanf("")})
    EXPECT_THROW(primary_rays(Camera{{0, 0, 0}, {0, 0, -1}, {0, 1, 0}, fov}, 4, 4), Error) << fov;
  EXPECT_THROW(primary_rays(Camera{{std::nanf(""), 0, 0}, {0, 0, -1}, {0, 1, 0}, 60}, 4, 4), Error);
  EXPECT_THROW(parse_ray_kind("shadow"), Error);
  EXPECT_THROW(parse_ray_format("pbrt"), Error);
  const Camera camera = scene_views(scene).at(0);
  EXPECT_THROW(generate_rays(scene, camera, RayKind::ao, config, nullptr), Error);
}

TEST_F(RaysTest, IrgridFileRoundTripKeepsEveryBit) {
  const auto rays = random_rays(scene.bounds(), 777, 9);
  const auto path = temp_file("irgrid.rays");
  write_rays(path, rays, RayFormat::irgrid);
  EXPECT_EQ(fs::file_size(path), 777u * 32u);
  EXPECT_TRUE(same_bits(read_rays(path, RayFormat::irgrid), rays));
  fs::remove(path);
}

TEST_F(RaysTest, HagridFileRoundTripKeepsOriginAndDirection) {
  auto rays = random_rays(scene.bounds(), 100, 9);
  const auto path = temp_file("hagrid.rays");
  write_rays(path, rays, RayFormat::hagrid);
  EXPECT_EQ(fs::file_size(path), 100u * 24u);
  const auto back = read_rays(path, RayFormat::hagrid, 0.5f, 7.f);
  for (Ray& ray : rays)
    ray.tmin = 0.5f, ray.tmax = 7.f;
  EXPECT_TRUE(same_bits(back, rays));
  fs::remove(path);
}

TEST_F(RaysTest, TruncatedOrMissingRayFilesNameThePath) {
  const auto path = temp_file("bad.rays");
  std::ofstream(path, std::ios::binary) << std::string(33, 'x');
  try {
    read_rays(path, RayFormat::irgrid);
    FAIL() << "expected an error";
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), ErrorCode::io);
    EXPECT_NE(std::string(e.what()).find(path.string()), std::string::npos);
    EXPECT_NE(std::string(e.what()).find("33 bytes"), std::string::npos);
  }
  fs::remove(path);
  EXPECT_THROW(read_rays(path, RayFormat::hagrid), Error);
}

TEST_F(RaysTest, HitFilesHoldSixteenBytesPerRay) {
  std::vector<Hit> hits(5);
  hits[2] = {7, 1.5f, 0.25f, 0.5f};
  const auto path = temp_file("out.hits");
  write_hits(path, hits);
  ASSERT_EQ(fs::file_size(path), 80u);
  std::vector<Hit> back(5);
  std::ifstream(path, std::ios::binary).read(reinterpret_cast<char*>(back.data()), 80);
  EXPECT_EQ(back[2].prim, 7u);
  EXPECT_EQ(back[2].t, 1.5f);
  EXPECT_EQ(back[0].prim, kNoHit);
  fs::remove(path);
}

}  // namespace
}  // namespace irgrid
