// irgrid/kernel/cwbvh_traverse.h: closest- and any-hit traversal of a compressed wide BVH, for
// host and device.
//
// Ylitie, Karras, Laine, "Efficient Incoherent Ray Traversal on GPUs Through Compressed Wide
// BVHs", HPG 2017, §4: a node's child boxes are tested together and give one 32-bit hit mask,
// its internal children in bits 24..31 (at the position slot ^ octant, so that the lowest set bit
// is the child nearest the ray's origin first) and its leaf triangles in bits 0..23. The stack
// holds *node groups*: a node's remaining internal children (base index, hit bits, imask), so
// one entry stands for up to eight subtrees. Triangles are tested with the grid's watertight test
// (irgrid/kernel/watertight.h), so a hit on the same triangle has the same t, u, v bit for bit.
#pragma once

#include <cstdint>
#include <cstring>

#include "irgrid/kernel/cwbvh_layout.h"
#include "irgrid/kernel/grid_traverse.h"
#include "irgrid/kernel/watertight.h"

namespace irgrid {

/// Entries of the traversal stack: at most one per tree level (cwbvh build checks the depth).
inline constexpr int kCwbvhStackSize = 64;

IRGRID_HD inline int cwbvh_lowest_bit(std::uint32_t x) {
#if IRGRID_ON_DEVICE
  return __ffs(int(x)) - 1;
#else
  return __builtin_ctz(x);
#endif
}

IRGRID_HD inline int cwbvh_popcount(std::uint32_t x) {
#if IRGRID_ON_DEVICE
  return __popc(x);
#else
  return __builtin_popcount(x);
#endif
}

/// Per-ray constants of the box tests.
struct CwbvhRay {
  float org[3];
  float inv_dir[3];      ///< 1 / dir (±infinity where dir is ±0)
  std::uint32_t octant;  ///< bit a set when the ray runs towards -a (inv_dir[a] < 0)
};

IRGRID_HD inline CwbvhRay make_cwbvh_ray(const Ray& ray) {
  CwbvhRay r;
  r.octant = 0;
  for (int a = 0; a < 3; ++a) {
    r.org[a] = ray.org[a];
    r.inv_dir[a] = 1.f / ray.dir[a];
    // From inv_dir, not dir: -0 gives -infinity, and its entry plane is then the upper one.
    if (r.inv_dir[a] < 0.f) r.octant |= 1u << a;
  }
  return r;
}

/// Reads a node; on the device as five 16-byte loads through the read-only cache (the node
/// array comes from cudaMalloc, and 80-byte nodes keep every node 16-byte aligned).
IRGRID_HD IRGRID_ALWAYS_INLINE CwbvhNodeWords load_cwbvh_node(const CwbvhNode* nodes,
                                                              std::uint32_t index) {
  CwbvhNodeWords node;
#if IRGRID_ON_DEVICE
  static_assert(sizeof(CwbvhNode) == 5 * sizeof(uint4));
  const uint4* from = reinterpret_cast<const uint4*>(nodes + index);
#pragma unroll
  for (int k = 0; k < 5; ++k) {
    const uint4 v = __ldg(from + k);
    node.w[4 * k] = v.x, node.w[4 * k + 1] = v.y, node.w[4 * k + 2] = v.z, node.w[4 * k + 3] = v.w;
  }
#else
  std::memcpy(node.w, nodes + index, sizeof node.w);
#endif
  return node;
}

/// The slab test of the ray against every child box of `node` within [t_lo, t_hi]; returns the
/// hit mask (bits 24 + (slot ^ octant) for internal children, the leaves' triangle bits below).
/// Conservative: the planes are the exact floats the builder checked (cwbvh_plane), and a box
/// counts as hit unless its slab interval is empty by more than the rounding of the distances
/// (at most 3 ulp each: the subtraction, 1 / dir and the product; Ize, "Robust BVH Ray
/// Traversal", JCGT 2(2), 2013), so a triangle's box is never missed through rounding. A
/// distance that is NaN (0 x infinity: a ray in a box plane, parallel to it) does not narrow the
/// interval.
IRGRID_HD IRGRID_ALWAYS_INLINE std::uint32_t intersect_cwbvh_children(const CwbvhNodeWords& node,
                                                                      const CwbvhRay& r, float t_lo,
                                                                      float t_hi) {
  // Axis by axis over the eight slots; every byte offset is a constant once the loops unroll.
  float t_near[kCwbvhWidth], t_far[kCwbvhWidth];
#if IRGRID_ON_DEVICE
#pragma unroll
#endif
  for (int s = 0; s < kCwbvhWidth; ++s)
    t_near[s] = t_lo, t_far[s] = t_hi;
#if IRGRID_ON_DEVICE
#pragma unroll
#endif
  for (int a = 0; a < 3; ++a) {
    const bool down = (r.octant >> a) & 1u;
    const float p = node.p(a), step = cwbvh_step(node.exp(a));
    const float org = r.org[a], inv_dir = r.inv_dir[a];
#if IRGRID_ON_DEVICE
#pragma unroll
#endif
    for (int s = 0; s < kCwbvhWidth; ++s) {
      const std::uint32_t lo = node.q_lo(a, s), hi = node.q_hi(a, s);
      const float t0 = (cwbvh_plane(p, down ? hi : lo, step) - org) * inv_dir;
      const float t1 = (cwbvh_plane(p, down ? lo : hi, step) - org) * inv_dir;
      t_near[s] = max_fast(t0, t_near[s]);
      t_far[s] = min_fast(t1, t_far[s]);
    }
  }
  std::uint32_t hits = 0;
  const std::uint32_t imask = node.imask();
#if IRGRID_ON_DEVICE
#pragma unroll
#endif
  for (int s = 0; s < kCwbvhWidth; ++s) {
    const std::uint32_t meta = node.meta(s);
    // 2^-21 = 8 ulp of relative slack on each end (NaN compares false: a miss).
    if (meta == 0 || !(t_near[s] - t_far[s] <= 0x1p-21f * (fabsf(t_near[s]) + fabsf(t_far[s]))))
      continue;
    if ((imask >> s) & 1u)
      hits |= 1u << (kCwbvhInnerBit + (std::uint32_t(s) ^ r.octant));
    else  // the unary triangle count, shifted to the leaf's first reference
      hits |= (meta >> 5) << (meta & 31u);
  }
  return hits;
}

/// A node group on the stack: child base index (bits 0..31), the positions still to visit (bits
/// 32..39) and the node's imask (bits 40..47).
IRGRID_HD inline std::uint64_t cwbvh_group(std::uint32_t base, std::uint32_t positions,
                                           std::uint32_t imask) {
  return std::uint64_t(base) | std::uint64_t(positions) << 32 | std::uint64_t(imask) << 40;
}

/// Traces one ray. Closest hit: the nearest triangle with tmin <= t <= tmax (ties on t go to the
/// smaller id, as in the brute force and the grid); any hit: the first one found. Rays that are
/// not finite miss. `counters` (optional) counts the nodes visited and the triangles tested.
template <Query kQuery>
IRGRID_HD inline Hit traverse_cwbvh(const CwbvhView& bvh, const Ray& ray,
                                    TraversalCounters* counters = nullptr) {
  if (bvh.node_count == 0 || !ray_is_finite(ray)) return Hit{};
  const CwbvhRay r = make_cwbvh_ray(ray);
  const WatertightRay<float> shear = make_watertight_ray<float>(ray);
  Hit best{kNoHit, ray.tmax, 0.f, 0.f};
  std::uint64_t stack[kCwbvhStackSize];
  int size = 0;
  // The root as the only internal child (slot 0) of a node whose children start at 0.
  std::uint64_t group = cwbvh_group(0, 1u << r.octant, 1u);
  TriangleHit<float> hit;
  for (;;) {
    std::uint32_t positions = std::uint32_t(group >> 32) & 0xFFu;
    if (positions == 0) {
      if (size == 0) break;
      group = stack[--size];
      continue;
    }
    const int position = cwbvh_lowest_bit(positions);
    positions &= positions - 1;
    const std::uint32_t imask = std::uint32_t(group >> 40) & 0xFFu;
    const std::uint32_t base = std::uint32_t(group);
    const std::uint32_t slot = std::uint32_t(position) ^ r.octant;
    if (positions != 0) stack[size++] = cwbvh_group(base, positions, imask);
    const std::uint32_t index = base + std::uint32_t(cwbvh_popcount(imask & ((1u << slot) - 1u)));
    const CwbvhNodeWords node = load_cwbvh_node(bvh.nodes, index);
    if (counters) ++counters->cells;
    const std::uint32_t mask = intersect_cwbvh_children(node, r, ray.tmin, best.t);
    for (std::uint32_t triangles = mask & ((1u << kCwbvhInnerBit) - 1u); triangles != 0;
         triangles &= triangles - 1) {
      const std::uint32_t id =
          bvh.refs[node.ref_base() + std::uint32_t(cwbvh_lowest_bit(triangles))];
      const TriangleVertices& tri = bvh.triangles[id];
      if (counters) ++counters->triangles;
      if (!intersect_watertight(shear, tri.p0, tri.p1, tri.p2, float(INFINITY), hit)) continue;
      if (hit.t > best.t || (hit.t == best.t && id > best.prim)) continue;
      best = {id, hit.t, hit.u, hit.v};
      if constexpr (kQuery == Query::any) return best;
    }
    group = cwbvh_group(node.child_base(), mask >> kCwbvhInnerBit, node.imask());
  }
  return best.prim == kNoHit ? Hit{} : best;
}

}  // namespace irgrid
