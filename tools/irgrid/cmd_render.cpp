// `irgrid render`: a picture of a scene view (shaded, normals, triangle ids or ambient occlusion).
#include <algorithm>
#include <cmath>

#include <fmt/format.h>
#include <tbb/parallel_for.h>

#include "commands.h"
#include "common.h"
#include "irgrid/error.h"
#include "irgrid/io/camera.h"
#include "irgrid/io/image.h"
#include "irgrid/io/random.h"
#include "irgrid/io/rays.h"
#include "irgrid/kernel/vec.h"

namespace irgrid::cli {
namespace {

struct RenderOptions {
  std::string scene, output, mode = "shaded", views_file, eye, target, up = "0,1,0";
  StructureOptions structure;
  int view = 0, width = 1024, height = 1024, spp = 16;
  float fov = 60;
  bool fov_given = false;  // --fov also overrides a view's field of view
};

using Rgb = Vec3<float>;

std::uint8_t to_byte(float value) {
  return std::uint8_t(std::lround(255.f * std::pow(std::clamp(value, 0.f, 1.f), 1 / 2.2f)));
}

Rgb background(const Ray& ray) {
  const float up = 0.5f + 0.5f * ray.dir[1] /
                              std::sqrt(ray.dir[0] * ray.dir[0] + ray.dir[1] * ray.dir[1] +
                                        ray.dir[2] * ray.dir[2]);
  return Rgb{0.05f, 0.06f, 0.09f} * (1 - up) + Rgb{0.18f, 0.22f, 0.32f} * up;
}

/// Unit geometric normal of the hit triangle, facing the ray.
Vec3<float> facing_normal(const Scene& scene, const Ray& ray, const Hit& hit) {
  const auto& tri = scene.triangles[hit.prim];
  const auto p0 = Vec3<float>::from(scene.vertices[tri[0]]);
  auto n = normalize(cross(Vec3<float>::from(scene.vertices[tri[1]]) - p0,
                           Vec3<float>::from(scene.vertices[tri[2]]) - p0));
  return dot(n, Vec3<float>::from(ray.dir)) > 0 ? -n : n;
}

Rgb shade(const std::string& mode, const Scene& scene, const Ray& ray, const Hit& hit) {
  if (!hit.hit()) return background(ray);
  const auto n = facing_normal(scene, ray, hit);
  if (mode == "normal") return Rgb{n.x, n.y, n.z} * 0.5f + Rgb{0.5f, 0.5f, 0.5f};
  if (mode == "primid") {
    const auto h = hash64(hit.prim);
    return Rgb{float(h & 255), float(h >> 8 & 255), float(h >> 16 & 255)} * (1 / 255.f);
  }
  const float cosine = -dot(n, normalize(Vec3<float>::from(ray.dir)));
  return Rgb{0.85f, 0.80f, 0.72f} * (0.12f + 0.88f * cosine);
}

/// Fraction of unoccluded ambient-occlusion rays per pixel.
std::vector<float> ambient_occlusion(const Scene& scene, const Accelerator& tracer,
                                     std::span<const Ray> primary, std::span<const Hit> hits,
                                     int spp) {
  const auto ao_rays = secondary_rays(scene, primary, hits, RayKind::ao, spp, 0x5eed);
  std::vector<Hit> occlusion(ao_rays.size());
  trace_with_progress(tracer, ao_rays, occlusion, Query::any, "ambient occlusion");
  std::vector<float> visibility(primary.size(), 1.f);
  std::size_t next = 0;
  for (std::size_t i = 0; i < primary.size(); ++i) {
    if (!hits[i].hit()) continue;
    int free = 0;
    for (int s = 0; s < spp; ++s)
      free += !occlusion[next++].hit();
    visibility[i] = float(free) / float(spp);
  }
  return visibility;
}

Camera choose_camera(const Scene& scene, const RenderOptions& o) {
  if (o.eye.empty() != o.target.empty())
    throw Error(ErrorCode::invalid_argument, "--eye and --target go together");
  Camera camera = o.eye.empty()
                      ? pick_view(scene, o.view, o.views_file)
                      : Camera{parse_vec3(o.eye, "--eye"), parse_vec3(o.target, "--target"),
                               parse_vec3(o.up, "--up"), o.fov};
  if (o.fov_given) camera.fov_deg = o.fov;
  return camera;
}

/// Blue (little work) to red (most work) through green and yellow.
Rgb heat_colour(float x) {
  x = std::clamp(x, 0.f, 1.f);
  const Rgb stops[5] = {{0.02f, 0.02f, 0.3f},
                        {0.f, 0.4f, 1.f},
                        {0.f, 0.9f, 0.3f},
                        {1.f, 0.9f, 0.f},
                        {1.f, 0.05f, 0.f}};
  const float scaled = x * 4.f;
  const int i = std::min(int(scaled), 3);
  const float f = scaled - float(i);
  return stops[i] * (1.f - f) + stops[i + 1] * f;
}

/// Per-pixel work (cells visited + triangles tested) as colours, scaled to the 99th percentile.
std::vector<Rgb> heat_map(const Accelerator& tracer, std::span<const Ray> rays,
                          std::span<Hit> hits) {
  std::vector<RayWork> work(rays.size());
  tracer.trace_counted(rays, hits, work, Query::closest);
  std::vector<std::uint32_t> totals(work.size());
  double sum = 0;
  for (std::size_t i = 0; i < work.size(); ++i)
    sum += totals[i] = work[i].cells + work[i].triangles;
  std::vector<std::uint32_t> sorted = totals;
  const std::size_t p99 = sorted.size() * 99 / 100;
  std::nth_element(sorted.begin(), sorted.begin() + std::ptrdiff_t(p99), sorted.end());
  const float scale = float(std::max<std::uint32_t>(sorted[p99], 1));
  fmt::print("work per ray (cells + triangle tests): mean {:.1f}, 99th percentile {:.0f}, max {}\n",
             sum / double(work.size()), scale, *std::max_element(totals.begin(), totals.end()));
  std::vector<Rgb> colours(rays.size());
  for (std::size_t i = 0; i < rays.size(); ++i)
    colours[i] = heat_colour(float(totals[i]) / scale);
  return colours;
}

void run_render(const RenderOptions& o) {
  const std::vector<std::string> modes = {"shaded", "normal", "primid", "ao", "heatmap"};
  if (std::find(modes.begin(), modes.end(), o.mode) == modes.end())
    throw Error(ErrorCode::invalid_argument,
                fmt::format("--mode '{}': expected shaded, normal, primid, ao or heatmap", o.mode));
  check_writable(o.output);
  const Scene scene = load_scene_reporting(o.scene);
  const Camera camera = choose_camera(scene, o);
  const auto tracer = build_reporting(scene, o.structure);
  const auto rays = primary_rays(camera, o.width, o.height);
  std::vector<Hit> hits(rays.size());
  std::vector<Rgb> colours;
  if (o.mode == "heatmap") {
    colours = heat_map(*tracer, rays, hits);
  } else {
    trace_with_progress(*tracer, rays, hits, Query::closest, "primary rays");
    std::vector<float> visibility;
    if (o.mode == "ao") visibility = ambient_occlusion(scene, *tracer, rays, hits, o.spp);
    colours.resize(rays.size());
    tbb::parallel_for(std::size_t(0), rays.size(), [&](std::size_t i) {
      colours[i] = o.mode == "ao"
                       ? (hits[i].hit() ? Rgb{1, 1, 1} * visibility[i] : background(rays[i]))
                       : shade(o.mode, scene, rays[i], hits[i]);
    });
  }
  std::vector<std::uint8_t> pixels(rays.size() * 3);
  for (std::size_t i = 0; i < rays.size(); ++i)
    pixels[3 * i] = to_byte(colours[i].x), pixels[3 * i + 1] = to_byte(colours[i].y),
               pixels[3 * i + 2] = to_byte(colours[i].z);
  write_png(o.output, o.width, o.height, pixels);
  fmt::print("wrote {}x{} {} image to {}\n", o.width, o.height, o.mode, o.output);
}

}  // namespace

void add_render_command(CLI::App& app) {
  auto o = std::make_shared<RenderOptions>();
  auto* cmd = app.add_subcommand("render", "Render a view of a scene to a PNG");
  cmd->set_help_flag("--help", "Print this help message and exit");
  cmd->add_option("scene", o->scene, "Scene file or builtin:NAME[:N]")->required();
  cmd->add_option("-o,--output", o->output, "PNG file to write")->required();
  cmd->add_option("--view", o->view, "Index of the camera in the scene's views")
      ->capture_default_str();
  cmd->add_option("--views-file,--views", o->views_file, "views.json to take the cameras from");
  cmd->add_option("--eye", o->eye, "Camera position x,y,z (with --target)");
  cmd->add_option("--target", o->target, "Point looked at x,y,z");
  cmd->add_option("--up", o->up, "Up vector x,y,z (with --eye)")->capture_default_str();
  auto* fov = cmd->add_option("--fov", o->fov,
                              "Vertical field of view in degrees, in (0, 180) (default: the "
                              "view's; 60 with --eye)");
  cmd->add_option("-w,--width", o->width, "Image width")
      ->capture_default_str()
      ->check(whole_number(1));
  cmd->add_option("-h,--height", o->height, "Image height")
      ->capture_default_str()
      ->check(whole_number(1));
  cmd->add_option("--mode", o->mode, "shaded, normal, primid, ao or heatmap")
      ->capture_default_str();
  cmd->add_option("--spp", o->spp, "Ambient-occlusion rays per pixel (mode ao)")
      ->capture_default_str()
      ->check(CLI::Range(1, kMaxSamplesPerHit));
  add_structure_options(cmd, o->structure);
  cmd->callback([o, fov] {
    o->fov_given = fov->count() > 0;
    run_render(*o);
  });
}

}  // namespace irgrid::cli
