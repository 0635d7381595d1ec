// api/lazy_host_triangles.h: a host copy of a structure's triangles, made on first use, for the
// structures that keep theirs in another layout (Embree's buffers) or in device memory.
#pragma once

#include <mutex>
#include <span>
#include <vector>

#include "core/release_buffer.h"
#include "irgrid/kernel/triangle.h"

namespace irgrid {

/// The triangles by index, filled by `fill(std::vector<TriangleVertices>&)` the first time get
/// is called after construction or reset: only trace(RayArrays, HitArrays) with normals on such
/// a structure pays for the copy. get may be called from many threads at once; reset (at a
/// rebuild) may not run beside it, as rebuild may not run beside a trace.
class LazyHostTriangles {
 public:
  template <typename Fill>
  std::span<const TriangleVertices> get(Fill&& fill) const {
    const std::lock_guard lock(mutex_);
    if (!filled_) {
      fill(triangles_);
      filled_ = true;
    }
    return triangles_;
  }
  /// Drops the copy (the triangles moved).
  void reset() {
    release_buffer(triangles_);
    filled_ = false;
  }

 private:
  mutable std::mutex mutex_;
  mutable std::vector<TriangleVertices> triangles_;
  mutable bool filled_ = false;
};

}  // namespace irgrid
