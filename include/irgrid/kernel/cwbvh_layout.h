// irgrid/kernel/cwbvh_layout.h: the compressed 8-wide BVH node (80 bytes) and its views.
//
// Ylitie, Karras, Laine, "Efficient Incoherent Ray Traversal on GPUs Through Compressed Wide
// BVHs", HPG 2017, §3.1: each node stores the eight child boxes quantised to 8 bits per plane on
// a per-axis power-of-two grid anchored at the node's origin `p`; the internal children are
// stored contiguously from `child_base`, the leaves' triangle references contiguously from
// `ref_base`, and one `meta` byte per child says what the slot holds.
#pragma once

#include <cstddef>
#include <cstdint>
#include <cstring>

#include "irgrid/kernel/platform.h"
#include "irgrid/kernel/triangle.h"
#include "irgrid/kernel/vec.h"

namespace irgrid {

/// Children per node.
inline constexpr int kCwbvhWidth = 8;
/// Triangles per leaf slot (the unary count in meta's top three bits).
inline constexpr int kCwbvhMaxLeafTriangles = 3;
/// Bit of the traversal's hit mask where the internal children's positions start (0..23 hold
/// the node's leaf triangles, 24..31 its internal children), §4.
inline constexpr int kCwbvhInnerBit = 24;

/// One node, 80 bytes. A child slot's box is, per axis a, the planes
/// p[a] + q_lo[a][s] * 2^(exp[a] - 127) and p[a] + q_hi[a][s] * 2^(exp[a] - 127), each rounded to
/// float once (cwbvh_plane); the builder picks q so that those rounded planes hold the child.
struct CwbvhNode {
  Vec3<float> p;             ///< 12 B origin of the quantisation grid (the node box's min)
  std::uint8_t exp[3];       ///<  3 B biased float exponents of the grid steps per axis
  std::uint8_t imask;        ///<  1 B bit s set: slot s holds an internal child
  std::uint32_t child_base;  ///<  4 B index of the first internal child node
  std::uint32_t ref_base;    ///<  4 B index of the first triangle reference of the leaves
  /// 8 B per slot: 0 empty; internal child: 0b001'11sss (24 + slot s); leaf: the triangle count
  /// in unary in the top three bits (0b001, 0b011, 0b111) and its first reference's offset from
  /// ref_base (0..23) in the low five.
  std::uint8_t meta[kCwbvhWidth];
  std::uint8_t q_lo[3][kCwbvhWidth];  ///< 24 B quantised lower planes, per axis and slot
  std::uint8_t q_hi[3][kCwbvhWidth];  ///< 24 B quantised upper planes, per axis and slot
};
static_assert(sizeof(CwbvhNode) == 80 && alignof(CwbvhNode) == 4);

/// The float whose bits are `bits`.
IRGRID_HD inline float cwbvh_as_float(std::uint32_t bits) {
#if IRGRID_ON_DEVICE
  return __uint_as_float(bits);
#else
  float value;
  std::memcpy(&value, &bits, sizeof value);
  return value;
#endif
}

/// The grid step 2^(exp - 127) of a biased exponent (1..254: a normal float).
IRGRID_HD inline float cwbvh_step(std::uint32_t exp) {
  return cwbvh_as_float(exp << 23);  // the float 2^(exp - 127) for normal exponents
}

/// A node as the traversal reads it: its 80 bytes as twenty 32-bit words, each field taken out
/// by shifts at a constant offset, so that on the GPU the node stays in registers (a byte array
/// indexed at run time would be placed in local memory).
struct CwbvhNodeWords {
  std::uint32_t w[20];

  /// Byte k of the node (little endian, as the host wrote it).
  IRGRID_HD std::uint32_t byte(int k) const { return (w[k >> 2] >> (8 * (k & 3))) & 0xFFu; }
  IRGRID_HD float p(int a) const { return cwbvh_as_float(w[a]); }
  IRGRID_HD std::uint32_t exp(int a) const { return byte(12 + a); }
  IRGRID_HD std::uint32_t imask() const { return byte(15); }
  IRGRID_HD std::uint32_t child_base() const { return w[4]; }
  IRGRID_HD std::uint32_t ref_base() const { return w[5]; }
  IRGRID_HD std::uint32_t meta(int s) const { return byte(24 + s); }
  IRGRID_HD std::uint32_t q_lo(int a, int s) const { return byte(32 + kCwbvhWidth * a + s); }
  IRGRID_HD std::uint32_t q_hi(int a, int s) const { return byte(56 + kCwbvhWidth * a + s); }
};
static_assert(sizeof(CwbvhNodeWords) == sizeof(CwbvhNode));
static_assert(offsetof(CwbvhNode, exp) == 12 && offsetof(CwbvhNode, imask) == 15 &&
              offsetof(CwbvhNode, child_base) == 16 && offsetof(CwbvhNode, ref_base) == 20 &&
              offsetof(CwbvhNode, meta) == 24 && offsetof(CwbvhNode, q_lo) == 32 &&
              offsetof(CwbvhNode, q_hi) == 56);

/// The world coordinate of plane q on an axis with origin p and step `step`: q * step is exact
/// (an 8-bit integer times a power of two, both normal), so the one rounding is the sum's, the
/// same with or without fused multiply-add, on the host and the device.
IRGRID_HD inline float cwbvh_plane(float p, std::uint32_t q, float step) {
  return p + float(q) * step;
}

/// Read-only views of a CWBVH's arrays, in the memory space of the code that traverses it.
/// An empty BVH (no triangles) has node_count 0.
struct CwbvhView {
  const CwbvhNode* nodes;             ///< nodes[0] is the root
  const std::uint32_t* refs;          ///< triangle ids, leaves' runs contiguous
  const TriangleVertices* triangles;  ///< indexed by triangle id, as the grid stores them
  std::uint32_t node_count;
};

}  // namespace irgrid
