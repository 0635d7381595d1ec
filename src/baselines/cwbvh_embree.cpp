// The CWBVH's tree from Embree 3's BVH builder API (rtcBuildBVH): 8 children per node, high
// quality (SAH with spatial splits, Stich et al. 2009), leaves of at most 3 triangles, as
// Ylitie et al. 2017 (§5) build theirs before compressing it.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <vector>

#include <embree3/rtcore.h>
#include <fmt/format.h>

#include "baselines/wide_tree.h"
#include "cpu/parallel.h"
#include "cpu/structures.h"
#include "irgrid/error.h"
#include "irgrid/kernel/cwbvh_traverse.h"

namespace irgrid {
namespace {

/// Spatial splits may replicate a triangle reference into several leaves; Embree takes its room
/// for them from the primitive array beyond primitiveCount.
constexpr std::size_t kSplitCapacityFactor = 2;

BoxF box_of(const RTCBounds& b) {
  return {{b.lower_x, b.lower_y, b.lower_z}, {b.upper_x, b.upper_y, b.upper_z}};
}
BoxF box_of(const RTCBuildPrimitive& p) {
  return {{p.lower_x, p.lower_y, p.lower_z}, {p.upper_x, p.upper_y, p.upper_z}};
}
void set_bounds(RTCBounds& out, const BoxF& box) {
  out.lower_x = box.lo.x, out.lower_y = box.lo.y, out.lower_z = box.lo.z, out.align0 = 0;
  out.upper_x = box.hi.x, out.upper_y = box.hi.y, out.upper_z = box.hi.z, out.align1 = 0;
}

struct BuildContext {
  std::span<const TriangleVertices> triangles;
  TsanHandOff* hand_off;  ///< Embree's builder threads, made visible to ThreadSanitizer
};

/// The callback's task of the build, for ThreadSanitizer (user: the BuildContext, or null).
TsanTask build_task(void* user) {
  return TsanTask(user ? static_cast<BuildContext*>(user)->hand_off : nullptr);
}

void* create_node(RTCThreadLocalAllocator alloc, unsigned count, void* user) {
  const TsanTask task = build_task(user);
  auto* node = new (rtcThreadLocalAlloc(alloc, sizeof(WideInner), 16)) WideInner;
  node->count = count;
  return node;
}

void set_children(void* node, void** children, unsigned count, void* user) {
  const TsanTask task = build_task(user);
  auto* inner = static_cast<WideInner*>(node);
  for (unsigned k = 0; k < count; ++k)
    inner->children[k] = static_cast<const WideNode*>(children[k]);
}

void set_node_bounds(void* node, const RTCBounds** bounds, unsigned count, void* user) {
  const TsanTask task = build_task(user);
  auto* inner = static_cast<WideInner*>(node);
  for (unsigned k = 0; k < count; ++k)
    inner->boxes[k] = box_of(*bounds[k]);
}

/// A leaf, or (should Embree hand over more than 3 triangles) a small tree of leaves of at most
/// 3 under inner nodes of at most 8 children.
WideNode* make_leaves(RTCThreadLocalAllocator alloc, const RTCBuildPrimitive* prims,
                      std::size_t count) {
  if (count <= std::size_t(kCwbvhMaxLeafTriangles)) {
    auto* leaf = new (rtcThreadLocalAlloc(alloc, sizeof(WideLeaf), 16)) WideLeaf;
    leaf->leaf = true;
    leaf->count = std::uint32_t(count);
    for (std::size_t k = 0; k < count; ++k)
      leaf->prims[k] = prims[k].primID;
    return leaf;
  }
  auto* inner = static_cast<WideInner*>(create_node(alloc, 0, nullptr));
  // Children of equal share, each of at most ceil(count / 8) triangles.
  const std::size_t share = (count + kCwbvhWidth - 1) / kCwbvhWidth;
  const std::size_t chunk = std::max<std::size_t>(share, kCwbvhMaxLeafTriangles);
  for (std::size_t first = 0; first < count; first += chunk) {
    const std::size_t n = std::min(chunk, count - first);
    BoxF box = box_of(prims[first]);
    for (std::size_t k = first + 1; k < first + n; ++k)
      box = box_union(box, box_of(prims[k]));
    inner->children[inner->count] = make_leaves(alloc, prims + first, n);
    inner->boxes[inner->count++] = box;
  }
  return inner;
}

void* create_leaf(RTCThreadLocalAllocator alloc, const RTCBuildPrimitive* prims, size_t count,
                  void* user) {
  const TsanTask task = build_task(user);
  return make_leaves(alloc, prims, count);
}

/// Grows `box` by point c, padded on the axes other than `dim` by a bound of c's rounding.
void grow_by_cut(BoxF& box, const Vec3<float>& c, const Vec3<float>& a, const Vec3<float>& b,
                 unsigned dim) {
  for (int k = 0; k < 3; ++k) {
    const float pad = unsigned(k) == dim ? 0.f : 0x1p-20f * (std::fabs(a[k]) + std::fabs(b[k]));
    box.lo[k] = std::min(box.lo[k], c[k] - pad);
    box.hi[k] = std::max(box.hi[k], c[k] + pad);
  }
}

/// Boxes of the parts of the triangle on either side of the plane x[dim] = position, each
/// clipped to the primitive's box (which may already be a part). Conservative: the cut points
/// are padded by their rounding error, so the two boxes hold every point of the part.
void split_primitive(const RTCBuildPrimitive* prim, unsigned dim, float position, RTCBounds* left,
                     RTCBounds* right, void* user) {
  const TsanTask task = build_task(user);
  const auto& tri = static_cast<const BuildContext*>(user)->triangles[prim->primID];
  const Vec3<float> v[3] = {tri.p0, tri.p1, tri.p2};
  const BoxF empty = {{INFINITY, INFINITY, INFINITY}, {-INFINITY, -INFINITY, -INFINITY}};
  BoxF l = empty, r = empty;
  for (int i = 0; i < 3; ++i) {
    const Vec3<float>& a = v[i];
    const Vec3<float>& b = v[(i + 1) % 3];
    if (a[dim] <= position) l = box_union(l, {a, a});
    if (a[dim] >= position) r = box_union(r, {a, a});
    if ((a[dim] < position && b[dim] > position) || (a[dim] > position && b[dim] < position)) {
      const float t = (position - a[dim]) / (b[dim] - a[dim]);
      Vec3<float> c;
      for (int k = 0; k < 3; ++k)
        c[k] = a[k] + t * (b[k] - a[k]);
      c[dim] = position;
      grow_by_cut(l, c, a, b, dim);
      grow_by_cut(r, c, a, b, dim);
    }
  }
  BoxF bounds = box_of(*prim);
  BoxF lb = bounds, rb = bounds;
  lb.hi[dim] = std::min(bounds.hi[dim], position);
  rb.lo[dim] = std::max(bounds.lo[dim], position);
  for (int k = 0; k < 3; ++k) {  // the part's box within the primitive's
    lb.lo[k] = std::max(lb.lo[k], l.lo[k]), lb.hi[k] = std::min(lb.hi[k], l.hi[k]);
    rb.lo[k] = std::max(rb.lo[k], r.lo[k]), rb.hi[k] = std::min(rb.hi[k], r.hi[k]);
  }
  set_bounds(*left, lb);
  set_bounds(*right, rb);
}

[[noreturn]] void throw_embree_error(RTCDevice device, const char* what) {
  const RTCError code = rtcGetDeviceError(device);
  throw Error(code == RTC_ERROR_OUT_OF_MEMORY ? ErrorCode::out_of_memory : ErrorCode::internal,
              fmt::format("cwbvh: embree {} failed (error {})", what, int(code)));
}

/// Owns Embree's device and BVH (whose allocator holds the tree's nodes).
struct EmbreeHandles {
  RTCDevice device = nullptr;
  RTCBVH bvh = nullptr;
  EmbreeHandles() = default;
  EmbreeHandles(const EmbreeHandles&) = delete;
  EmbreeHandles& operator=(const EmbreeHandles&) = delete;
  ~EmbreeHandles() {
    if (bvh) rtcReleaseBVH(bvh);
    if (device) rtcReleaseDevice(device);
  }
};

}  // namespace

HostCwbvh build_cwbvh(const TriangleMesh& mesh, const std::string& embree_config) {
  HostCwbvh out;
  gather_triangles(mesh, out.triangles);
  if (out.triangles.empty()) return out;
  const auto start = std::chrono::steady_clock::now();
  EmbreeHandles embree;
  embree.device = rtcNewDevice(embree_config.empty() ? nullptr : embree_config.c_str());
  if (!embree.device)
    throw Error(
        ErrorCode::invalid_argument,
        fmt::format("cwbvh: rtcNewDevice failed for the configuration '{}'", embree_config));
  embree.bvh = rtcNewBVH(embree.device);
  if (!embree.bvh) throw_embree_error(embree.device, "rtcNewBVH");

  const std::size_t count = out.triangles.size();
  std::vector<RTCBuildPrimitive> prims(kSplitCapacityFactor * count);
  for (std::size_t i = 0; i < count; ++i) {
    const BoxF box = triangle_box(out.triangles[i]);
    prims[i] = {box.lo.x, box.lo.y, box.lo.z, 0u, box.hi.x, box.hi.y, box.hi.z, std::uint32_t(i)};
  }
  TsanHandOff hand_off;
  BuildContext context{out.triangles, &hand_off};
  RTCBuildArguments args = rtcDefaultBuildArguments();
  args.buildQuality = RTC_BUILD_QUALITY_HIGH;
  args.maxBranchingFactor = kCwbvhWidth;
  args.maxDepth = 48;
  args.minLeafSize = 1;
  args.maxLeafSize = kCwbvhMaxLeafTriangles;
  args.bvh = embree.bvh;
  args.primitives = prims.data();
  args.primitiveCount = count;
  args.primitiveArrayCapacity = prims.size();
  args.createNode = create_node;
  args.setNodeChildren = set_children;
  args.setNodeBounds = set_node_bounds;
  args.createLeaf = create_leaf;
  args.splitPrimitive = split_primitive;
  args.userPtr = &context;
  const auto* root = static_cast<const WideNode*>(rtcBuildBVH(&args));
  hand_off.all_tasks_ended();
  if (!root || rtcGetDeviceError(embree.device) != RTC_ERROR_NONE)
    throw_embree_error(embree.device, "rtcBuildBVH");
  out.embree_ms = elapsed_ms<std::chrono::steady_clock>(start);

  const auto compress_start = std::chrono::steady_clock::now();
  WideInner wrapper;  // a leaf root becomes the only child of an inner root
  if (root->leaf) {
    BoxF box = triangle_box(out.triangles[static_cast<const WideLeaf*>(root)->prims[0]]);
    for (std::uint32_t k = 1; k < root->count; ++k)
      box =
          box_union(box, triangle_box(out.triangles[static_cast<const WideLeaf*>(root)->prims[k]]));
    wrapper.count = 1;
    wrapper.children[0] = root;
    wrapper.boxes[0] = box;
  }
  compress_wide_tree(root->leaf ? wrapper : *static_cast<const WideInner*>(root), out);
  out.compress_ms = elapsed_ms<std::chrono::steady_clock>(compress_start);
  if (out.depth > std::uint32_t(kCwbvhStackSize))
    throw Error(ErrorCode::limit_exceeded,
                fmt::format("cwbvh: the tree has {} levels; the traversal stack holds {}",
                            out.depth, kCwbvhStackSize));
  return out;
}

HostCwbvh build_cwbvh_timed(const TriangleMesh& mesh, const AcceleratorOptions& options,
                            BuildStats& stats) {
  const auto start = std::chrono::steady_clock::now();
  HostCwbvh bvh = build_cwbvh(mesh, options.embree_config);
  stats = {};
  stats.build_ms = elapsed_ms<std::chrono::steady_clock>(start);
  stats.phase_ms[std::size_t(BuildPhase::bvh_build)] = bvh.embree_ms;
  stats.phase_ms[std::size_t(BuildPhase::bvh_compress)] = bvh.compress_ms;
  stats.memory_bytes = bvh.memory_bytes();
  stats.bvh = BvhStats{bvh.nodes.size(),
                       bvh.refs.size(),
                       bvh.depth,
                       bvh.nodes.size() * sizeof(CwbvhNode),
                       bvh.refs.size() * sizeof(std::uint32_t),
                       bvh.triangles.size() * sizeof(TriangleVertices)};
  if (options.on_phase) {
    options.on_phase(BuildPhase::bvh_build);
    options.on_phase(BuildPhase::bvh_compress);
  }
  return bvh;
}

}  // namespace irgrid
