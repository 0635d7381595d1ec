// baselines/cwbvh_build.h: the compressed wide BVH built on the host (Embree's builder, then
// the compressed layout), for the CPU and CUDA accelerators.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "irgrid/accelerator.h"
#include "irgrid/kernel/cwbvh_layout.h"
#include "irgrid/mesh.h"

namespace irgrid {

/// A CWBVH in host memory, and what its build took.
struct HostCwbvh {
  std::vector<CwbvhNode> nodes;             ///< nodes[0] is the root; empty for no triangles
  std::vector<std::uint32_t> refs;          ///< triangle ids of the leaves
  std::vector<TriangleVertices> triangles;  ///< the mesh's triangles, in order
  std::uint32_t depth = 0;                  ///< node levels (the traversal stack's bound)
  double embree_ms = 0;                     ///< Embree's 8-wide SAH build with spatial splits
  double compress_ms = 0;                   ///< conversion to the compressed layout

  /// Bytes of the final structure: nodes, references and triangles.
  std::uint64_t memory_bytes() const {
    return nodes.size() * sizeof(CwbvhNode) + refs.size() * sizeof(std::uint32_t) +
           triangles.size() * sizeof(TriangleVertices);
  }
  CwbvhView view() const {
    return {nodes.data(), refs.data(), triangles.data(), std::uint32_t(nodes.size())};
  }
};

/// Builds the CWBVH of Ylitie et al. 2017 over `mesh` (which check_mesh accepted): Embree 3's
/// rtcBuildBVH (8 children, high quality with spatial splits, leaves of at most 3 triangles),
/// then the compressed 80-byte nodes with octant-ordered children. `embree_config` goes to
/// rtcNewDevice. Throws Error{out_of_memory} or Error{internal} when Embree fails, and
/// Error{limit_exceeded} for a tree deeper than the traversal stack.
HostCwbvh build_cwbvh(const TriangleMesh& mesh, const std::string& embree_config);

/// build_cwbvh, timed into `stats` (build_ms, the bvh_build and bvh_compress phases, memory),
/// telling options.on_phase as each phase ends.
HostCwbvh build_cwbvh_timed(const TriangleMesh& mesh, const AcceleratorOptions& options,
                            BuildStats& stats);

}  // namespace irgrid
