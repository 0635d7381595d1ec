// The Embree 3 baselines (Debian's libembree): same rays, same oneTBB threads; `embree` traces
// one ray at a time (rtcIntersect1 / rtcOccluded1), `embree-packets` in packets of 8
// consecutive rays (rtcIntersect8 / rtcOccluded8), the way Embree is used for camera rays.
#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstring>
#include <limits>
#include <span>
#include <vector>

#include <embree3/rtcore.h>
#include <fmt/format.h>
#include <tbb/blocked_range.h>
#include <xmmintrin.h>

#include "api/lazy_host_triangles.h"
#include "cpu/parallel.h"
#include "cpu/structures.h"
#include "irgrid/error.h"

namespace irgrid {
namespace {

/// Embree asks for flush-to-zero and denormals-are-zero on its calling threads ("severe
/// performance impact" otherwise); set them for the scope of its calls only, so the rest of
/// the process keeps IEEE behaviour.
class DenormalsAreZero {
 public:
  DenormalsAreZero() : saved_(_mm_getcsr()) {
    _mm_setcsr(saved_ | kFlushToZero | kDenormalsAreZero);
  }
  ~DenormalsAreZero() { _mm_setcsr(saved_); }
  DenormalsAreZero(const DenormalsAreZero&) = delete;
  DenormalsAreZero& operator=(const DenormalsAreZero&) = delete;

 private:
  static constexpr unsigned kFlushToZero = 0x8000, kDenormalsAreZero = 0x0040;
  unsigned saved_;
};

[[noreturn]] void throw_embree_error(RTCDevice device, const char* what) {
  const RTCError code = rtcGetDeviceError(device);
  throw Error(code == RTC_ERROR_OUT_OF_MEMORY ? ErrorCode::out_of_memory : ErrorCode::internal,
              fmt::format("embree: {} failed (error {})", what, int(code)));
}

class EmbreeCpu final : public Accelerator {
 public:
  EmbreeCpu(const TriangleMesh& mesh, bool packets, const std::string& config) : packets_(packets) {
    // The configuration goes through to Embree, e.g. "isa=avx2" to compare with irgrid's AVX2
    // walk (CpuWalk::avx2) on an AVX-512 machine.
    device_ = rtcNewDevice(config.empty() ? nullptr : config.c_str());
    if (!device_)
      throw Error(ErrorCode::invalid_argument,
                  fmt::format("embree: rtcNewDevice failed for the configuration '{}'", config));
    rtcSetDeviceMemoryMonitorFunction(device_, &EmbreeCpu::count_bytes, &bytes_);
    scene_ = rtcNewScene(device_);
    rtcSetSceneBuildQuality(scene_, RTC_BUILD_QUALITY_MEDIUM);
    triangle_count_ = mesh.triangle_count;
    // An empty scene commits with no geometry (Embree cannot allocate empty buffers).
    if (triangle_count_ > 0) attach_triangles(mesh);
    commit(mesh);
  }

  void rebuild(const TriangleMesh& mesh) override {
    check_rebuild(mesh, triangle_count_);
    host_triangles_.reset();
    if (triangle_count_ > 0) {
      // Embree's buffers keep their size when the mesh keeps its vertex count.
      const std::size_t vertex_count = mesh.vertex_count;
      if (vertex_count != vertex_count_) {
        rtcDetachGeometry(scene_, geometry_id_);
        attach_triangles(mesh);
      } else {
        RTCGeometry geometry = rtcGetGeometry(scene_, geometry_id_);
        copy_vertices(mesh, static_cast<float*>(
                                rtcGetGeometryBufferData(geometry, RTC_BUFFER_TYPE_VERTEX, 0)));
        copy_indices(mesh, static_cast<std::uint32_t*>(
                               rtcGetGeometryBufferData(geometry, RTC_BUFFER_TYPE_INDEX, 0)));
        rtcUpdateGeometryBuffer(geometry, RTC_BUFFER_TYPE_VERTEX, 0);
        rtcUpdateGeometryBuffer(geometry, RTC_BUFFER_TYPE_INDEX, 0);
        rtcCommitGeometry(geometry);
      }
    }
    commit(mesh);
  }

  ~EmbreeCpu() override {
    if (scene_) rtcReleaseScene(scene_);
    if (device_) rtcReleaseDevice(device_);
  }
  EmbreeCpu(const EmbreeCpu&) = delete;
  EmbreeCpu& operator=(const EmbreeCpu&) = delete;

  Structure structure() const override {
    return packets_ ? Structure::embree_packets : Structure::embree;
  }
  Backend backend() const override { return Backend::cpu; }
  const BuildStats& build_stats() const override { return info_; }

  using Accelerator::trace;  // and trace over RayArrays / HitArrays, converting
  void trace(std::span<const Ray> rays, std::span<Hit> hits, Query query) const override {
    check_trace_spans(rays, hits);
    irgrid::parallel_for(
        tbb::blocked_range<std::size_t>(0, rays.size(), 64), [&](const auto& range) {
          const DenormalsAreZero denormals_are_zero;
          RTCIntersectContext context;
          rtcInitIntersectContext(&context);
          if (packets_) {
            context.flags = RTC_INTERSECT_CONTEXT_FLAG_COHERENT;
            for (std::size_t first = range.begin(); first < range.end(); first += kPacket)
              trace_packet(rays, hits, first, std::min(kPacket, range.end() - first), query,
                           context);
            return;
          }
          for (std::size_t i = range.begin(); i != range.end(); ++i) {
            float shift;
            const Ray ray = embree_ray(rays[i], shift);
            hits[i] = !embree_accepts(ray)      ? Hit{}
                      : query == Query::closest ? intersect(ray, shift, context)
                                                : occluded(ray, context);
          }
        });
  }

 private:
  /// From Embree's own vertex and index buffers (the mesh is not kept).
  std::span<const TriangleVertices> host_triangles() const override {
    return host_triangles_.get([&](std::vector<TriangleVertices>& out) {
      out.clear();
      if (triangle_count_ == 0) return;
      RTCGeometry geometry = rtcGetGeometry(scene_, geometry_id_);
      const TriangleMesh buffers{
          static_cast<const float*>(rtcGetGeometryBufferData(geometry, RTC_BUFFER_TYPE_VERTEX, 0)),
          vertex_count_, 3 * sizeof(float),
          static_cast<const std::uint32_t*>(
              rtcGetGeometryBufferData(geometry, RTC_BUFFER_TYPE_INDEX, 0)),
          triangle_count_};
      gather_triangles(buffers, out);
    });
  }

  /// Commits the scene (its build) and records the time and memory.
  void commit(const TriangleMesh&) {
    const auto start = std::chrono::steady_clock::now();
    {
      const DenormalsAreZero denormals_are_zero;  // the build runs on this thread and TBB's
      rtcCommitScene(scene_);
    }
    if (rtcGetDeviceError(device_) != RTC_ERROR_NONE) throw_embree_error(device_, "rtcCommitScene");
    info_.build_ms = elapsed_ms<std::chrono::steady_clock>(start);
    info_.memory_bytes = std::uint64_t(bytes_.load());
  }

  /// Copies the mesh's vertices and triangles into one new Embree triangle geometry of scene_.
  void attach_triangles(const TriangleMesh& mesh) {
    RTCGeometry geometry = rtcNewGeometry(device_, RTC_GEOMETRY_TYPE_TRIANGLE);
    auto* vertices = static_cast<float*>(
        rtcSetNewGeometryBuffer(geometry, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3,
                                3 * sizeof(float), mesh.vertex_count));
    auto* indices = static_cast<std::uint32_t*>(
        rtcSetNewGeometryBuffer(geometry, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3,
                                3 * sizeof(std::uint32_t), mesh.triangle_count));
    if (!vertices || !indices) {
      rtcReleaseGeometry(geometry);
      throw_embree_error(device_, "allocating geometry buffers");
    }
    copy_vertices(mesh, vertices);
    copy_indices(mesh, indices);
    rtcCommitGeometry(geometry);
    geometry_id_ = rtcAttachGeometry(scene_, geometry);
    rtcReleaseGeometry(geometry);
    vertex_count_ = mesh.vertex_count;
  }

  static void copy_vertices(const TriangleMesh& mesh, float* out) {
    for (std::size_t k = 0; k < mesh.vertex_count; ++k)
      std::memcpy(out + 3 * k, mesh.vertex(k), 3 * sizeof(float));
  }
  static void copy_indices(const TriangleMesh& mesh, std::uint32_t* out) {
    std::memcpy(out, mesh.indices, mesh.triangle_count * 3 * sizeof(std::uint32_t));
  }

  /// Whether Embree may be given the ray (as embree_ray makes it). Embree 3 asserts (Debian's
  /// build aborts) on a ray whose origin or direction has a component that is not a number or
  /// exceeds 1.844e18 in magnitude, or whose tnear or tfar is not a number or negative; and a
  /// ray with tmin > tmax has no interval to hit in (its tfar could even read as "occluded").
  /// Such rays miss here. irgrid's own structures miss the NaN ones and the empty intervals
  /// too, and trace the huge ones; a hit the reference finds there counts as Embree's mismatch
  /// in validation.
  static bool embree_accepts(const Ray& ray) {
    constexpr float kLargest = 1.844e18f;  // Embree's FLT_LARGE
    for (int a = 0; a < 3; ++a)
      if (!(std::fabs(ray.org[a]) <= kLargest && std::fabs(ray.dir[a]) <= kLargest)) return false;
    return ray.tmin >= 0 && ray.tmin <= ray.tmax;  // false when either is NaN
  }

  /// The ray Embree traces: Embree needs tnear >= 0, so a ray with a negative tmin starts at
  /// org + tmin dir instead, its interval shifted by -tmin; `shift` (tmin, or 0) is added back
  /// to the distance of its hit.
  static Ray embree_ray(const Ray& ray, float& shift) {
    shift = 0;
    if (!(ray.tmin < 0)) return ray;
    Ray moved = ray;
    shift = ray.tmin;
    for (int a = 0; a < 3; ++a)
      moved.org[a] = ray.org[a] + ray.tmin * ray.dir[a];
    moved.tmin = 0;
    moved.tmax = ray.tmax - ray.tmin;
    return moved;
  }

  static RTCRay to_embree(const Ray& ray) {
    RTCRay r;
    r.org_x = ray.org[0], r.org_y = ray.org[1], r.org_z = ray.org[2], r.tnear = ray.tmin;
    r.dir_x = ray.dir[0], r.dir_y = ray.dir[1], r.dir_z = ray.dir[2], r.tfar = ray.tmax;
    r.time = 0, r.mask = 0xFFFFFFFFu, r.id = 0, r.flags = 0;
    return r;
  }
  /// The closest hit of a ray embree_ray made (`shift` its shift).
  Hit intersect(const Ray& ray, float shift, RTCIntersectContext& context) const {
    RTCRayHit rayhit;
    rayhit.ray = to_embree(ray);
    rayhit.hit.geomID = RTC_INVALID_GEOMETRY_ID;
    rayhit.hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
    rtcIntersect1(scene_, &context, &rayhit);
    if (rayhit.hit.geomID == RTC_INVALID_GEOMETRY_ID) return Hit{};
    return {rayhit.hit.primID, rayhit.ray.tfar + shift, rayhit.hit.u, rayhit.hit.v};
  }
  Hit occluded(const Ray& ray, RTCIntersectContext& context) const {
    RTCRay r = to_embree(ray);
    rtcOccluded1(scene_, &context, &r);
    return occlusion(r.tfar);
  }
  /// The any-hit answer from the tfar Embree left: -infinity when the ray is occluded. Embree
  /// does not say which triangle occludes, nor where: triangle 0, distance unknown.
  static Hit occlusion(float tfar) {
    if (tfar != -std::numeric_limits<float>::infinity()) return Hit{};
    return {0, std::numeric_limits<float>::quiet_NaN(), 0, 0};
  }

  static constexpr std::size_t kPacket = 8;
  static constexpr Ray kIdleRay{{0, 0, 0}, 0, {0, 0, 1}, 0};

  /// Traces rays[first, first + count) (count <= 8) as one packet; the other slots, and rays
  /// Embree does not accept, are inactive and miss.
  void trace_packet(std::span<const Ray> rays, std::span<Hit> hits, std::size_t first,
                    std::size_t count, Query query, RTCIntersectContext& context) const {
    alignas(32) int valid[kPacket];
    float shift[kPacket] = {};
    RTCRayHit8 packet;
    RTCRay8& r = packet.ray;
    for (std::size_t k = 0; k < kPacket; ++k) {
      const Ray moved = k < count ? embree_ray(rays[first + k], shift[k]) : kIdleRay;
      valid[k] = k < count && embree_accepts(moved) ? -1 : 0;
      // Inactive slots hold a harmless ray rather than a rejected one's numbers.
      const Ray& ray = valid[k] ? moved : kIdleRay;
      r.org_x[k] = ray.org[0], r.org_y[k] = ray.org[1], r.org_z[k] = ray.org[2];
      r.tnear[k] = ray.tmin;
      r.dir_x[k] = ray.dir[0], r.dir_y[k] = ray.dir[1], r.dir_z[k] = ray.dir[2];
      r.tfar[k] = ray.tmax;
      r.time[k] = 0, r.mask[k] = 0xFFFFFFFFu, r.id[k] = 0, r.flags[k] = 0;
      packet.hit.geomID[k] = RTC_INVALID_GEOMETRY_ID;
      packet.hit.instID[0][k] = RTC_INVALID_GEOMETRY_ID;
    }
    if (query == Query::any) {
      rtcOccluded8(valid, scene_, &context, &r);
      for (std::size_t k = 0; k < count; ++k)
        hits[first + k] = valid[k] ? occlusion(r.tfar[k]) : Hit{};
      return;
    }
    rtcIntersect8(valid, scene_, &context, &packet);
    for (std::size_t k = 0; k < count; ++k)
      hits[first + k] =
          !valid[k] || packet.hit.geomID[k] == RTC_INVALID_GEOMETRY_ID
              ? Hit{}
              : Hit{packet.hit.primID[k], r.tfar[k] + shift[k], packet.hit.u[k], packet.hit.v[k]};
  }

  // Embree reports each allocation (bytes > 0) and release (bytes < 0) through this callback.
  static bool count_bytes(void* counter, ssize_t bytes, bool /*post*/) {
    static_cast<std::atomic<std::int64_t>*>(counter)->fetch_add(bytes);
    return true;
  }

  std::atomic<std::int64_t> bytes_{0};
  RTCDevice device_ = nullptr;
  RTCScene scene_ = nullptr;
  BuildStats info_;
  bool packets_;
  std::size_t triangle_count_ = 0, vertex_count_ = 0;
  LazyHostTriangles host_triangles_;  // for trace(RayArrays, HitArrays) with normals
  unsigned geometry_id_ = RTC_INVALID_GEOMETRY_ID;
};

}  // namespace

std::unique_ptr<Accelerator> make_embree_cpu(const TriangleMesh& mesh, bool packets,
                                             const std::string& config) {
  return std::make_unique<EmbreeCpu>(mesh, packets, config);
}

}  // namespace irgrid
