// cpu/simd_walk.cpp: the AVX2 walk of cpu/simd_walk.h.
//
// Every lane-wise operation below mirrors one line of core/grid/traverse.h or core/watertight.h
// with the same float operations in the same order (no FMA: -ffp-contract=off, and AVX2 alone
// has none), and _mm256_min_ps / _mm256_max_ps return their second operand on NaN exactly as
// min_fast(a, b) = a < b ? a : b does. Only the headers' scalar code is compiled for the
// baseline target; the functions of this file get AVX2 from the pragma below and run only when
// simd_walk_supported() says the CPU has it.
#include "cpu/simd_walk.h"

#include <immintrin.h>

#include <cstddef>
#include <cstdint>
#include <cstring>

namespace irgrid {

bool simd_walk_supported(const GridInfo& info) {
  static const bool has_avx2 = __builtin_cpu_supports("avx2");
  return has_avx2 && std::uint64_t(info.num_triangles) * 9 < (1ull << 31) &&
         std::uint64_t(info.num_cells + 1) * 4 < (1ull << 31);
}

#pragma GCC push_options
#pragma GCC target("avx2")

namespace {

constexpr int L = kSimdWalkLanes;

/// The walks' per-ray values, one array slot per lane (structure of arrays). Every member is a
/// row of L 4-byte values, so a lane moves as a column (copy_lane).
struct alignas(32) Lanes {
  float org[3][L];               // WalkRay::org
  float dir[3][L];               // WalkRay::dir
  float t_per_voxel[3][L];       // WalkRay::t_per_voxel
  float t_at_plane0[3][L];       // WalkRay::t_at_plane0
  std::int32_t ascending[3][L];  // WalkRay::ascending, as -1 (true) or 0
  std::int32_t voxel[3][L];      // GridWalk::voxel
  float t_leave[L];
  float best_t[L], best_u[L], best_v[L];  // GridWalk::best
  std::int32_t best_prim[L];
  float org_k[3][L];        // WatertightRay::org_k
  float shear[3][L];        // WatertightRay::sx, sy, sz
  float tmin[L], tmax[L];   // WatertightRay::tmin, tmax
  std::int32_t axis[3][L];  // WatertightRay::kx, ky, kz
};
constexpr std::size_t kLaneRows = sizeof(Lanes) / (4 * L);
static_assert(sizeof(Lanes) == kLaneRows * 4 * L, "Lanes holds rows of L 4-byte values only");

/// Copies the walk in slot `from_lane` of `from` into lane `lane` of `to`.
void copy_lane(Lanes& to, int lane, const Lanes& from, int from_lane) {
  auto* t = reinterpret_cast<unsigned char*>(&to);
  const auto* f = reinterpret_cast<const unsigned char*>(&from);
#pragma GCC unroll 64
  for (std::size_t row = 0; row < kLaneRows; ++row)
    std::memcpy(t + (row * L + lane) * 4, f + (row * L + from_lane) * 4, 4);
}

/// The cell each lane is in, per round.
struct alignas(32) LaneCells {
  std::int32_t lo[3][L], hi[3][L];  // exit box
  std::int32_t begin[L], end[L];    // references
};

inline __m256 load(const float* p) {
  return _mm256_load_ps(p);
}
inline __m256i load(const std::int32_t* p) {
  return _mm256_load_si256(reinterpret_cast<const __m256i*>(p));
}
inline void store(std::int32_t* p, __m256i v) {
  _mm256_store_si256(reinterpret_cast<__m256i*>(p), v);
}
inline __m256i as_int(__m256 v) {
  return _mm256_castps_si256(v);
}
inline __m256 as_float(__m256i v) {
  return _mm256_castsi256_ps(v);
}
inline std::uint32_t lane_bits(__m256i mask) {
  return std::uint32_t(_mm256_movemask_ps(as_float(mask)));
}
/// All ones in the lanes whose bit is set in `bits`.
inline __m256i lanes_of(std::uint32_t bits) {
  const __m256i bit = _mm256_setr_epi32(1, 2, 4, 8, 16, 32, 64, 128);
  return _mm256_cmpeq_epi32(_mm256_and_si256(_mm256_set1_epi32(int(bits)), bit), bit);
}
inline __m256i gather(const void* base, __m256i index, __m256i mask) {
  return _mm256_mask_i32gather_epi32(_mm256_setzero_si256(), static_cast<const int*>(base), index,
                                     mask, 4);
}
inline __m256 gather(const float* base, __m256i index, __m256i mask) {
  return _mm256_mask_i32gather_ps(_mm256_setzero_ps(), base, index, as_float(mask), 4);
}

/// Per lane: a if the lane's bit of `mask` is clear, b if it is set.
inline __m256 select(__m256i mask, __m256 a, __m256 b) {
  return _mm256_blendv_ps(a, b, as_float(mask));
}
inline __m256i select(__m256i mask, __m256i a, __m256i b) {
  return _mm256_blendv_epi8(a, b, mask);
}
/// Per lane: v[k] for k in 0..2.
inline __m256 pick(const __m256 v[3], __m256i k) {
  return select(_mm256_cmpeq_epi32(k, _mm256_set1_epi32(2)),
                select(_mm256_cmpeq_epi32(k, _mm256_set1_epi32(1)), v[0], v[1]), v[2]);
}

/// walk_position, lane-wise: the walk position at t on axis a, in voxels.
inline __m256 walk_position(const GridInfo& info, int a, __m256 walk_org, __m256 walk_dir,
                            __m256 t) {
  return _mm256_add_ps(
      walk_org, _mm256_mul_ps(_mm256_mul_ps(t, walk_dir), _mm256_set1_ps(info.inv_voxel_size[a])));
}
/// voxel_at, lane-wise: the voxel holding position p on axis a, clamped to the grid.
inline __m256i voxel_at(const GridInfo& info, int a, __m256 p) {
  return _mm256_cvttps_epi32(_mm256_min_ps(_mm256_max_ps(p, _mm256_setzero_ps()),
                                           _mm256_set1_ps(float(info.virtual_dims[a] - 1))));
}

/// begin_walk, lane-wise, for the lanes of `starting`: lane l begins rays[l] (read with
/// gathers). Writes the walks into s and returns the lanes whose ray enters the grid (where
/// begin_walk returns true); the other lanes of s hold no walk.
__m256i begin_walks(const GridInfo& info, const Ray* rays, Lanes& s, __m256i starting) {
  const float* base = &rays[0].org[0];
  const __m256i field = _mm256_setr_epi32(0, 8, 16, 24, 32, 40, 48, 56);  // 8 floats per ray
  const auto read = [&](int f) {
    return gather(base, _mm256_add_epi32(field, _mm256_set1_epi32(f)), starting);
  };
  const __m256 org[3] = {read(0), read(1), read(2)}, tmin = read(3);
  const __m256 dir[3] = {read(4), read(5), read(6)}, tmax = read(7);
  const __m256 zero = _mm256_setzero_ps(), one = _mm256_set1_ps(1.f);
  const __m256 infinity = _mm256_set1_ps(INFINITY);
  const __m256 all_ones = as_float(_mm256_set1_epi32(-1));
  __m256 inv_dir[3];
  for (int a = 0; a < 3; ++a)
    inv_dir[a] = _mm256_div_ps(one, dir[a]);
  // clip_to_grid
  __m256 t_enter = tmin, t_leave = tmax;
  for (int a = 0; a < 3; ++a) {
    const __m256 lo = _mm256_set1_ps(info.box_lo[a]), hi = _mm256_set1_ps(info.box_hi[a]);
    const __m256i flat = as_int(_mm256_cmp_ps(dir[a], zero, _CMP_EQ_OQ));
    const __m256i outside = as_int(
        _mm256_or_ps(_mm256_cmp_ps(org[a], lo, _CMP_LT_OQ), _mm256_cmp_ps(org[a], hi, _CMP_GT_OQ)));
    const __m256 t0 = _mm256_mul_ps(_mm256_sub_ps(lo, org[a]), inv_dir[a]);
    const __m256 t1 = _mm256_mul_ps(_mm256_sub_ps(hi, org[a]), inv_dir[a]);
    const __m256i swap = as_int(_mm256_cmp_ps(t0, t1, _CMP_GT_OQ));
    const __m256 near = select(swap, t0, t1), far = select(swap, t1, t0);
    const __m256i missed = _mm256_and_si256(flat, outside);
    t_enter = select(flat, _mm256_max_ps(near, t_enter), select(missed, t_enter, one));
    t_leave = select(flat, _mm256_min_ps(far, t_leave), select(missed, t_leave, zero));
  }
  const __m256i enters =
      _mm256_and_si256(starting, as_int(_mm256_cmp_ps(t_enter, t_leave, _CMP_LE_OQ)));
  // make_watertight_ray
  __m256 magnitude[3];
  for (int a = 0; a < 3; ++a)
    magnitude[a] = select(as_int(_mm256_cmp_ps(dir[a], zero, _CMP_LT_OQ)), dir[a],
                          _mm256_sub_ps(zero, dir[a]));
  const __m256i x_largest =
      as_int(_mm256_and_ps(_mm256_cmp_ps(magnitude[0], magnitude[1], _CMP_GE_OQ),
                           _mm256_cmp_ps(magnitude[0], magnitude[2], _CMP_GE_OQ)));
  const __m256i y_over_z = as_int(_mm256_cmp_ps(magnitude[1], magnitude[2], _CMP_GE_OQ));
  const __m256i c0 = _mm256_setzero_si256(), c1 = _mm256_set1_epi32(1), c2 = _mm256_set1_epi32(2);
  const __m256i kz = select(x_largest, select(y_over_z, c2, c1), c0);
  const __m256i kx0 = select(_mm256_cmpeq_epi32(kz, c2), _mm256_add_epi32(kz, c1), c0);
  const __m256i ky0 = select(_mm256_cmpeq_epi32(kx0, c2), _mm256_add_epi32(kx0, c1), c0);
  const __m256 dir_z = pick(dir, kz);
  const __m256i flip = as_int(_mm256_cmp_ps(dir_z, zero, _CMP_LT_OQ));
  const __m256i kx = select(flip, kx0, ky0), ky = select(flip, ky0, kx0);
  const __m256 shear[3] = {_mm256_div_ps(pick(dir, kx), dir_z), _mm256_div_ps(pick(dir, ky), dir_z),
                           _mm256_div_ps(one, dir_z)};
  const __m256i axis[3] = {kx, ky, kz};
  for (int k = 0; k < 3; ++k) {
    _mm256_store_ps(s.org_k[k], pick(org, axis[k]));
    _mm256_store_ps(s.shear[k], shear[k]);
    store(s.axis[k], axis[k]);
  }
  _mm256_store_ps(s.tmin, tmin);
  _mm256_store_ps(s.tmax, tmax);
  _mm256_store_ps(s.t_leave, t_leave);
  _mm256_store_ps(s.best_t, tmax);
  _mm256_store_ps(s.best_u, zero);
  _mm256_store_ps(s.best_v, zero);
  store(s.best_prim, _mm256_set1_epi32(int(kNoHit)));
  // make_walk_ray, then the entry voxel
  for (int a = 0; a < 3; ++a) {
    const __m256 walk_org = _mm256_mul_ps(_mm256_sub_ps(org[a], _mm256_set1_ps(info.box_lo[a])),
                                          _mm256_set1_ps(info.inv_voxel_size[a]));
    const __m256 t_per_voxel = _mm256_mul_ps(_mm256_set1_ps(info.voxel_size[a]), inv_dir[a]);
    const __m256 t_at_plane0 =
        _mm256_mul_ps(_mm256_sub_ps(_mm256_set1_ps(info.box_lo[a]), org[a]), inv_dir[a]);
    const __m256 finite_limit = _mm256_set1_ps(-INFINITY);
    const auto finite = [&](__m256 v) {
      return _mm256_and_ps(_mm256_cmp_ps(v, finite_limit, _CMP_GT_OQ),
                           _mm256_cmp_ps(v, infinity, _CMP_LT_OQ));
    };
    const __m256 flat_axis = info.inv_voxel_size[a] == 0.f ? all_ones : zero;
    const __m256i parallel = as_int(_mm256_or_ps(
        _mm256_or_ps(_mm256_cmp_ps(dir[a], zero, _CMP_EQ_OQ), flat_axis),
        _mm256_andnot_ps(_mm256_and_ps(finite(t_per_voxel), finite(t_at_plane0)), all_ones)));
    const __m256 walk_dir = select(parallel, dir[a], zero);
    _mm256_store_ps(s.org[a], walk_org);
    _mm256_store_ps(s.dir[a], walk_dir);
    _mm256_store_ps(s.t_per_voxel[a], select(parallel, t_per_voxel, zero));
    _mm256_store_ps(s.t_at_plane0[a], select(parallel, t_at_plane0, infinity));
    store(s.ascending[a], as_int(_mm256_cmp_ps(walk_dir, zero, _CMP_NLT_UQ)));
    const __m256 position = select(as_int(_mm256_cmp_ps(walk_dir, zero, _CMP_EQ_OQ)),
                                   walk_position(info, a, walk_org, walk_dir, t_enter), walk_org);
    store(s.voxel[a], voxel_at(info, a, position));
  }
  return enters;
}

/// Field `offset` (in bytes) of the structs of `stride` bytes at `base`, for the cells `index`
/// of the lanes of `mask` (0 elsewhere).
template <int kOffset, int kStride>
inline __m256i gather_field(const void* base, __m256i index, __m256i mask) {
  static_assert(kStride % 8 == 0, "gathers scale indices by at most 8");
  const auto* field = reinterpret_cast<const int*>(static_cast<const char*>(base) + kOffset);
  const __m256i scaled = _mm256_mullo_epi32(index, _mm256_set1_epi32(kStride / 8));
  return _mm256_mask_i32gather_epi32(_mm256_setzero_si256(), field, scaled, mask, 8);
}

/// load_cell, lane-wise: the cells `index` of the lanes of `mask` into c.
void load_cells(const Cell* cells, __m256i index, __m256i mask, LaneCells& c) {
  static_assert(offsetof(Cell, begin) == 12 && offsetof(Cell, hi) == 16 &&
                offsetof(Cell, end) == 28);
  store(c.lo[0], gather_field<0, 32>(cells, index, mask));
  store(c.lo[1], gather_field<4, 32>(cells, index, mask));
  store(c.lo[2], gather_field<8, 32>(cells, index, mask));
  store(c.begin, gather_field<12, 32>(cells, index, mask));
  store(c.hi[0], gather_field<16, 32>(cells, index, mask));
  store(c.hi[1], gather_field<20, 32>(cells, index, mask));
  store(c.hi[2], gather_field<24, 32>(cells, index, mask));
  store(c.end, gather_field<28, 32>(cells, index, mask));
}
void load_cells(const CompactCell* cells, __m256i index, __m256i mask, LaneCells& c) {
  static_assert(offsetof(CompactCell, hi) == 6 && offsetof(CompactCell, begin) == 12);
  const __m256i low16 = _mm256_set1_epi32(0xffff);
  const __m256i lo01 = gather_field<0, 16>(cells, index, mask);  // lo[0], lo[1]
  const __m256i lo2hi0 = gather_field<4, 16>(cells, index, mask);
  const __m256i hi12 = gather_field<8, 16>(cells, index, mask);
  store(c.lo[0], _mm256_and_si256(lo01, low16));
  store(c.lo[1], _mm256_srli_epi32(lo01, 16));
  store(c.lo[2], _mm256_and_si256(lo2hi0, low16));
  store(c.hi[0], _mm256_srli_epi32(lo2hi0, 16));
  store(c.hi[1], _mm256_and_si256(hi12, low16));
  store(c.hi[2], _mm256_srli_epi32(hi12, 16));
  store(c.begin, gather_field<12, 16>(cells, index, mask));
  store(c.end, gather_field<16 + 12, 16>(cells, index, mask));  // the next cell's begin
}

/// cell_exit, lane-wise: the far plane and its t per axis, and the nearest t capped at t_leave.
struct LaneExit {
  __m256i far[3];
  __m256 t_axis[3];
  __m256 t_exit;
};

LaneExit cell_exits(const Lanes& s, const LaneCells& c) {
  LaneExit e;
  e.t_exit = load(s.t_leave);
  for (int a = 0; a < 3; ++a) {
    e.far[a] = _mm256_blendv_epi8(load(c.lo[a]), load(c.hi[a]), load(s.ascending[a]));
    e.t_axis[a] = _mm256_add_ps(_mm256_mul_ps(_mm256_cvtepi32_ps(e.far[a]), load(s.t_per_voxel[a])),
                                load(s.t_at_plane0[a]));
    e.t_exit = _mm256_min_ps(e.t_axis[a], e.t_exit);
  }
  return e;
}

/// The triangle tests of one round, packed from the cells of all lanes, each lane's in its
/// reference order: test p is triangle prim[p] against the ray of lane lane[p]. They run in
/// batches of kSimdWalkLanes.
struct alignas(32) TestList {
  static constexpr int kCapacity = 16 * L;
  // Appends write whole rows of L, so each array has L slots of slack; slots past `size` stay
  // valid lanes for the permutes.
  std::int32_t lane[kCapacity + L] = {};
  std::uint32_t prim[kCapacity + L] = {};
  std::int32_t ordinal[kCapacity + L];  // the test's place among its cell's references
  int size = 0;

  /// Appends the tests of lane `l` against refs[k] for k < count (count <= L and <= the room
  /// left), with ordinals from `ordinal0`: one masked row, no branch.
  void append_row(int l, const std::uint32_t* refs, int count, int ordinal0) {
    const __m256i iota = _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7);
    const __m256i valid = _mm256_cmpgt_epi32(_mm256_set1_epi32(count), iota);
    const __m256i ids =
        _mm256_maskload_epi32(reinterpret_cast<const int*>(refs), valid);  // no overread
    _mm256_storeu_si256(reinterpret_cast<__m256i*>(prim + size), ids);
    _mm256_storeu_si256(reinterpret_cast<__m256i*>(lane + size), _mm256_set1_epi32(l));
    _mm256_storeu_si256(reinterpret_cast<__m256i*>(ordinal + size),
                        _mm256_add_epi32(iota, _mm256_set1_epi32(ordinal0)));
    size += count;
  }
  /// append_row for any count <= the room left.
  void append(int l, const std::uint32_t* refs, int count, int ordinal0) {
    for (int j = 0; j < count; j += L)
      append_row(l, refs + j, count - j < L ? count - j : L, ordinal0 + j);
  }
};
static_assert(TestList::kCapacity >= L * L, "L cells of at most L references each fit the list");

/// What the lane-wise triangle test found for a batch of tests, bit p for test first + p.
struct alignas(32) BatchHits {
  float t[L], u[L], v[L];  // where `hits` has the bit: intersect_watertight's hit
  std::uint32_t hits;      // intersect_watertight returns true
  std::uint32_t scalar;    // left to the scalar test (an edge function is zero, or not a number)
};

/// intersect_watertight, lane-wise, for tests first + p (p < count <= kSimdWalkLanes, first a
/// multiple of it) of `tests`, against the rays of their lanes, with the same operations in the
/// same order. Tests whose edge functions are not all nonzero numbers are left to the scalar
/// test (its double-precision redo of zero edge functions).
void test_triangles(const GridView& grid, const Lanes& s, const TestList& tests, int first,
                    int count, BatchHits& out) {
  const __m256i slots = lanes_of((1u << count) - 1);
  const float* coords = &grid.triangles[0].p0.x;
  const __m256i lane = load(tests.lane + first);
  const __m256i prim = load(reinterpret_cast<const std::int32_t*>(tests.prim + first));
  const __m256i base = _mm256_add_epi32(_mm256_slli_epi32(prim, 3), prim);  // 9 floats each
  // Each test takes its lane's ray constants.
  const auto ray_int = [&](const std::int32_t* v) {
    return _mm256_permutevar8x32_epi32(load(v), lane);
  };
  const auto ray_float = [&](const float* v) { return _mm256_permutevar8x32_ps(load(v), lane); };
  const __m256i kx = ray_int(s.axis[0]), ky = ray_int(s.axis[1]), kz = ray_int(s.axis[2]);
  const __m256 ox = ray_float(s.org_k[0]), oy = ray_float(s.org_k[1]), oz = ray_float(s.org_k[2]);
  const __m256 sx = ray_float(s.shear[0]), sy = ray_float(s.shear[1]), sz = ray_float(s.shear[2]);
  __m256 x[3], y[3], z[3];
  for (int j = 0; j < 3; ++j) {  // shear_vertex for p0, p1, p2
    const __m256i vertex = _mm256_add_epi32(base, _mm256_set1_epi32(3 * j));
    const __m256 px = gather(coords, _mm256_add_epi32(vertex, kx), slots);
    const __m256 py = gather(coords, _mm256_add_epi32(vertex, ky), slots);
    const __m256 pz = _mm256_sub_ps(gather(coords, _mm256_add_epi32(vertex, kz), slots), oz);
    x[j] = _mm256_sub_ps(_mm256_sub_ps(px, ox), _mm256_mul_ps(sx, pz));
    y[j] = _mm256_sub_ps(_mm256_sub_ps(py, oy), _mm256_mul_ps(sy, pz));
    z[j] = _mm256_mul_ps(sz, pz);
  }
  // a = p0, b = p1, c = p2: u = c_x b_y - c_y b_x, v = a_x c_y - a_y c_x, w = b_x a_y - b_y a_x.
  const __m256 u = _mm256_sub_ps(_mm256_mul_ps(x[2], y[1]), _mm256_mul_ps(y[2], x[1]));
  const __m256 v = _mm256_sub_ps(_mm256_mul_ps(x[0], y[2]), _mm256_mul_ps(y[0], x[2]));
  const __m256 w = _mm256_sub_ps(_mm256_mul_ps(x[1], y[0]), _mm256_mul_ps(y[1], x[0]));
  const __m256 zero = _mm256_setzero_ps();
  const __m256 negative = _mm256_or_ps(
      _mm256_or_ps(_mm256_cmp_ps(u, zero, _CMP_LT_OQ), _mm256_cmp_ps(v, zero, _CMP_LT_OQ)),
      _mm256_cmp_ps(w, zero, _CMP_LT_OQ));
  const __m256 positive = _mm256_or_ps(
      _mm256_or_ps(_mm256_cmp_ps(u, zero, _CMP_GT_OQ), _mm256_cmp_ps(v, zero, _CMP_GT_OQ)),
      _mm256_cmp_ps(w, zero, _CMP_GT_OQ));
  const __m256 numbers =
      _mm256_and_ps(_mm256_cmp_ps(u, v, _CMP_ORD_Q), _mm256_cmp_ps(w, w, _CMP_ORD_Q));
  const __m256 some_zero = _mm256_or_ps(
      _mm256_or_ps(_mm256_cmp_ps(u, zero, _CMP_EQ_OQ), _mm256_cmp_ps(v, zero, _CMP_EQ_OQ)),
      _mm256_cmp_ps(w, zero, _CMP_EQ_OQ));
  // Mixed nonzero signs: a miss whatever the double redo would make of a zero.
  const __m256 missed = _mm256_and_ps(_mm256_and_ps(negative, positive), numbers);
  const __m256 scalar = _mm256_andnot_ps(
      missed, _mm256_or_ps(some_zero, _mm256_andnot_ps(numbers, as_float(_mm256_set1_epi32(-1)))));
  const __m256 det = _mm256_add_ps(_mm256_add_ps(u, v), w);
  const __m256 t_scaled = _mm256_add_ps(
      _mm256_add_ps(_mm256_mul_ps(u, z[0]), _mm256_mul_ps(v, z[1])), _mm256_mul_ps(w, z[2]));
  const __m256 inv_det = _mm256_div_ps(_mm256_set1_ps(1.f), det);
  const __m256 t = _mm256_mul_ps(t_scaled, inv_det);
  const __m256 in_range =
      _mm256_and_ps(_mm256_and_ps(_mm256_cmp_ps(t, ray_float(s.tmin), _CMP_GE_OQ),
                                  _mm256_cmp_ps(t, ray_float(s.tmax), _CMP_LE_OQ)),
                    _mm256_and_ps(_mm256_cmp_ps(t, _mm256_set1_ps(INFINITY), _CMP_LT_OQ),
                                  _mm256_cmp_ps(det, zero, _CMP_NEQ_UQ)));
  const __m256 hit = _mm256_andnot_ps(_mm256_or_ps(missed, scalar), in_range);
  _mm256_store_ps(out.t, t);
  _mm256_store_ps(out.u, _mm256_mul_ps(v, inv_det));
  _mm256_store_ps(out.v, _mm256_mul_ps(w, inv_det));
  out.hits = lane_bits(_mm256_and_si256(slots, as_int(hit)));
  out.scalar = lane_bits(_mm256_and_si256(slots, as_int(scalar)));
}

/// step_past_cell, lane-wise, for lanes whose walk goes on; returns the lanes whose walk ends
/// (the closest hit lies within the cell, or the ray leaves the grid).
__m256i step_lanes(const GridInfo& info, Lanes& s, const LaneExit& e) {
  const __m256 best_t = load(s.best_t);
  const __m256i has_hit = _mm256_xor_si256(
      _mm256_cmpeq_epi32(load(s.best_prim), _mm256_set1_epi32(int(kNoHit))), _mm256_set1_epi32(-1));
  __m256i ends = _mm256_and_si256(has_hit, as_int(_mm256_cmp_ps(best_t, e.t_exit, _CMP_LE_OQ)));
  ends = _mm256_or_si256(ends, as_int(_mm256_cmp_ps(e.t_exit, load(s.t_leave), _CMP_NLT_UQ)));
  __m256i outside = _mm256_setzero_si256();
  const __m256i minus_one = _mm256_set1_epi32(-1);
  for (int a = 0; a < 3; ++a) {
    const __m256i up = load(s.ascending[a]);
    const __m256i is_exit = as_int(_mm256_cmp_ps(e.t_axis[a], e.t_exit, _CMP_EQ_OQ));
    const __m256i far = e.far[a], far_below = _mm256_add_epi32(far, minus_one);
    const __m256i dims = _mm256_set1_epi32(info.virtual_dims[a]);
    // The exit axis: past the far plane; outside the grid when not in [0, dims).
    const __m256i jumped = _mm256_blendv_epi8(far_below, far, up);
    // The other axes: voxel_at(walk_position(t_exit)), kept within the cell and never back.
    const __m256i v =
        voxel_at(info, a, walk_position(info, a, load(s.org[a]), load(s.dir[a]), e.t_exit));
    const __m256i at = load(s.voxel[a]);
    const __m256i up_v =
        _mm256_blendv_epi8(_mm256_blendv_epi8(v, far_below, _mm256_cmpgt_epi32(v, far_below)), at,
                           _mm256_cmpgt_epi32(at, v));
    const __m256i down_v = _mm256_blendv_epi8(
        _mm256_blendv_epi8(v, far, _mm256_cmpgt_epi32(far, v)), at, _mm256_cmpgt_epi32(v, at));
    const __m256i followed = _mm256_blendv_epi8(down_v, up_v, up);
    store(s.voxel[a], _mm256_blendv_epi8(followed, jumped, is_exit));
    const __m256i in_grid =
        _mm256_and_si256(_mm256_cmpgt_epi32(jumped, minus_one), _mm256_cmpgt_epi32(dims, jumped));
    outside = _mm256_or_si256(outside, _mm256_andnot_si256(in_grid, is_exit));
  }
  return _mm256_or_si256(ends, outside);
}

/// One set of L walks in flight, with the cells and tests of its current round.
struct alignas(32) Group {
  Lanes s{};
  LaneCells c{};
  TestList list;
  std::int32_t cells_visited[L] = {}, triangles_tested[L] = {};  // TraversalCounters
  std::uint32_t ray_of[L] = {};
  std::uint32_t active = 0;     // lanes with a walk
  std::uint32_t hit_lanes = 0;  // any hit: lanes that found one this round
};

/// The cell of each active lane's voxel (lookup_cell, lane-wise), for every group: one gather
/// per map level, then the cell's fields. The groups descend together, so that the gathers of
/// one group wait for memory while the others' are in flight too.
template <typename CellT, int G>
void find_cells(const GridView& grid, const CellT* cells, Group (&groups)[G]) {
  const GridInfo& info = grid.info;
  const __m128i top_shift = _mm_cvtsi32_si128(info.shift);
  const __m256i zero = _mm256_setzero_si256(), one = _mm256_set1_epi32(1);
  __m256i v[G][3], entry[G], level_shift[G], inner[G];
  for (int g = 0; g < G; ++g) {
    const __m256i active = lanes_of(groups[g].active);
    for (int a = 0; a < 3; ++a)
      v[g][a] = load(groups[g].s.voxel[a]);
    const __m256i top_x = _mm256_sra_epi32(v[g][0], top_shift);
    const __m256i top_y = _mm256_sra_epi32(v[g][1], top_shift);
    const __m256i top_z = _mm256_sra_epi32(v[g][2], top_shift);
    const __m256i top = _mm256_add_epi32(
        _mm256_mullo_epi32(
            _mm256_add_epi32(_mm256_mullo_epi32(top_z, _mm256_set1_epi32(info.top_dims[1])), top_y),
            _mm256_set1_epi32(info.top_dims[0])),
        top_x);
    entry[g] = gather(grid.entries, top, active);
    level_shift[g] = _mm256_set1_epi32(info.shift);
    inner[g] = _mm256_and_si256(active, _mm256_cmpgt_epi32(_mm256_srli_epi32(entry[g], 30), zero));
  }
  for (bool descending = true; descending;) {
    descending = false;
    for (int g = 0; g < G; ++g) {
      if (_mm256_testz_si256(inner[g], inner[g])) continue;
      descending = true;
      const __m256i k = _mm256_srli_epi32(entry[g], 30);  // 0 in leaf and idle lanes
      const __m256i mask = _mm256_sub_epi32(_mm256_sllv_epi32(one, k), one);
      level_shift[g] = _mm256_sub_epi32(level_shift[g], k);
      const __m256i cx = _mm256_and_si256(_mm256_srav_epi32(v[g][0], level_shift[g]), mask);
      const __m256i cy = _mm256_and_si256(_mm256_srav_epi32(v[g][1], level_shift[g]), mask);
      const __m256i cz = _mm256_and_si256(_mm256_srav_epi32(v[g][2], level_shift[g]), mask);
      const __m256i child =
          _mm256_or_si256(_mm256_sllv_epi32(_mm256_or_si256(_mm256_sllv_epi32(cz, k), cy), k), cx);
      const __m256i index = _mm256_add_epi32(
          _mm256_and_si256(entry[g], _mm256_set1_epi32(int(kMaxEntryTarget))), child);
      entry[g] = _mm256_mask_i32gather_epi32(entry[g], reinterpret_cast<const int*>(grid.entries),
                                             index, inner[g], 4);
      inner[g] =
          _mm256_and_si256(inner[g], _mm256_cmpgt_epi32(_mm256_srli_epi32(entry[g], 30), zero));
    }
  }
  for (int g = 0; g < G; ++g)
    load_cells(cells, _mm256_and_si256(entry[g], _mm256_set1_epi32(int(kMaxEntryTarget))),
               lanes_of(groups[g].active), groups[g].c);
}

}  // namespace

template <Query kQuery, typename CellT>
void trace_simd_lanes(const GridView& grid, std::span<const Ray> rays, std::span<Hit> hits,
                      std::span<RayWork> work) {
  constexpr int G = kSimdWalkGroups;
  const CellT* cells = cell_array<CellT>(grid);
  const TriangleVertices* triangles = grid.triangles;
  const bool counted = !work.empty();
  Group groups[G];
  Lanes staged{};  // walks begun ahead, eight rays at a time
  std::uint32_t staged_ray[L];
  std::uint32_t staged_ready = 0;  // slots of `staged` whose ray enters the grid, not yet taken
  std::size_t next = 0;
  // Gives the lanes of `idle` in `group` the next rays that enter the grid; rays that miss it
  // are answered at once. Returns the lanes that got one.
  const auto start = [&](Group& group, std::uint32_t idle) {
    std::uint32_t started = 0;
    while (idle != 0) {
      if (staged_ready == 0) {
        if (next == rays.size()) break;
        const std::size_t count = rays.size() - next < L ? rays.size() - next : L;
        const std::uint32_t starting = (1u << count) - 1;
        staged_ready =
            lane_bits(begin_walks(grid.info, rays.data() + next, staged, lanes_of(starting)));
        for (std::uint32_t slot = 0; slot < count; ++slot) {
          staged_ray[slot] = std::uint32_t(next + slot);
          if (staged_ready >> slot & 1) continue;
          hits[next + slot] = Hit{};
          if (counted) work[next + slot] = {};
        }
        next += count;
        continue;
      }
      const int l = __builtin_ctz(idle), slot = __builtin_ctz(staged_ready);
      copy_lane(group.s, l, staged, slot);
      group.ray_of[l] = staged_ray[slot];
      group.cells_visited[l] = group.triangles_tested[l] = 0;
      started |= 1u << l;
      idle &= idle - 1;
      staged_ready &= staged_ready - 1;
    }
    return started;
  };
  // Runs the listed tests of `group` and keeps each lane's closest (or any) hit.
  const auto run_tests = [&](Group& group) {
    Lanes& s = group.s;
    TestList& list = group.list;
    BatchHits batch;
    for (int first = 0; first < list.size; first += L) {
      const int count = list.size - first < L ? list.size - first : L;
      test_triangles(grid, s, list, first, count, batch);
      // Only the tests that hit, or need the scalar test, are looked at one by one, in order.
      for (std::uint32_t bits = batch.hits | batch.scalar; bits != 0; bits &= bits - 1) {
        const int p = __builtin_ctz(bits);
        const int l = list.lane[first + p];
        if (kQuery == Query::any && (group.hit_lanes >> l & 1)) continue;
        const std::uint32_t id = list.prim[first + p];
        TriangleHit<float> hit{batch.t[p], batch.u[p], batch.v[p]};
        if (batch.scalar >> p & 1) {
          const TriangleVertices& tri = grid.triangles[id];
          const WatertightRay<float> ray{{s.org_k[0][l], s.org_k[1][l], s.org_k[2][l]},
                                         s.axis[0][l],
                                         s.axis[1][l],
                                         s.axis[2][l],
                                         s.shear[0][l],
                                         s.shear[1][l],
                                         s.shear[2][l],
                                         s.tmin[l],
                                         s.tmax[l]};
          if (!intersect_watertight(ray, tri.p0, tri.p1, tri.p2, float(INFINITY), hit)) continue;
        }
        const float best_t = s.best_t[l];
        if (hit.t > best_t || (hit.t == best_t && id > std::uint32_t(s.best_prim[l]))) continue;
        s.best_t[l] = hit.t;
        s.best_u[l] = hit.u;
        s.best_v[l] = hit.v;
        s.best_prim[l] = std::int32_t(id);
        if constexpr (kQuery == Query::any) {
          group.hit_lanes |= 1u << l;
          group.triangles_tested[l] += list.ordinal[first + p] + 1;  // the tests up to this hit
        }
      }
    }
    list.size = 0;
  };
  // Lists the tests of the cells of `group`, each lane's in its reference order, and requests
  // their triangles. Runs the tests early only when the list fills.
  const auto list_tests = [&](Group& group, __m256i cell_refs) {
    const LaneCells& c = group.c;
    TestList& list = group.list;
    const __m256i long_cells = _mm256_cmpgt_epi32(cell_refs, _mm256_set1_epi32(L));
    if (_mm256_testz_si256(long_cells, long_cells)) {
      // The usual round: every cell has at most L references, and all fit the list (L rows of
      // L). One row per lane, without branches, then the triangles of every listed test
      // (slots past the size hold earlier, valid ids).
      alignas(32) std::int32_t count[L];
      store(count, cell_refs);
#pragma GCC unroll 8
      for (int l = 0; l < L; ++l)
        list.append_row(l, grid.refs + c.begin[l], count[l], 0);
      for (int row = 0; row < list.size; row += L) {
#pragma GCC unroll 8
        for (int k = 0; k < L; ++k)
          __builtin_prefetch(triangles + list.prim[row + k]);
      }
      return;
    }
    for (std::uint32_t bits = group.active; bits != 0; bits &= bits - 1) {
      const int l = __builtin_ctz(bits);
      const std::int32_t begin = c.begin[l], count = c.end[l] - begin;
      for (std::int32_t done = 0; done < count;) {
        if (kQuery == Query::any && (group.hit_lanes >> l & 1)) break;
        const int room = TestList::kCapacity - list.size;
        const int take = count - done < room ? count - done : room;
        const std::uint32_t* ids = list.prim + list.size;
        list.append(l, grid.refs + begin + done, take, done);
        for (int k = 0; k < take; ++k)
          __builtin_prefetch(triangles + ids[k]);
        done += take;
        if (list.size == TestList::kCapacity) run_tests(group);
      }
    }
  };

  bool walking = false;
  for (Group& group : groups)
    walking |= (group.active = start(group, (1u << L) - 1)) != 0;
  while (walking) {
    // Every phase runs for all groups before the next phase, so that one group's loads are
    // in flight while another computes.
    find_cells(grid, cells, groups);
    LaneExit exit[G];
    __m256i cell_refs[G];  // references per lane's cell, 0 in idle lanes
    for (int g = 0; g < G; ++g) {
      exit[g] = cell_exits(groups[g].s, groups[g].c);
      groups[g].hit_lanes = 0;
      cell_refs[g] = _mm256_sub_epi32(load(groups[g].c.end), load(groups[g].c.begin));
      list_tests(groups[g], cell_refs[g]);
    }
    walking = false;
    for (int g = 0; g < G; ++g) {
      Group& group = groups[g];
      if (group.active == 0) continue;
      if (group.list.size > 0) run_tests(group);
      const __m256i lanes = lanes_of(group.active);
      // Every listed test counts, except those past an any-hit query's hit (counted above).
      const __m256i whole_cells =
          kQuery == Query::any ? _mm256_andnot_si256(lanes_of(group.hit_lanes), lanes) : lanes;
      store(group.triangles_tested, _mm256_add_epi32(load(group.triangles_tested),
                                                     _mm256_and_si256(cell_refs[g], whole_cells)));
      const std::uint32_t ended =
          (lane_bits(step_lanes(grid.info, group.s, exit[g])) | group.hit_lanes) & group.active;
      store(group.cells_visited,
            _mm256_sub_epi32(load(group.cells_visited), lanes));  // lanes: -1 each
      const Lanes& s = group.s;
      for (std::uint32_t bits = ended; bits != 0; bits &= bits - 1) {
        const int l = __builtin_ctz(bits);
        const auto prim = std::uint32_t(s.best_prim[l]);
        const std::uint32_t ray = group.ray_of[l];
        hits[ray] = prim == kNoHit ? Hit{} : Hit{prim, s.best_t[l], s.best_u[l], s.best_v[l]};
        if (counted)
          work[ray] = {std::uint32_t(group.cells_visited[l]),
                       std::uint32_t(group.triangles_tested[l])};
      }
      group.active = (group.active & ~ended) | start(group, ended);
      walking |= group.active != 0;
    }
  }
}

template void trace_simd_lanes<Query::closest, Cell>(const GridView&, std::span<const Ray>,
                                                     std::span<Hit>, std::span<RayWork>);
template void trace_simd_lanes<Query::any, Cell>(const GridView&, std::span<const Ray>,
                                                 std::span<Hit>, std::span<RayWork>);
template void trace_simd_lanes<Query::closest, CompactCell>(const GridView&, std::span<const Ray>,
                                                            std::span<Hit>, std::span<RayWork>);
template void trace_simd_lanes<Query::any, CompactCell>(const GridView&, std::span<const Ray>,
                                                        std::span<Hit>, std::span<RayWork>);

#pragma GCC pop_options

}  // namespace irgrid
