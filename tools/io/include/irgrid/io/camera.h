// irgrid/io/camera.h: a pinhole camera and the standard views of a scene.
#pragma once

#include <array>
#include <string>
#include <vector>

namespace irgrid {

struct Box3f;
struct Scene;

/// A pinhole camera: eye, the point looked at, the up vector and the vertical field of view.
struct Camera {
  std::array<float, 3> eye{0, 0, 0};
  std::array<float, 3> target{0, 0, -1};
  std::array<float, 3> up{0, 1, 0};
  float fov_deg = 60;
};

/// Reads the cameras of `scene_key` from a views.json file ({"key": [{eye,target,up,fov}, ...]}).
/// Returns an empty list when the key is absent; throws Error{io} for a malformed file.
std::vector<Camera> read_views(const std::string& views_path, const std::string& scene_key);

/// A camera that frames the scene box from a fixed oblique direction (used when no views exist).
Camera auto_camera(const Box3f& box);

/// The cameras for a scene: those of `views_path` if given (Error{io} if it lacks the scene),
/// else the scene's own (built-in scenes), else those of a views.json in the scene file's
/// folder or its parent keyed by the folder's name, else one auto_camera().
std::vector<Camera> scene_views(const Scene& scene, const std::string& views_path = "");

}  // namespace irgrid
