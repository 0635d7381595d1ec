// `irgrid trace`: traces a user's own rays and writes one 16-byte hit per ray, in ray order.
#include <chrono>
#include <cmath>
#include <limits>
#include <optional>

#include <fmt/format.h>

#include "commands.h"
#include "common.h"
#include "irgrid/error.h"
#include "irgrid/io/rays.h"

namespace irgrid::cli {
namespace {

struct TraceOptions {
  std::string scene, rays_file, format = "irgrid", output;
  StructureOptions structure;
  std::optional<float> tmin, tmax;
  bool any_hit = false;
};

/// Hit files name triangles as the input file numbers them (before invalid ones were dropped);
/// any-hit records carry t = 0 when occluded and infinity otherwise.
void to_file_convention(const Scene& scene, std::span<Hit> hits, bool any_hit) {
  const float inf = std::numeric_limits<float>::infinity();
  for (Hit& hit : hits) {
    if (hit.hit()) hit.prim = scene.input_ids[hit.prim];
    if (any_hit) hit = hit.hit() ? Hit{hit.prim, 0.f, 0.f, 0.f} : Hit{kNoHit, inf, 0.f, 0.f};
  }
}

void run_trace(const TraceOptions& o) {
  const RayFormat format = parse_ray_format(o.format);
  const float inf = std::numeric_limits<float>::infinity();
  if (!(o.tmin.value_or(0.f) <= o.tmax.value_or(inf)))
    throw Error(ErrorCode::invalid_argument,
                fmt::format("--tmin {} and --tmax {} leave no interval to hit in",
                            o.tmin.value_or(0.f), o.tmax.value_or(inf)));
  check_writable(o.output);
  auto rays = read_rays(o.rays_file, format, o.tmin.value_or(0.f), o.tmax.value_or(inf));
  if (format == RayFormat::irgrid && (o.tmin || o.tmax))
    for (Ray& ray : rays)
      ray.tmin = o.tmin.value_or(ray.tmin), ray.tmax = o.tmax.value_or(ray.tmax);
  const Scene scene = load_scene_reporting(o.scene);
  const auto tracer = build_reporting(scene, o.structure);
  std::vector<Hit> hits(rays.size());
  const auto start = std::chrono::steady_clock::now();
  trace_with_progress(*tracer, rays, hits, o.any_hit ? Query::any : Query::closest, "tracing");
  const double ms = milliseconds_since(start);
  std::size_t hit_count = 0;
  for (const Hit& hit : hits)
    hit_count += hit.hit();
  to_file_convention(scene, hits, o.any_hit);
  write_hits(o.output, hits);
  fmt::print("traced {} rays ({} {}) in {:.1f} ms ({:.2f} MRays/s), wrote {} hits to {}\n",
             rays.size(), hit_count, o.any_hit ? "occluded" : "hits", ms,
             ms > 0 ? rays.size() / ms / 1000 : 0.0, hits.size(), o.output);
}

}  // namespace

void add_trace_command(CLI::App& app) {
  auto o = std::make_shared<TraceOptions>();
  auto* cmd =
      app.add_subcommand("trace", "Trace rays from a file; write 16-byte hits (prim, t, u, v)");
  cmd->add_option("scene", o->scene, "Scene file or builtin:NAME[:N]")->required();
  cmd->add_option("--rays", o->rays_file, "Ray file")->required();
  cmd->add_option("--format", o->format, "irgrid (32 B/ray) or hagrid (24 B/ray)")
      ->capture_default_str();
  cmd->add_option("--tmin", o->tmin, "Ray start for all rays (hagrid: default 0)");
  cmd->add_option("--tmax", o->tmax, "Ray end for all rays (hagrid: default infinity)");
  cmd->add_flag("--any-hit", o->any_hit,
                "Occlusion query: t = 0 when occluded, infinity otherwise");
  cmd->add_option("-o,--output", o->output, "Hit file to write")->required();
  add_structure_options(cmd, o->structure);
  cmd->callback([o] { run_trace(*o); });
}

}  // namespace irgrid::cli
