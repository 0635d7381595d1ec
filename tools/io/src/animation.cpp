// A twisting, rippling deformation of any scene: frames for `irgrid bench --rebuild`.
#include "irgrid/io/animation.h"

#include <cmath>
#include <numbers>

namespace irgrid {

void animate_vertices(const Scene& rest, int frame, int frames, std::vector<Vec3f>& out) {
  out.resize(rest.vertices.size());
  const Box3f box = rest.bounds();
  const float extent = std::fmax(box.diagonal(), 1e-30f);
  const float centre[3] = {0.5f * (box.lo[0] + box.hi[0]), 0.5f * (box.lo[1] + box.hi[1]),
                           0.5f * (box.lo[2] + box.hi[2])};
  // One full period over the frames: frame 0 is the rest pose, the middle frame the most bent.
  const float phase = 2 * std::numbers::pi_v<float> * float(frame) / float(frames > 0 ? frames : 1);
  const float twist = 0.6f * std::sin(0.5f * phase);  // radians across the box's height
  const float ripple = 0.02f * extent * std::sin(0.5f * phase);
  for (std::size_t i = 0; i < rest.vertices.size(); ++i) {
    const Vec3f& p = rest.vertices[i];
    const float x = p[0] - centre[0], y = p[1] - centre[1], z = p[2] - centre[2];
    const float angle = twist * y / extent;
    const float c = std::cos(angle), s = std::sin(angle);
    const float wave = ripple * std::sin(12.f * x / extent + phase);
    out[i] = {centre[0] + c * x - s * z, centre[1] + y + wave, centre[2] + s * x + c * z};
  }
}

}  // namespace irgrid
