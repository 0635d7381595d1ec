// Standard cameras: views.json look-up (../shared/scenes/views.json) and an automatic camera.
#include <cmath>
#include <filesystem>
#include <fstream>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "irgrid/error.h"
#include "irgrid/io/camera.h"
#include "irgrid/io/scene.h"

namespace irgrid {
namespace {

std::array<float, 3> read_vec3(const nlohmann::json& value, const std::string& where) {
  if (!value.is_array() || value.size() != 3)
    throw Error(ErrorCode::io, fmt::format("{}: expected an array of 3 numbers", where));
  std::array<float, 3> out{};
  for (int i = 0; i < 3; ++i) {
    if (!value[i].is_number())
      throw Error(ErrorCode::io, fmt::format("{}: expected an array of 3 numbers", where));
    out[i] = value[i].get<float>();
  }
  return out;
}

Camera read_camera(const nlohmann::json& value, const std::string& where) {
  if (!value.is_object()) throw Error(ErrorCode::io, fmt::format("{}: expected an object", where));
  Camera camera;
  camera.eye = read_vec3(value.value("eye", nlohmann::json()), where + ".eye");
  camera.target = read_vec3(value.value("target", nlohmann::json()), where + ".target");
  if (value.contains("up")) camera.up = read_vec3(value["up"], where + ".up");
  if (value.contains("fov")) {
    if (!value["fov"].is_number())
      throw Error(ErrorCode::io, fmt::format("{}.fov: expected a number", where));
    camera.fov_deg = value["fov"].get<float>();
  }
  if (!(camera.fov_deg > 0 && camera.fov_deg < 180))
    throw Error(ErrorCode::io, fmt::format("{}.fov: {} is not in (0, 180)", where, camera.fov_deg));
  return camera;
}

}  // namespace

std::vector<Camera> read_views(const std::string& views_path, const std::string& scene_key) {
  std::error_code ec;
  if (std::filesystem::exists(views_path, ec) && !std::filesystem::is_regular_file(views_path, ec))
    throw Error(ErrorCode::io, fmt::format("{}: cannot read: not a regular file", views_path));
  std::ifstream file(views_path);
  if (!file) throw Error(ErrorCode::io, fmt::format("{}: cannot open", views_path));
  nlohmann::json root;
  try {
    root = nlohmann::json::parse(file);
  } catch (const nlohmann::json::exception& e) {  // parse errors, and numbers such as 1e400
    throw Error(ErrorCode::io, fmt::format("{}: malformed JSON: {}", views_path, e.what()));
  }
  if (!root.is_object() || !root.contains(scene_key)) return {};
  const auto& list = root[scene_key];
  if (!list.is_array())
    throw Error(ErrorCode::io, fmt::format("{}: \"{}\" is not a list", views_path, scene_key));
  std::vector<Camera> cameras;
  for (std::size_t i = 0; i < list.size(); ++i)
    cameras.push_back(read_camera(list[i], fmt::format("{}: {}[{}]", views_path, scene_key, i)));
  return cameras;
}

Camera auto_camera(const Box3f& box) {
  Camera camera;
  if (box.empty()) return camera;
  const float radius = std::max(0.5f * box.diagonal(), 1e-6f);
  const std::array<float, 3> centre{0.5f * (box.lo[0] + box.hi[0]), 0.5f * (box.lo[1] + box.hi[1]),
                                    0.5f * (box.lo[2] + box.hi[2])};
  // Look from the (+x, +y, +z) octant, far enough that the bounding sphere fills the view.
  const float distance = radius / std::sin(0.5f * camera.fov_deg * 3.14159265f / 180.f);
  const float dir[3] = {0.58f, 0.40f, 0.71f};
  const float norm = std::sqrt(dir[0] * dir[0] + dir[1] * dir[1] + dir[2] * dir[2]);
  for (int a = 0; a < 3; ++a)
    camera.eye[a] = centre[a] + distance * dir[a] / norm;
  camera.target = centre;
  return camera;
}

std::vector<Camera> scene_views(const Scene& scene, const std::string& views_path) {
  const std::string key = scene.name;
  if (!views_path.empty()) {
    auto cameras = read_views(views_path, key);
    if (cameras.empty())
      throw Error(ErrorCode::io, fmt::format("{}: no views for scene \"{}\"", views_path, key));
    return cameras;
  }
  if (!scene.views.empty()) return scene.views;
  namespace fs = std::filesystem;
  if (scene.source.rfind("builtin:", 0) != 0) {
    const fs::path folder = fs::absolute(fs::path(scene.source)).parent_path();
    for (const fs::path& candidate : {folder / "views.json", folder.parent_path() / "views.json"}) {
      if (!fs::exists(candidate)) continue;
      auto cameras = read_views(candidate.string(), key);
      if (!cameras.empty()) return cameras;
    }
  }
  return {auto_camera(scene.bounds())};
}

}  // namespace irgrid
