// baselines/wide_tree.h: the 8-wide tree Embree's builder makes (callbacks of
// cwbvh_embree.cpp), before its compression (cwbvh_compress.cpp).
#pragma once

#include <cstdint>
#include <span>

#include "baselines/cwbvh_build.h"
#include "irgrid/kernel/triangle.h"

namespace irgrid {

/// What inner nodes and leaves share: `count` is the number of children or of triangles.
struct WideNode {
  bool leaf = false;
  std::uint32_t count = 0;
};

struct WideInner : WideNode {
  const WideNode* children[kCwbvhWidth];
  BoxF boxes[kCwbvhWidth];  ///< the children's boxes (spatial splits clip them)
};

struct WideLeaf : WideNode {
  std::uint32_t prims[kCwbvhMaxLeafTriangles];  ///< triangle ids
};

/// Compresses the tree at `root` (an inner node) into out.nodes and out.refs, with children in
/// the octant order of Ylitie et al. 2017, §3.1. Sets out.depth.
void compress_wide_tree(const WideInner& root, HostCwbvh& out);

}  // namespace irgrid
