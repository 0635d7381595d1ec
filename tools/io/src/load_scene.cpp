// load_scene: dispatches a scene spec to the built-in generator or the OBJ / PLY loaders.
#include <algorithm>
#include <cctype>
#include <filesystem>
#include <new>
#include <string>

#include "irgrid/error.h"
#include "irgrid/io/scene.h"

namespace irgrid {
namespace detail {
// Defined in obj_loader.cpp and ply_loader.cpp; they keep invalid triangles for us to drop.
Scene load_obj_file(const std::string& path);
Scene load_ply_file(const std::string& path);
}  // namespace detail

namespace {

std::string lower_case(std::string text) {
  std::transform(text.begin(), text.end(), text.begin(),
                 [](unsigned char c) { return char(std::tolower(c)); });
  return text;
}

// "dir/mesh.obj.xz" -> "dir/mesh.obj": the compression suffix says nothing of the format.
std::string strip_compression_suffix(const std::string& path) {
  const std::string lower = lower_case(path);
  for (const char* suffix : {".gz", ".xz"})
    if (lower.size() > 3 && lower.ends_with(suffix)) return path.substr(0, path.size() - 3);
  return path;
}

// The folder holding the file ("crytek-sponza"), or the file's stem when there is none.
std::string scene_name(const std::string& path) {
  const std::filesystem::path uncompressed(strip_compression_suffix(path));
  const std::string folder = uncompressed.parent_path().filename().string();
  if (folder.empty() || folder == "." || folder == "..") return uncompressed.stem().string();
  return folder;
}

void warn_about_drops(const std::string& path, SceneReport& report) {
  const auto warn = [&](std::uint64_t count, const char* what) {
    if (count > 0)
      report.warnings.push_back(path + ": dropped " + std::to_string(count) + " " + what);
  };
  warn(report.dropped_bad_index, "triangles with an out-of-range vertex index");
  warn(report.dropped_nonfinite, "triangles with a NaN or infinite vertex coordinate");
  warn(report.dropped_degenerate, "degenerate (zero-area) triangles");
}

Scene load_scene_file(const std::string& path) {
  std::error_code ec;
  if (!std::filesystem::exists(path, ec)) throw Error(ErrorCode::io, path + ": no such file");
  const std::string extension =
      lower_case(std::filesystem::path(strip_compression_suffix(path)).extension().string());
  try {
    if (extension == ".obj") return detail::load_obj_file(path);
    if (extension == ".ply") return detail::load_ply_file(path);
  } catch (const std::bad_alloc&) {  // tinyobjloader and std containers throw this
    throw Error(ErrorCode::out_of_memory, path + ": out of memory while loading");
  }
  throw Error(ErrorCode::io, path + ": unknown scene format '" + extension +
                                 "' (expected .obj or .ply, optionally .gz or .xz compressed)");
}

}  // namespace

Scene load_scene(const std::string& spec) {
  constexpr std::string_view kBuiltinPrefix = "builtin:";
  if (spec.starts_with(kBuiltinPrefix))
    return make_builtin_scene(spec.substr(kBuiltinPrefix.size()));
  Scene scene = load_scene_file(spec);
  scene.source = spec;
  scene.name = scene_name(spec);
  drop_invalid_triangles(scene);
  warn_about_drops(spec, scene.report);
  return scene;
}

}  // namespace irgrid
