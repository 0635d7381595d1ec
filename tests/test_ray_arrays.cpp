// trace over the caller's own arrays (RayArrays, HitArrays): the same hits as trace over Ray
// records, on every structure, walk and layout, with normals, strides and null outputs.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <string>
#include <vector>

#include "cpu/staged_hits.h"
#include "irgrid/io/random.h"
#include "irgrid/io/rays.h"
#include "irgrid/io/scene.h"
#include "irgrid/irgrid.h"
#include "ray_test_support.h"

namespace irgrid {
namespace {

/// Primary, diffuse and random rays of the scene's first view, each with tmin and tmax of its
/// own (some rays cut short, some starting late), so that the per-ray intervals matter.
std::vector<Ray> varied_rays(const Scene& scene) {
  std::vector<Ray> rays = testing::mixed_rays(scene, 48, 32, 3000);
  for (std::size_t i = 0; i < rays.size(); i += 3)
    rays[i].tmax = 0.5f * (i % 7 + 1);
  for (std::size_t i = 1; i < rays.size(); i += 5)
    rays[i].tmin = 0.25f;
  return rays;
}

/// The rays as one array of (origin, direction) rows of `row` floats (6 or more: padding after
/// them), with tmin and tmax in arrays of their own.
struct RowRays {
  std::vector<float> rows, tmin, tmax;
  std::size_t row;
  RowRays(const std::vector<Ray>& rays, std::size_t row_floats) : row(row_floats) {
    rows.assign(rays.size() * row, std::nanf(""));  // the padding must not be read
    for (std::size_t i = 0; i < rays.size(); ++i) {
      float* r = &rows[i * row];
      std::memcpy(r, rays[i].org, 12);
      std::memcpy(r + 3, rays[i].dir, 12);
      tmin.push_back(rays[i].tmin);
      tmax.push_back(rays[i].tmax);
    }
  }
  RayArrays arrays() const {
    RayArrays a;
    a.count = tmin.size();
    a.origins = rows.data(), a.origin_stride = row;
    a.directions = rows.data() + 3, a.direction_stride = row;
    a.tmin = tmin.data(), a.tmin_stride = 1;
    a.tmax = tmax.data(), a.tmax_stride = 1;
    return a;
  }
};

/// Split outputs, in the layout Python returns them.
struct SplitHits {
  std::vector<float> t, uv, normals;
  std::vector<std::uint32_t> prim;
  explicit SplitHits(std::size_t n)
      : t(n, -1.f), uv(2 * n, -1.f), normals(3 * n, -1.f), prim(n, 12345u) {}
  HitArrays arrays() {
    HitArrays h;
    h.t = t.data(), h.prim = prim.data();
    h.u = uv.data(), h.u_stride = 2;
    h.v = uv.data() + 1, h.v_stride = 2;
    h.normal = normals.data();
    return h;
  }
};

/// Whether a and b hold the same bits (Embree's any-hit distance is a NaN).
bool same_bits(float a, float b) {
  return std::memcmp(&a, &b, sizeof(float)) == 0;
}

/// The normal the API promises: of the triangle's vertices as the mesh gives them.
Vec3<float> expected_normal(const Scene& scene, std::uint32_t prim) {
  const auto& tri = scene.triangles[prim];
  const auto corner = [&](int k) { return Vec3<float>::from(scene.vertices[tri[k]].data()); };
  return triangle_normal({corner(0), corner(1), corner(2)});
}

/// Compares the split hits with Hit records of the same rays: the same bits, the miss
/// conventions, and normals of unit length (zero on a miss) that are the triangle's.
void expect_split_equals_records(const Scene& scene, const std::vector<Hit>& records,
                                 const SplitHits& split, const std::string& what) {
  std::size_t wrong = 0, hits = 0;
  for (std::size_t i = 0; i < records.size(); ++i) {
    const Hit& h = records[i];
    const float* n = &split.normals[3 * i];
    if (!h.hit()) {
      wrong += split.prim[i] != kNoHit || !std::isinf(split.t[i]) || split.uv[2 * i] != 0 ||
               split.uv[2 * i + 1] != 0 || n[0] != 0 || n[1] != 0 || n[2] != 0;
      continue;
    }
    ++hits;
    const Vec3<float> e = expected_normal(scene, h.prim);
    wrong += split.prim[i] != h.prim || !same_bits(split.t[i], h.t) ||
             !same_bits(split.uv[2 * i], h.u) || !same_bits(split.uv[2 * i + 1], h.v) ||
             n[0] != e.x || n[1] != e.y || n[2] != e.z;
    const float length = std::sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
    wrong += std::fabs(length - 1) > 1e-5f;
  }
  EXPECT_EQ(wrong, 0u) << what;
  EXPECT_GT(hits, records.size() / 4) << what << ": too few hits to tell";
}

void expect_arrays_trace_like_records(const Scene& scene, const Accelerator& accelerator,
                                      const std::string& what) {
  const auto rays = varied_rays(scene);
  for (const Query query : {Query::closest, Query::any}) {
    std::vector<Hit> records(rays.size());
    accelerator.trace(rays, records, query);
    for (const std::size_t row : {6, 8, 11}) {
      const RowRays in(rays, row);
      SplitHits out(rays.size());
      accelerator.trace(in.arrays(), out.arrays(), query);
      expect_split_equals_records(
          scene, records, out,
          what + (query == Query::any ? " any" : " closest") + ", rows of " + std::to_string(row));
    }
  }
}

TEST(RayArrays, EveryStructureTracesTheCallersArraysAsItsOwnRecords) {
  const Scene scene = load_scene("builtin:teapot-stadium:3000");
  for (const Structure structure : available_structures()) {
    const auto accelerator = make_accelerator(scene, structure);
    expect_arrays_trace_like_records(scene, *accelerator, to_string(structure));
  }
}

TEST(RayArrays, EveryCpuWalkAndCellLayoutTracesTheArraysAsRecords) {
  const Scene scene = load_scene("builtin:cornell");
  for (const CpuWalk walk : {CpuWalk::automatic, CpuWalk::avx2, CpuWalk::avx512, CpuWalk::single,
                             CpuWalk::interleaved}) {
    for (const bool compress : {false, true}) {
      AcceleratorOptions options;
      options.cpu_walk = walk;
      options.grid.compress = compress;
      std::unique_ptr<Accelerator> grid;
      try {
        grid = make_accelerator(scene, Structure::irregular, options);
      } catch (const Error&) {
        continue;  // a SIMD walk this CPU lacks
      }
      expect_arrays_trace_like_records(
          scene, *grid, std::string(to_string(walk)) + (compress ? ", compressed" : ""));
    }
  }
}

TEST(RayArrays, StagedHitsWriteEveryRayWhateverOrderTheyEndIn) {
  // Ray 0 walks longest: its slot is needed while it still walks, so it writes its own fields;
  // every other ray goes through the ring, a few at a time, ending in reverse order of a batch.
  constexpr std::size_t kRays = 3 * StagedHits::kSlots + 123, kBatch = 16;
  std::vector<float> t(kRays, -1.f);
  std::vector<std::uint32_t> prim(kRays, 12345u);
  HitFields fields{};
  fields.t = t.data(), fields.prim = prim.data(), fields.t_stride = fields.prim_stride = 1;
  StagedHits out(fields, kRays);
  const auto hit_of = [](std::size_t ray) { return ray % 5 == 0 ? kNoHit : std::uint32_t(ray); };
  for (std::size_t first = 0; first < kRays; first += kBatch) {
    const std::size_t n = std::min(kBatch, kRays - first);
    out.make_room(first, n);
    for (std::size_t k = n; k-- > 0;) {
      const std::size_t ray = first + k;
      if (ray != 0) out.write(ray, hit_of(ray), float(ray), 0, 0);
    }
  }
  out.write(0, hit_of(0), 0.f, 0, 0);  // the straggler ends last
  out.finish(kRays);
  std::size_t wrong = 0;
  for (std::size_t i = 0; i < kRays; ++i) {
    const bool miss = hit_of(i) == kNoHit;
    wrong += prim[i] != hit_of(i) || (miss ? !std::isinf(t[i]) : t[i] != float(i));
  }
  EXPECT_EQ(wrong, 0u);
}

TEST(RayArrays, LargeBatchesOfMixedRaysTraceAsRecords) {
  // Hundreds of thousands of rays of mixed lengths: each walk's pieces are larger than the
  // staging ring, and long walks outlive their ring slots.
  const Scene scene = load_scene("builtin:teapot-stadium:3000");
  const auto grid = make_accelerator(scene, Structure::irregular);
  std::vector<Ray> rays;
  while (rays.size() < 200000) {
    const auto some = varied_rays(scene);
    rays.insert(rays.end(), some.begin(), some.end());
  }
  std::vector<Hit> records(rays.size());
  grid->trace(rays, records, Query::closest);
  const RowRays in(rays, 6);
  SplitHits out(rays.size());
  grid->trace(in.arrays(), out.arrays(), Query::closest);
  expect_split_equals_records(scene, records, out, "200K rays");
}

TEST(RayArrays, SharedValuesNullBoundsAndUnsetOutputs) {
  const Scene scene = load_scene("builtin:cornell");
  const auto grid = make_accelerator(scene, Structure::irregular);
  // Camera rays from one origin: origin stride 0, one tmax for all (the median distance of
  // their hits), no tmin (0).
  const auto rays = primary_rays(auto_camera(scene.bounds()), 40, 30);
  std::vector<Ray> same_origin = rays;
  std::vector<float> directions;
  for (Ray& r : same_origin) {
    std::memcpy(r.org, rays[0].org, 12);
    r.tmin = 0;
    directions.insert(directions.end(), r.dir, r.dir + 3);
  }
  std::vector<Hit> records(rays.size());
  grid->trace(same_origin, records, Query::closest);
  std::vector<float> distances;
  for (const Hit& h : records)
    if (h.hit()) distances.push_back(h.t);
  ASSERT_GT(distances.size(), rays.size() / 4);
  std::nth_element(distances.begin(), distances.begin() + distances.size() / 2, distances.end());
  const float tmax = distances[distances.size() / 2];
  for (Ray& r : same_origin)
    r.tmax = tmax;
  grid->trace(same_origin, records, Query::closest);
  RayArrays in;
  in.count = rays.size();
  in.origins = rays[0].org, in.origin_stride = 0;
  in.directions = directions.data();
  in.tmax = &tmax;
  // Only t and prim, into interleaved (t, prim) pairs; u, v and normals unset.
  std::vector<std::uint32_t> pairs(2 * rays.size(), 7);
  HitArrays out;
  out.t = reinterpret_cast<float*>(pairs.data()), out.t_stride = 2;
  out.prim = pairs.data() + 1, out.prim_stride = 2;
  grid->trace(in, out, Query::closest);
  std::size_t wrong = 0, hits = 0;
  for (std::size_t i = 0; i < rays.size(); ++i) {
    float t;
    std::memcpy(&t, &pairs[2 * i], 4);
    hits += records[i].hit();
    wrong += pairs[2 * i + 1] != records[i].prim || t != records[i].t;
  }
  EXPECT_EQ(wrong, 0u);
  EXPECT_GT(hits, distances.size() / 3);
  EXPECT_LT(hits, distances.size());  // tmax cuts some rays short
  // No outputs at all: traces, writes nothing, does not fail.
  EXPECT_NO_THROW(grid->trace(in, HitArrays{}, Query::any));
}

TEST(RayArrays, BadArraysAreClearErrors) {
  const Scene scene = load_scene("builtin:cornell");
  const auto grid = make_accelerator(scene, Structure::irregular);
  const auto brute = make_accelerator(scene, Structure::brute);
  std::vector<float> rows(60, 0.f);
  std::vector<float> t(10);
  HitArrays out;
  out.t = t.data();
  for (const Accelerator* a : {grid.get(), brute.get()}) {
    RayArrays no_directions;
    no_directions.count = 10, no_directions.origins = rows.data();
    try {
      a->trace(no_directions, out, Query::closest);
      ADD_FAILURE() << "no directions accepted";
    } catch (const Error& e) {
      EXPECT_EQ(e.code(), ErrorCode::invalid_argument);
      EXPECT_NE(std::string(e.what()).find("directions"), std::string::npos) << e.what();
    }
    RayArrays huge_stride;
    huge_stride.count = 10, huge_stride.origins = rows.data(), huge_stride.directions = rows.data();
    huge_stride.direction_stride = std::size_t(1) << 26;
    try {
      a->trace(huge_stride, out, Query::closest);
      ADD_FAILURE() << "a stride of 2^26 accepted";
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find("direction_stride 67108864"), std::string::npos)
          << e.what();
    }
    // No rays: nothing to read, so null arrays are fine.
    EXPECT_NO_THROW(a->trace(RayArrays{}, out, Query::closest));
  }
}

TEST(RayArrays, AnEmptySceneMissesEveryRay) {
  const std::vector<float> no_vertices;
  const std::vector<std::uint32_t> no_triangles;
  const TriangleMesh empty{no_vertices.data(), 0, 12, no_triangles.data(), 0};
  const auto grid = make_accelerator(empty, Structure::irregular);
  const std::vector<float> rows = {0, 0, 0, 1, 0, 0, 0, 0, 0, 0, 1, 0};
  RayArrays in;
  in.count = 2, in.origins = rows.data(), in.origin_stride = 6;
  in.directions = rows.data() + 3, in.direction_stride = 6;
  SplitHits out(2);
  grid->trace(in, out.arrays(), Query::closest);
  for (int i = 0; i < 2; ++i) {
    EXPECT_EQ(out.prim[i], kNoHit);
    EXPECT_TRUE(std::isinf(out.t[i]));
    EXPECT_EQ(out.normals[3 * i], 0.f);
  }
}

}  // namespace
}  // namespace irgrid
