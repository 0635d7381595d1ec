// The compressed wide BVH from Embree's 8-wide tree: Ylitie, Karras, Laine, "Efficient
// Incoherent Ray Traversal on GPUs Through Compressed Wide BVHs", HPG 2017, §3.1 (child order by
// octant, quantised child boxes, the meta byte per slot).
#include <algorithm>
#include <array>
#include <cmath>

#include <fmt/format.h>

#include "baselines/wide_tree.h"
#include "irgrid/error.h"

namespace irgrid {
namespace {

constexpr int kNoChild = -1;

Vec3<float> centre(const BoxF& box) {
  return {0.5f * (box.lo.x + box.hi.x), 0.5f * (box.lo.y + box.hi.y), 0.5f * (box.lo.z + box.hi.z)};
}

/// The union of the children's boxes (the node's quantisation frame).
BoxF children_box(const WideInner& node) {
  BoxF box = node.boxes[0];
  for (std::uint32_t i = 1; i < node.count; ++i)
    box = box_union(box, node.boxes[i]);
  return box;
}

/// Which child goes to which slot (kNoChild: empty). §3.1: slot s should hold the child a ray
/// running in octant s's diagonal direction meets first, so the cost of child i in slot s is the
/// projection of its centre, relative to the node's, onto that direction; the assignment of least
/// total cost is approximated greedily, cheapest pairs first (the paper uses an auction).
std::array<int, kCwbvhWidth> order_by_octant(const WideInner& node, const BoxF& box) {
  const Vec3<float> c = centre(box);
  struct Pair {
    float cost;
    int child, slot;
  };
  std::array<Pair, kCwbvhWidth * kCwbvhWidth> pairs;
  int n = 0;
  for (std::uint32_t i = 0; i < node.count; ++i) {
    const Vec3<float> d = centre(node.boxes[i]) - c;
    for (int s = 0; s < kCwbvhWidth; ++s) {
      const Vec3<float> diagonal{s & 1 ? -1.f : 1.f, s & 2 ? -1.f : 1.f, s & 4 ? -1.f : 1.f};
      pairs[std::size_t(n++)] = {dot(d, diagonal), int(i), s};
    }
  }
  // Stable on ties, so equal costs keep child and slot order (a deterministic layout).
  std::stable_sort(pairs.begin(), pairs.begin() + n,
                   [](const Pair& a, const Pair& b) { return a.cost < b.cost; });
  std::array<int, kCwbvhWidth> slot_child;
  slot_child.fill(kNoChild);
  std::array<bool, kCwbvhWidth> placed{};
  for (int k = 0; k < n; ++k) {
    const Pair& p = pairs[std::size_t(k)];
    if (placed[std::size_t(p.child)] || slot_child[std::size_t(p.slot)] != kNoChild) continue;
    slot_child[std::size_t(p.slot)] = p.child;
    placed[std::size_t(p.child)] = true;
  }
  return slot_child;
}

/// The smallest biased exponent whose step covers [lo, hi] in 255 steps from lo, as
/// cwbvh_plane rounds.
std::uint8_t step_exponent(float lo, float hi) {
  const double extent = double(hi) - double(lo);
  int e = 1;
  if (extent > 0) e = std::clamp(int(std::ceil(std::log2(extent / 255.0))) + 127, 1, 254);
  while (e < 254 && cwbvh_plane(lo, 255, cwbvh_step(std::uint8_t(e))) < hi)
    ++e;
  return std::uint8_t(e);
}

/// The tightest planes q_lo <= q_hi whose rounded world positions hold [lo, hi].
void quantise(float p, float step, float lo, float hi, std::uint8_t& q_lo, std::uint8_t& q_hi) {
  int a = std::clamp(int(std::floor((double(lo) - double(p)) / double(step))), 0, 255);
  while (a > 0 && cwbvh_plane(p, std::uint8_t(a), step) > lo)
    --a;
  while (a < 255 && cwbvh_plane(p, std::uint8_t(a + 1), step) <= lo)
    ++a;
  int b = std::clamp(int(std::ceil((double(hi) - double(p)) / double(step))), 0, 255);
  while (b < 255 && cwbvh_plane(p, std::uint8_t(b), step) < hi)
    ++b;
  while (b > 0 && cwbvh_plane(p, std::uint8_t(b - 1), step) >= hi)
    --b;
  q_lo = std::uint8_t(a);
  q_hi = std::uint8_t(std::max(a, b));
}

class Compressor {
 public:
  explicit Compressor(HostCwbvh& out) : out_(out) {}

  /// Writes `node` as out_.nodes[index], then its internal children.
  void emit(const WideInner& node, std::uint32_t index, std::uint32_t level) {
    out_.depth = std::max(out_.depth, level);
    const BoxF box = children_box(node);
    const auto slot_child = order_by_octant(node, box);
    CwbvhNode c{};
    c.p = box.lo;
    for (int a = 0; a < 3; ++a)
      c.exp[a] = step_exponent(box.lo[a], box.hi[a]);
    c.child_base = std::uint32_t(out_.nodes.size());
    c.ref_base = std::uint32_t(out_.refs.size());
    std::uint32_t inner = 0;
    for (int s = 0; s < kCwbvhWidth; ++s) {
      const int i = slot_child[std::size_t(s)];
      if (i == kNoChild) continue;
      const WideNode* child = node.children[i];
      const BoxF& b = node.boxes[i];
      for (int a = 0; a < 3; ++a)
        quantise(c.p[a], cwbvh_step(c.exp[a]), b.lo[a], b.hi[a], c.q_lo[a][s], c.q_hi[a][s]);
      if (!child->leaf) {
        c.imask |= std::uint8_t(1u << s);
        c.meta[s] = std::uint8_t(1u << 5 | (kCwbvhInnerBit + s));
        ++inner;
        continue;
      }
      if (child->count == 0) continue;  // an empty leaf stays an empty slot
      const auto* leaf = static_cast<const WideLeaf*>(child);
      const std::uint32_t offset = std::uint32_t(out_.refs.size()) - c.ref_base;
      c.meta[s] = std::uint8_t(((1u << leaf->count) - 1u) << 5 | offset);
      out_.refs.insert(out_.refs.end(), leaf->prims, leaf->prims + leaf->count);
    }
    out_.nodes[index] = c;
    // The internal children's block, in slot order, then their subtrees.
    out_.nodes.resize(out_.nodes.size() + inner);
    std::uint32_t k = 0;
    for (int s = 0; s < kCwbvhWidth; ++s) {
      const int i = slot_child[std::size_t(s)];
      if (i == kNoChild || node.children[i]->leaf) continue;
      emit(*static_cast<const WideInner*>(node.children[i]), c.child_base + k++, level + 1);
    }
  }

 private:
  HostCwbvh& out_;
};

}  // namespace

void compress_wide_tree(const WideInner& root, HostCwbvh& out) {
  out.nodes.assign(1, CwbvhNode{});
  out.refs.clear();
  out.depth = 0;
  Compressor(out).emit(root, 0, 1);
}

}  // namespace irgrid
