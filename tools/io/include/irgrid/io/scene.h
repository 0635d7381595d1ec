// irgrid/io/scene.h: an indexed triangle mesh as loaded from a file or generated built in.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "irgrid/accelerator.h"
#include "irgrid/io/camera.h"
#include "irgrid/mesh.h"

namespace irgrid {

using Vec3f = std::array<float, 3>;

/// Axis-aligned box; empty when lo > hi on any axis.
struct Box3f {
  Vec3f lo{+1e30f, +1e30f, +1e30f};
  Vec3f hi{-1e30f, -1e30f, -1e30f};
  bool empty() const { return lo[0] > hi[0] || lo[1] > hi[1] || lo[2] > hi[2]; }
  void extend(const Vec3f& p);
  /// Length of the diagonal (0 when empty).
  float diagonal() const;
};

/// What a loader read and what it dropped. Dropped triangles are not in Scene::triangles.
struct SceneReport {
  std::uint64_t triangles_read = 0;      ///< after fan-triangulating n-gons (an n-gon gives n-2)
  std::uint64_t vertices_read = 0;       ///< position records in the file
  std::uint64_t dropped_nonfinite = 0;   ///< a vertex coordinate was NaN or infinite
  std::uint64_t dropped_bad_index = 0;   ///< a vertex index was out of range
  std::uint64_t dropped_degenerate = 0;  ///< zero area (repeated index, coincident or collinear)
  std::uint64_t unknown_statements = 0;  ///< lines or elements the loader skipped (OBJ only)
  std::vector<std::string> warnings;     ///< one line each, already naming the file
  std::uint64_t dropped() const {
    return dropped_nonfinite + dropped_bad_index + dropped_degenerate;
  }
};

/// An indexed triangle mesh. Triangle i of the structures and of every Hit::prim is
/// triangles[i]; input_ids[i] is its index among the input's triangles before dropping.
struct Scene {
  std::string name;    ///< short name: the scene's folder ("crytek-sponza") or "builtin:cornell"
  std::string source;  ///< the path or builtin spec it came from
  std::vector<Vec3f> vertices;
  std::vector<std::array<std::uint32_t, 3>> triangles;
  std::vector<std::uint32_t> input_ids;
  std::vector<Camera> views;  ///< cameras shipped with the scene (built-in scenes); may be empty
  SceneReport report;

  std::size_t triangle_count() const { return triangles.size(); }
  /// The library's view of the vertex and index arrays (valid while the scene is unchanged).
  TriangleMesh mesh() const {
    static_assert(sizeof(Vec3f) == 3 * sizeof(float) &&
                  sizeof(triangles[0]) == 3 * sizeof(std::uint32_t));
    return {vertices.empty() ? nullptr : vertices.front().data(), vertices.size(), sizeof(Vec3f),
            triangles.empty() ? nullptr : triangles.front().data(), triangles.size()};
  }
  /// Box of the vertices that kept triangles use.
  Box3f bounds() const;
};

/// Loads a scene. `spec` is a path to .obj or .ply (optionally .gz or .xz compressed) or
/// "builtin:NAME[:N]" (see builtin_scene_names()). Throws Error{io} naming the path (and line)
/// for a missing, unreadable or malformed file, Error{invalid_argument} for an unknown builtin.
Scene load_scene(const std::string& spec);

/// Reads a whole file, transparently decompressing by suffix (.gz via zlib, .xz via liblzma).
/// Throws Error{io} naming the path.
std::string read_file_decompressed(const std::string& path);

/// Names of the built-in procedural scenes, with a one-line description each.
std::vector<std::pair<std::string, std::string>> builtin_scene_names();

/// Generates a built-in scene from "NAME" or "NAME:N" (without the "builtin:" prefix).
Scene make_builtin_scene(const std::string& spec);

/// Removes triangles with an out-of-range index, a non-finite vertex or zero area, counting
/// them into scene.report, and fills input_ids. Loaders call it once at the end.
void drop_invalid_triangles(Scene& scene);

/// Throws Error{invalid_argument} naming the first triangle that has a vertex index out of range
/// or a vertex with a NaN or infinite coordinate (loaded scenes never do: their loaders drop
/// such triangles; call drop_invalid_triangles on a scene built by hand to do the same).
/// It is check_mesh(scene.mesh()) with the scene's name in the message.
void check_scene(const Scene& scene);

/// make_accelerator over the scene's mesh, after check_scene (so that errors name the scene).
std::unique_ptr<Accelerator> make_accelerator(const Scene& scene, Structure structure,
                                              const AcceleratorOptions& options = {});

}  // namespace irgrid
