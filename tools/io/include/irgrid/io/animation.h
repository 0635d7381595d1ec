// irgrid/io/animation.h: deterministic animation frames of a scene, for rebuild benchmarks.
#pragma once

#include <vector>

#include "irgrid/io/scene.h"

namespace irgrid {

/// The vertices of frame `frame` (0 <= frame < frames) of a scene that twists about its
/// vertical axis and ripples, written into `out` (resized to the scene's vertex count). Frame 0
/// is the rest pose; the triangles stay the same, every vertex off the axis moves, and the box
/// stays within 1.5 times the rest pose's. The same arguments always give the same frame.
void animate_vertices(const Scene& rest, int frame, int frames, std::vector<Vec3f>& out);

}  // namespace irgrid
