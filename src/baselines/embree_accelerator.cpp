// The Embree 3 baseline (Debian's libembree): same rays, same oneTBB threads, rtcIntersect1.
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstring>
#include <limits>

#include <embree3/rtcore.h>
#include <fmt/format.h>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <xmmintrin.h>

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
  explicit EmbreeCpu(const Scene& scene) {
    const auto start = std::chrono::steady_clock::now();
    device_ = rtcNewDevice(nullptr);
    if (!device_) throw Error(ErrorCode::internal, "embree: rtcNewDevice failed");
    rtcSetDeviceMemoryMonitorFunction(device_, &EmbreeCpu::count_bytes, &bytes_);
    scene_ = rtcNewScene(device_);
    rtcSetSceneBuildQuality(scene_, RTC_BUILD_QUALITY_MEDIUM);
    RTCGeometry geometry = rtcNewGeometry(device_, RTC_GEOMETRY_TYPE_TRIANGLE);
    auto* vertices = static_cast<float*>(
        rtcSetNewGeometryBuffer(geometry, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3,
                                3 * sizeof(float), scene.vertices.size()));
    auto* indices = static_cast<std::uint32_t*>(
        rtcSetNewGeometryBuffer(geometry, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3,
                                3 * sizeof(std::uint32_t), scene.triangles.size()));
    if (!vertices || !indices) throw_embree_error(device_, "allocating geometry buffers");
    std::memcpy(vertices, scene.vertices.data(), scene.vertices.size() * 3 * sizeof(float));
    std::memcpy(indices, scene.triangles.data(),
                scene.triangles.size() * 3 * sizeof(std::uint32_t));
    rtcCommitGeometry(geometry);
    rtcAttachGeometry(scene_, geometry);
    rtcReleaseGeometry(geometry);
    {
      const DenormalsAreZero denormals_are_zero;  // the build runs on this thread and TBB's
      rtcCommitScene(scene_);
    }
    if (rtcGetDeviceError(device_) != RTC_ERROR_NONE) throw_embree_error(device_, "rtcCommitScene");
    info_.build_ms =
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
    info_.phases_ms["commit"] = info_.build_ms;
    info_.memory_bytes = std::uint64_t(bytes_.load());
  }
  ~EmbreeCpu() override {
    if (scene_) rtcReleaseScene(scene_);
    if (device_) rtcReleaseDevice(device_);
  }
  EmbreeCpu(const EmbreeCpu&) = delete;
  EmbreeCpu& operator=(const EmbreeCpu&) = delete;

  std::string structure() const override { return "embree"; }
  std::string backend() const override { return "cpu"; }
  const BuildInfo& build_info() const override { return info_; }

  void trace(std::span<const Ray> rays, std::span<Hit> hits, Query query) const override {
    check_trace_spans(rays, hits);
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, rays.size(), 64), [&](const auto& range) {
      const DenormalsAreZero denormals_are_zero;
      RTCIntersectContext context;
      rtcInitIntersectContext(&context);
      for (std::size_t i = range.begin(); i != range.end(); ++i)
        hits[i] =
            query == Query::closest ? intersect(rays[i], context) : occluded(rays[i], context);
    });
  }

 private:
  static RTCRay to_embree(const Ray& ray) {
    RTCRay r;
    r.org_x = ray.org[0], r.org_y = ray.org[1], r.org_z = ray.org[2], r.tnear = ray.tmin;
    r.dir_x = ray.dir[0], r.dir_y = ray.dir[1], r.dir_z = ray.dir[2], r.tfar = ray.tmax;
    r.time = 0, r.mask = 0xFFFFFFFFu, r.id = 0, r.flags = 0;
    return r;
  }
  Hit intersect(const Ray& ray, RTCIntersectContext& context) const {
    RTCRayHit rayhit;
    rayhit.ray = to_embree(ray);
    rayhit.hit.geomID = RTC_INVALID_GEOMETRY_ID;
    rayhit.hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
    rtcIntersect1(scene_, &context, &rayhit);
    if (rayhit.hit.geomID == RTC_INVALID_GEOMETRY_ID) return Hit{};
    return {rayhit.hit.primID, rayhit.ray.tfar, rayhit.hit.u, rayhit.hit.v};
  }
  Hit occluded(const Ray& ray, RTCIntersectContext& context) const {
    RTCRay r = to_embree(ray);
    rtcOccluded1(scene_, &context, &r);
    if (r.tfar != -std::numeric_limits<float>::infinity()) return Hit{};
    // Embree does not say which triangle occludes, nor where: triangle 0, distance unknown.
    return {0, std::numeric_limits<float>::quiet_NaN(), 0, 0};
  }

  // Embree reports each allocation (bytes > 0) and release (bytes < 0) through this callback.
  static bool count_bytes(void* counter, ssize_t bytes, bool /*post*/) {
    static_cast<std::atomic<std::int64_t>*>(counter)->fetch_add(bytes);
    return true;
  }

  std::atomic<std::int64_t> bytes_{0};
  RTCDevice device_ = nullptr;
  RTCScene scene_ = nullptr;
  BuildInfo info_;
};

}  // namespace

std::unique_ptr<Accelerator> make_embree_cpu(const Scene& scene) {
  return std::make_unique<EmbreeCpu>(scene);
}

}  // namespace irgrid
