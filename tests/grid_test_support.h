// tests/grid_test_support.h: building a grid directly from a scene for the grid tests.
#pragma once

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cctype>
#include <cstdint>
#include <cstring>
#include <limits>
#include <map>
#include <string>
#include <string_view>
#include <vector>

#include "core/construction/build_grid.h"
#include "core/triangle_box.h"
#include "cpu/cpu_executor.h"
#include "cpu/structures.h"
#include "irgrid/io/random.h"
#include "irgrid/io/rays.h"
#include "irgrid/io/scene.h"

namespace irgrid::testing {

/// The initial grid of the paper's §3.1: no merging, no expansion (tests of those phases start
/// from it; tests of the whole build pass BuildConfig{}).
inline BuildConfig initial_grid_config() {
  BuildConfig config;
  config.alpha = 0;
  config.expansion_passes = 0;
  return config;
}

inline GridArrays<CpuExecutor> build_test_grid(const Scene& scene,
                                               const BuildConfig& config = initial_grid_config()) {
  CpuExecutor exec;
  GridArrays<CpuExecutor> grid;
  gather_triangles(scene.mesh(), grid.triangles);
  PhaseTimes phases;
  build_grid(exec, grid, config, phases);
  return grid;
}

/// A GoogleTest name for a parameter "builtin:NAME[:N]": NAME[_N], other characters as '_'.
inline std::string builtin_scene_test_name(const ::testing::TestParamInfo<std::string>& info) {
  std::string name = info.param.substr(std::string_view("builtin:").size());
  for (char& c : name)
    if (!std::isalnum(static_cast<unsigned char>(c))) c = '_';
  return name;
}

/// Whether two arrays (of the same element type) hold the same bytes; empty ones, whose data()
/// may be null, are equal without a memcmp.
template <typename ArrayA, typename ArrayB>
bool same_bytes(const ArrayA& a, const ArrayB& b) {
  static_assert(sizeof(*a.data()) == sizeof(*b.data()));
  return a.size() == b.size() &&
         (a.size() == 0 || std::memcmp(a.data(), b.data(), a.size() * sizeof(*a.data())) == 0);
}

/// Expects two grids to be equal bit for bit: scalars, voxel map (and its level offsets), cells,
/// references and empty radii. The grids may come from different executors.
template <typename GridA, typename GridB>
void expect_same_grid(const GridA& a, const GridB& b) {
  ASSERT_EQ(std::memcmp(&a.info, &b.info, sizeof(GridInfo)), 0);
  EXPECT_EQ(a.level_offsets, b.level_offsets);
  ASSERT_EQ(a.entries.size(), b.entries.size());
  EXPECT_TRUE(same_bytes(a.entries, b.entries));
  ASSERT_EQ(a.cells.size(), b.cells.size());
  EXPECT_TRUE(same_bytes(a.cells, b.cells));
  EXPECT_TRUE(std::equal(a.refs.begin(), a.refs.end(), b.refs.begin(), b.refs.end()));
  EXPECT_TRUE(std::equal(a.empty_radii.begin(), a.empty_radii.end(), b.empty_radii.begin(),
                         b.empty_radii.end()));
}

inline std::uint64_t cell_volume(const Cell& c) {
  return std::uint64_t(c.hi[0] - c.lo[0]) * std::uint64_t(c.hi[1] - c.lo[1]) *
         std::uint64_t(c.hi[2] - c.lo[2]);
}

/// Every cell lies inside the virtual grid and their volumes add up to the grid's (with the voxel
/// map checks of the callers, this shows the cells tile the grid without overlap).
inline void expect_cells_tile_grid(const GridArrays<CpuExecutor>& grid) {
  const GridInfo& info = grid.info;
  ASSERT_EQ(grid.cells.size(), info.num_cells);
  std::uint64_t volume = 0;
  for (const Cell& c : grid.cells) {
    for (int a = 0; a < 3; ++a) {
      ASSERT_LE(0, c.lo[a]);
      ASSERT_LT(c.lo[a], c.hi[a]);
      ASSERT_LE(c.hi[a], info.virtual_dims[a]);
    }
    volume += cell_volume(c);
  }
  EXPECT_EQ(volume,
            std::uint64_t(info.virtual_dims[0]) * info.virtual_dims[1] * info.virtual_dims[2]);
}

/// A scene of the given triangles (invalid ones dropped, as the loaders do).
inline Scene scene_from_triangles(const std::vector<std::array<Vec3f, 3>>& triangles) {
  Scene scene;
  scene.name = "test";
  for (const auto& tri : triangles) {
    const auto base = std::uint32_t(scene.vertices.size());
    for (const auto& v : tri)
      scene.vertices.push_back(v);
    scene.triangles.push_back({base, base + 1, base + 2});
  }
  drop_invalid_triangles(scene);
  return scene;
}

/// An n x n grid of unit squares in the plane z = 0, two triangles each: a flat scene.
inline std::vector<std::array<Vec3f, 3>> flat_mesh_triangles(int n) {
  std::vector<std::array<Vec3f, 3>> triangles;
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) {
      const float x = float(i), y = float(j);
      triangles.push_back({{{x, y, 0}, {x + 1, y, 0}, {x + 1, y + 1, 0}}});
      triangles.push_back({{{x, y, 0}, {x + 1, y + 1, 0}, {x, y + 1, 0}}});
    }
  return triangles;
}

/// A unit square beside a sliver 100,000 units long and one unit wide: the scene's box is thin on
/// two axes, its padding (relative to the largest coordinate) near a unit.
inline std::vector<std::array<Vec3f, 3>> sliver_beside_square_triangles() {
  return {{{{0, 0, 0}, {1, 0, 0}, {1, 1, 0}}},
          {{{0, 0, 0}, {1, 1, 0}, {0, 1, 0}}},
          {{{0, 0, 0}, {1e5f, 0, 0}, {1e5f, 1, 1}}}};
}

/// Rays from within 0.71 units of the plane of sliver_beside_square_triangles()'s sliver
/// (y = z), anywhere along its length, in random directions. Its far vertices then lie far along
/// the ray on both of its sides, where the float test's t cancels (irgrid/kernel/watertight.h,
/// t_needs_double): before its redo in double, 5% of such rays got a wrong hit or miss.
inline std::vector<Ray> rays_near_the_slivers_plane(int count, std::uint64_t seed) {
  Pcg32 rng;
  rng.seed(seed);
  std::vector<Ray> rays(count);
  for (Ray& ray : rays) {
    const float x = 1e5f * rng.next_float(), off_plane = 2 * rng.next_float() - 1;
    const float y = rng.next_float() + 0.5f * off_plane;
    ray.org[0] = x, ray.org[1] = y, ray.org[2] = y - off_plane;
    for (float& d : ray.dir)
      d = 2 * rng.next_float() - 1;
    ray.tmin = 0;
    ray.tmax = std::numeric_limits<float>::infinity();
  }
  return rays;
}

/// Distance from `point` to the nearest point of the edges of triangle `prim`.
inline double distance_to_triangle_edges(const Scene& scene, std::uint32_t prim,
                                         const Vec3d& point) {
  double nearest = std::numeric_limits<double>::infinity();
  for (int e = 0; e < 3; ++e) {
    const Vec3d a = Vec3d::from(scene.vertices[scene.triangles[prim][e]]);
    const Vec3d ab = Vec3d::from(scene.vertices[scene.triangles[prim][(e + 1) % 3]]) - a;
    const double s = std::clamp(dot(point - a, ab) / dot(ab, ab), 0.0, 1.0);
    nearest = std::min(nearest, length(point - (a + ab * s)));
  }
  return nearest;
}

/// Expects closest hits equal to the double reference's up to a relative 1e-3 in t, except
/// where float and double may legitimately differ: a hit within `margin` of its triangle's
/// edges (which a float hit off the plane is not). Stricter than validate_hits, whose tolerance
/// is relative to the scene's size (a unit on the sliver's scene, as wide as the sliver).
inline void expect_hits_match_reference(const Scene& scene, const std::vector<Ray>& rays,
                                        const std::vector<Hit>& hits,
                                        const std::vector<Hit>& reference, double margin,
                                        const std::string& what) {
  const auto fragile = [&](const Ray& ray, const Hit& hit) {
    return hit.hit() && distance_to_triangle_edges(
                            scene, hit.prim,
                            Vec3d::from(ray.org) + Vec3d::from(ray.dir) * double(hit.t)) <= margin;
  };
  const auto distance = [](const Hit& hit) {
    return hit.hit() ? double(hit.t) : std::numeric_limits<double>::infinity();
  };
  int wrong = 0;
  for (std::size_t i = 0; i < rays.size(); ++i) {
    const Hit &got = hits[i], &want = reference[i];
    const double slack = 1e-3 * std::max(1.0, std::abs(distance(want)));
    bool ok;
    if (got.prim == want.prim)
      ok = !got.hit() || std::abs(distance(got) - distance(want)) <= slack;
    else  // wrong when either side has a robust hit clearly before the other's answer
      ok = !(!fragile(rays[i], got) && distance(got) < distance(want) - slack) &&
           !(!fragile(rays[i], want) && distance(want) < distance(got) - slack);
    if (!ok && ++wrong <= 3)
      ADD_FAILURE() << what << ": ray " << i << " hit " << got.prim << " at t=" << got.t
                    << ", reference " << want.prim << " at t=" << want.t;
  }
  EXPECT_EQ(wrong, 0) << what << " (of " << rays.size() << " rays)";
}

/// The voxel map answers every cell's 8 corner voxels with that cell, and 20000 random voxels
/// (drawn with `seed`) with a cell whose box holds them. For grids whose cells hold their entry
/// boxes (before expansion).
inline void expect_voxel_map_finds_owners(const GridArrays<CpuExecutor>& grid, std::uint64_t seed) {
  const GridInfo& info = grid.info;
  for (std::uint32_t id = 0; id < info.num_cells; ++id) {
    const Cell& c = grid.cells[id];
    for (int corner = 0; corner < 8; ++corner) {
      const Voxel v{(corner & 1) ? c.hi[0] - 1 : c.lo[0], (corner & 2) ? c.hi[1] - 1 : c.lo[1],
                    (corner & 4) ? c.hi[2] - 1 : c.lo[2]};
      ASSERT_EQ(lookup_cell(info, grid.entries.data(), v), id) << "corner " << corner;
    }
  }
  Pcg32 rng;
  rng.seed(seed);
  for (int k = 0; k < 20000; ++k) {
    const Voxel v{std::int32_t(rng.next_u32() % std::uint32_t(info.virtual_dims[0])),
                  std::int32_t(rng.next_u32() % std::uint32_t(info.virtual_dims[1])),
                  std::int32_t(rng.next_u32() % std::uint32_t(info.virtual_dims[2]))};
    const std::uint32_t id = lookup_cell(info, grid.entries.data(), v);
    ASSERT_LT(id, info.num_cells);
    const Cell& c = grid.cells[id];
    for (int a = 0; a < 3; ++a)
      ASSERT_TRUE(c.lo[a] <= v[a] && v[a] < c.hi[a]) << "voxel outside its cell";
  }
}

/// Checks, on every cell of small grids and an even sample of about 1500 cells of larger ones,
/// that every triangle overlapping the cell's exit box grown by `padding` is in its list
/// (stopping at the first one missing). Returns the number of overlapping pairs seen.
inline std::size_t check_lists_cover_exit_boxes(const GridArrays<CpuExecutor>& grid, float padding,
                                                const std::string& what) {
  const GridInfo& info = grid.info;
  std::size_t overlaps = 0;
  const std::size_t stride = std::max<std::size_t>(1, grid.cells.size() / 1500);
  for (std::size_t id = 0; id < grid.cells.size(); id += stride) {
    const Cell& c = grid.cells[id];
    Vec3<float> lo, hi;
    for (int a = 0; a < 3; ++a)
      lo[a] = voxel_to_world(info, a, c.lo[a]), hi[a] = voxel_to_world(info, a, c.hi[a]);
    const auto* list_begin = grid.refs.data() + c.begin;
    const auto* list_end = grid.refs.data() + c.end;
    for (std::uint32_t t = 0; t < info.num_triangles; ++t) {
      const auto& tri = grid.triangles[t];
      if (!triangle_overlaps_box(tri.p0, tri.p1, tri.p2, lo, hi, padding)) continue;
      ++overlaps;
      EXPECT_TRUE(std::binary_search(list_begin, list_end, t))
          << what << ": triangle " << t << " touches the exit box of cell " << id
          << " but is not in its list";
      if (!std::binary_search(list_begin, list_end, t)) return overlaps;
    }
  }
  return overlaps;
}

/// Appends `ray` and the same line started `distance` behind its origin with tmin 0 and no
/// tmax: a walk that enters the grid from far outside.
inline void append_with_far_start(std::vector<Ray>& rays, const Ray& ray, float distance) {
  rays.push_back(ray);
  Ray from_outside = ray;
  for (int b = 0; b < 3; ++b)
    from_outside.org[b] -= distance * ray.dir[b];
  from_outside.tmin = 0, from_outside.tmax = std::numeric_limits<float>::infinity();
  rays.push_back(from_outside);
}

/// Appends axis-parallel rays from outside the scene through the first vertex and the first
/// edge's midpoint of each of the first 300 triangles, along each axis.
inline void append_axis_rays_through_vertices(const Scene& scene, std::vector<Ray>& rays) {
  constexpr float kInf = std::numeric_limits<float>::infinity();
  for (std::size_t t = 0; t < scene.triangles.size() && t < 300; ++t) {
    const auto& v = scene.vertices[scene.triangles[t][0]];
    const auto& w = scene.vertices[scene.triangles[t][1]];
    for (int a = 0; a < 3; ++a) {
      Ray ray{{v[0], v[1], v[2]}, 0, {0, 0, 0}, kInf};
      ray.org[a] = scene.bounds().lo[a] - 1;
      ray.dir[a] = 1;
      rays.push_back(ray);
      Ray mid{
          {0.5f * (v[0] + w[0]), 0.5f * (v[1] + w[1]), 0.5f * (v[2] + w[2])}, 0, {0, 0, 0}, kInf};
      mid.org[a] = scene.bounds().hi[a] + 1;
      mid.dir[a] = -1;
      rays.push_back(mid);
    }
  }
}

}  // namespace irgrid::testing
