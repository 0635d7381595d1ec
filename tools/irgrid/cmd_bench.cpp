// `irgrid bench`: builds structures, traces the standard rays, validates, then reports speed.
#include <algorithm>
#include <chrono>
#include <cstdlib>
#include <cstring>
#include <memory>
#include <optional>

#include <fmt/format.h>

#include "bench_rebuild.h"
#include "bench_report.h"
#include "commands.h"
#include "common.h"
#include "device_timing.h"
#include "irgrid/error.h"
#include "irgrid/io/camera.h"
#include "irgrid/io/exact.h"
#include "irgrid/io/rays.h"
#include "irgrid/io/validate.h"
#include "irgrid/system.h"
#include "paper_table.h"
#include "progress.h"

namespace irgrid::cli {
namespace {

/// The command line: the settings the JSON records, and the rest.
struct BenchOptions : BenchSettings {
  std::string scene, format = "irgrid", json, compare;
  StructureOptions structure;
  bool any_hit = false;
  bool paper_table = false;  ///< print the paper's table (paper_table.h) after the results
  int rebuild = 0;           ///< frames of `--rebuild`; 0: the ray benchmark
};

double median(std::vector<double> values) {
  std::sort(values.begin(), values.end());
  const std::size_t n = values.size();
  return n % 2 ? values[n / 2] : 0.5 * (values[n / 2 - 1] + values[n / 2]);
}

/// The median wall time, in ms, of `repeat` calls of `call`.
template <typename Call>
double median_ms_of(int repeat, Call&& call) {
  std::vector<double> times;
  for (int i = 0; i < repeat; ++i) {
    const auto start = std::chrono::steady_clock::now();
    call();
    times.push_back(milliseconds_since(start));
  }
  return median(std::move(times));
}

/// MRays/s of `rays` traced in `ms` (0 for no time).
double mrays_per_s(std::uint64_t rays, double ms) {
  return ms > 0 ? double(rays) / ms / 1000.0 : 0.0;
}

/// Rays whose hits differ in triangle, t, u or v (bit for bit).
std::size_t count_differing_hits(std::span<const Hit> a, std::span<const Hit> b) {
  std::size_t differ = 0;
  for (std::size_t i = 0; i < a.size(); ++i)
    differ += std::memcmp(&a[i], &b[i], sizeof(Hit)) != 0;
  return differ;
}

/// One structure under test: "name" or "name@backend" of --compare.
struct Contender {
  AcceleratorOptions options;
  Structure structure = kDefaultStructure;
  std::unique_ptr<Accelerator> accelerator;
  BenchResult result;
};

std::vector<Contender> parse_contenders(const BenchOptions& o) {
  std::vector<std::string> names = split_list(o.compare);
  if (names.size() == 1 && names.front() == "all") {  // every structure built in but brute force
    names.clear();
    for (const Structure structure : available_structures())
      if (structure != Structure::brute) names.push_back(to_string(structure));
    // With a GPU visible (and --backend auto or cuda), the GPU grid leads and the rest run on
    // the CPU, so one command compares both backends.
    if (o.structure.backend != "cpu" && !cuda_status().gpus.empty()) {
      for (auto& name : names)
        name += "@cpu";
      names.insert(names.begin(), std::string(to_string(kDefaultStructure)) + "@cuda");
    }
  }
  if (names.empty() && !o.compare.empty())
    throw Error(ErrorCode::invalid_argument,
                "--compare '" + o.compare + "' names no structure (e.g. irregular,embree)");
  if (names.empty()) names.push_back(to_string(o.structure.parsed_structure()));
  std::vector<Contender> contenders;
  for (const auto& name : names) {
    Contender c;
    const auto at = name.find('@');
    c.structure = parse_structure(name.substr(0, at));
    c.options = accelerator_options(
        at == std::string::npos ? o.structure.backend : name.substr(at + 1), o.structure.grid);
    contenders.push_back(std::move(c));
  }
  return contenders;
}

/// Builds once to warm up, then `repeat` more times; keeps the last and the median time (the
/// warm-up's time when repeat is 0).
void timed_build(const Scene& scene, int repeat, Contender& c) {
  Progress progress(fmt::format("building {} ({} times)", to_string(c.structure), repeat + 1),
                    std::uint64_t(repeat + 1) * kBuildPhaseCount);
  AcceleratorOptions options = c.options;
  options.on_phase = [&](BuildPhase) { progress.advance(1); };
  c.accelerator = make_structure(scene, c.structure, options);
  std::vector<double> times;
  for (int i = 0; i < repeat; ++i) {
    c.accelerator.reset();
    c.accelerator = make_structure(scene, c.structure, options);
    times.push_back(c.accelerator->build_stats().build_ms);
  }
  if (times.empty()) times.push_back(c.accelerator->build_stats().build_ms);  // the warm-up's
  progress.done();
  warn_if_budget_limited(*c.accelerator);
  c.result = {scene.name,
              scene.triangle_count(),
              to_string(c.accelerator->structure()),
              to_string(c.accelerator->backend()),
              c.accelerator->build_stats(),
              {},
              {}};
  if (is_grid(c.structure)) c.result.grid = c.options.grid;
  c.result.build.build_ms = median(times);
  fmt::print(stderr, "built {} on {}: {:.1f} ms (median of {} builds)\n", c.result.structure,
             c.result.backend, c.result.build.build_ms, times.size());
}

/// --hit-arrays: times `rays` traced as Python's cast_rays traces them (rows of origin and
/// direction read in place, the hits written to separate arrays, reused between repetitions),
/// into run.arrays_*, and checks every ray's fields against `hits`, the records' trace.
void measure_hit_arrays(const Scene& scene, const Accelerator& accelerator,
                        std::span<const Ray> rays, std::span<const Hit> hits, Query query,
                        int repeat, BenchRun& run) {
  const std::size_t n = rays.size();
  if (n == 0) return;
  std::vector<float> rows(6 * n), tmin(n), tmax(n);
  for (std::size_t i = 0; i < n; ++i) {
    std::copy(rays[i].org, rays[i].org + 3, &rows[6 * i]);
    std::copy(rays[i].dir, rays[i].dir + 3, &rows[6 * i + 3]);
    tmin[i] = rays[i].tmin, tmax[i] = rays[i].tmax;
  }
  const auto all_equal = [](const std::vector<float>& v) {
    return std::all_of(v.begin(), v.end(), [&](float x) { return x == v[0]; });
  };
  RayArrays in;
  in.count = n;
  in.origins = rows.data(), in.origin_stride = 6;
  in.directions = rows.data() + 3, in.direction_stride = 6;
  // One value for all rays as Python passes it (tmin=0.0, tmax=inf), else one per ray.
  in.tmin = tmin.data(), in.tmin_stride = all_equal(tmin) ? 0 : 1;
  in.tmax = tmax.data(), in.tmax_stride = all_equal(tmax) ? 0 : 1;
  std::vector<float> t(n), uv(2 * n), normals(3 * n);
  std::vector<std::uint32_t> prim(n);
  HitArrays out;
  out.t = t.data(), out.prim = prim.data();
  out.u = uv.data(), out.v = uv.data() + 1, out.u_stride = out.v_stride = 2;
  out.normal = normals.data();
  accelerator.trace(in, out, query);  // warm-up
  const double ms = median_ms_of(repeat, [&] { accelerator.trace(in, out, query); });
  for (std::size_t i = 0; i < n; ++i) {
    const Hit h{prim[i], t[i], uv[2 * i], uv[2 * i + 1]};
    Vec3<float> expected{0, 0, 0};
    if (hits[i].hit()) {
      const auto& tri = scene.triangles[hits[i].prim];
      const auto at = [&](int k) { return Vec3<float>::from(scene.vertices[tri[k]]); };
      expected = triangle_normal({at(0), at(1), at(2)});
    }
    const bool same_normal = normals[3 * i] == expected.x && normals[3 * i + 1] == expected.y &&
                             normals[3 * i + 2] == expected.z;
    if (std::memcmp(&h, &hits[i], sizeof(Hit)) != 0 || !same_normal)
      throw Error(ErrorCode::internal,
                  fmt::format("{} {} view {}: the trace into arrays and into Hit records disagree "
                              "on ray {}",
                              to_string(accelerator.structure()), run.kind, run.view, i));
  }
  run.arrays_median_ms = ms;
  run.arrays_mrays_per_s = mrays_per_s(n, ms);
}

/// Validates o.validate rays against `reference`, which is null when o.validate is 0.
BenchRun measure(const Scene& scene, const HitReference* reference, const Accelerator& accelerator,
                 std::span<const Ray> rays, Query query, const BenchOptions& o, BenchRun run) {
  std::vector<Hit> hits(rays.size());
  trace_with_progress(
      accelerator, rays, hits, query,
      fmt::format("{} {} view {} warm-up", to_string(accelerator.structure()), run.kind, run.view));
  run.median_ms = median_ms_of(o.repeat, [&] { accelerator.trace(rays, hits, query); });
  run.rays = rays.size();
  run.hits =
      std::size_t(std::count_if(hits.begin(), hits.end(), [](const Hit& h) { return h.hit(); }));
  if (auto device = time_trace_on_device(accelerator, rays, query, o.repeat)) {
    // The headline figure of a GPU structure is its kernel's, as in the paper; what the copies
    // cost is reported beside it.
    run.host_median_ms = run.median_ms;
    run.host_mrays_per_s = mrays_per_s(run.rays, run.host_median_ms);
    run.median_ms = median(device->times_ms);
    const std::size_t differ = count_differing_hits(hits, device->hits);
    if (differ != 0)
      throw Error(
          ErrorCode::internal,
          fmt::format("{} {} view {}: trace_device and trace disagree on {} of {} rays",
                      to_string(accelerator.structure()), run.kind, run.view, differ, run.rays));
  }
  run.mrays_per_s = mrays_per_s(run.rays, run.median_ms);
  if (o.hit_arrays) measure_hit_arrays(scene, accelerator, rays, hits, query, o.repeat, run);
  if (accelerator.counts_work() && !rays.empty()) {
    std::vector<RayWork> work(rays.size());
    accelerator.trace_counted(rays, hits, work, query);
    double cells = 0, tests = 0;
    for (const RayWork& w : work)
      cells += w.cells, tests += w.triangles;
    run.cells_per_ray = cells / double(rays.size());
    run.tests_per_ray = tests / double(rays.size());
  }
  if (reference) {
    const auto validation = validate_hits(*reference, scene, rays, hits, query, o.validate);
    run.checked = validation.checked;
    run.mismatches = validation.mismatches;
    run.wrong_triangle = validation.wrong_triangle;
    run.wrong_t = validation.wrong_t;
    run.wrong_uv = validation.wrong_uv;
    run.outside_window = validation.outside_window;
    run.fragile = validation.fragile;
    run.unbounded = validation.unbounded;
    run.unlocated = validation.unlocated;
    for (const auto& example : validation.examples)
      fmt::print(stderr, "mismatch ({} {} view {}): {}\n", to_string(accelerator.structure()),
                 run.kind, run.view, example);
  }
  return run;
}

std::vector<int> chosen_views(const BenchOptions& o, std::size_t available) {
  std::vector<int> views;
  if (o.views.empty()) {
    for (std::size_t i = 0; i < available; ++i)
      views.push_back(int(i));
    return views;
  }
  for (const auto& part : split_list(o.views)) {
    char* end = nullptr;
    const long index = std::strtol(part.c_str(), &end, 10);
    if (*end != '\0' || index < 0 || std::size_t(index) >= available)
      throw Error(ErrorCode::invalid_argument,
                  fmt::format("--views: '{}' is not a view index below {}", part, available));
    views.push_back(int(index));
  }
  if (views.empty())
    throw Error(ErrorCode::invalid_argument,
                fmt::format("--views '{}' names no view index", o.views));
  return views;
}

/// The structure whose primary hits seed the ao and diffuse rays: the default structure with
/// default parameters on the CPU, so that every bench run traces the same rays whatever it
/// compares. A contender that is exactly that structure serves; otherwise it is built into
/// `built` (on Crown, a second irregular grid costs 10 s).
const Accelerator& secondary_ray_source(const Scene& scene,
                                        const std::vector<Contender>& contenders,
                                        std::unique_ptr<Accelerator>& built) {
  for (const auto& c : contenders)
    if (c.structure == kDefaultStructure && c.options.grid == BuildConfig{} &&
        c.accelerator->backend() == Backend::cpu)
      return *c.accelerator;
  built = make_accelerator(scene, kDefaultStructure, environment_options());
  return *built;
}

/// The cameras, views and ray kinds a bench of the standard rays traces, read before any
/// structure is built so that a bad --kinds, --views or --views-file fails at once.
struct StandardRays {
  std::vector<Camera> cameras;
  std::vector<int> views;
  std::vector<RayKind> kinds;
};

StandardRays plan_standard_rays(const Scene& scene, const BenchOptions& o) {
  StandardRays plan{scene_views(scene, o.views_file), {}, {}};
  plan.views = chosen_views(o, plan.cameras.size());
  for (const auto& name : split_list(o.kinds))
    plan.kinds.push_back(parse_ray_kind(name));
  if (plan.kinds.empty())
    throw Error(
        ErrorCode::invalid_argument,
        fmt::format("--kinds '{}' names no ray kind (primary, ao, diffuse, random)", o.kinds));
  return plan;
}

/// Every contender traces the same rays: secondary rays come from the primary hits of one fixed
/// structure (secondary_ray_source).
void run_standard_kinds(const Scene& scene, const HitReference* reference, const BenchOptions& o,
                        const StandardRays& plan, std::vector<Contender>& contenders) {
  const auto& [cameras, views, kinds] = plan;
  std::unique_ptr<Accelerator> built;
  const bool secondary = std::any_of(kinds.begin(), kinds.end(), [](RayKind k) {
    return k == RayKind::ao || k == RayKind::diffuse;
  });
  const Accelerator* generator =
      secondary ? &secondary_ray_source(scene, contenders, built) : nullptr;
  for (int view : views)
    for (RayKind kind : kinds) {
      const auto rays = generate_rays(scene, cameras[std::size_t(view)], kind, o.config, generator);
      const Query query = kind == RayKind::ao ? Query::any : Query::closest;
      for (auto& c : contenders)
        c.result.runs.push_back(
            measure(scene, reference, *c.accelerator, rays, query, o, {to_string(kind), view}));
    }
}

/// `--rebuild N`: the structures of --compare (default: the irregular grid and Embree) rebuilt
/// over N animation frames, validated on view 0's primary rays of the last frame.
int run_rebuild_bench(BenchOptions o) {
  if (o.compare.empty()) {
    o.compare = to_string(kDefaultStructure);
    const auto structures = available_structures();
    if (std::find(structures.begin(), structures.end(), Structure::embree) != structures.end())
      o.compare += std::string(",") + to_string(Structure::embree);
  }
  const Scene scene = load_scene_reporting(o.scene);
  const Camera camera = pick_view(scene, 0, o.views_file);
  std::vector<std::pair<Structure, AcceleratorOptions>> contenders;
  for (const auto& c : parse_contenders(o))
    contenders.emplace_back(c.structure, c.options);
  const auto results = bench_rebuilds(scene, contenders, o.rebuild, camera, o.config.width,
                                      o.config.height, o.validate);
  print_rebuild_table(scene, results);
  if (!o.json.empty())
    write_json_file({{"scene", scene.name},
                     {"scene_file", o.scene},
                     {"triangles", scene.triangle_count()},
                     {"irgrid_version", version()},
                     {"machine", machine_json()},
                     {"rebuild", rebuild_json(results, o.rebuild)}},
                    o.json);
  std::uint64_t mismatches = 0;
  for (const auto& r : results)
    mismatches += r.mismatches;
  if (mismatches == 0) return 0;
  fmt::print(stderr, "irgrid: validation failed: {} mismatching rays\n", mismatches);
  return 1;
}

int run_bench(BenchOptions o) {
  if (o.repeat < 1) throw Error(ErrorCode::invalid_argument, "--repeat must be at least 1");
  if (o.build_repeat < 0) o.build_repeat = o.repeat;
  if (o.config.count == 0)
    o.config.count = std::uint64_t(o.config.width) * std::uint64_t(o.config.height);
  if (!o.json.empty()) check_writable(o.json);
  if (o.rebuild > 0) return run_rebuild_bench(o);
  if (o.paper_table) {
    if (!o.rays_file.empty())
      throw Error(ErrorCode::invalid_argument,
                  "--paper-table traces the standard primary, ao and random rays, not --rays");
    if (o.kinds == BenchSettings{}.kinds) o.kinds = kPaperTableKinds;
    if (o.compare.empty()) o.compare = kPaperTableStructures;
  }
  // A ray file is read, and the standard rays planned, before the builds, so that bad input
  // fails at once.
  std::vector<Ray> file_rays;
  if (!o.rays_file.empty()) file_rays = read_rays(o.rays_file, parse_ray_format(o.format));
  const Scene scene = load_scene_reporting(o.scene);
  std::optional<StandardRays> standard;
  if (o.rays_file.empty()) standard = plan_standard_rays(scene, o);
  auto contenders = parse_contenders(o);
  for (auto& c : contenders)
    timed_build(scene, o.build_repeat, c);
  // The reference is built only to validate (on Crown it takes seconds).
  std::unique_ptr<HitReference> reference;
  if (o.validate > 0 && o.exact) reference = std::make_unique<ExactTracer>(scene);
  if (o.validate > 0 && !o.exact) reference = std::make_unique<ReferenceTracer>(scene);
  if (!o.rays_file.empty()) {
    for (auto& c : contenders)
      c.result.runs.push_back(measure(scene, reference.get(), *c.accelerator, file_rays,
                                      o.any_hit ? Query::any : Query::closest, o, {"file", 0}));
  } else {
    run_standard_kinds(scene, reference.get(), o, *standard, contenders);
  }
  std::vector<BenchResult> results;
  for (auto& c : contenders)
    results.push_back(std::move(c.result));
  for (const auto& result : results)
    print_bench_table(result);
  if (results.size() > 1) print_comparison(results);
  if (o.paper_table) print_paper_table(results);
  if (!o.json.empty()) write_bench_json(results, o.scene, o, o.json);
  std::uint64_t mismatches = 0;
  for (const auto& result : results)
    for (const auto& run : result.runs)
      mismatches += run.mismatches;
  if (mismatches == 0) return 0;
  fmt::print(stderr, "irgrid: validation failed: {} mismatching rays\n", mismatches);
  return 1;
}

}  // namespace

void add_bench_command(CLI::App& app) {
  auto o = std::make_shared<BenchOptions>();
  o->config.count = 0;  // 0: as many random rays as pixels
  auto* cmd =
      app.add_subcommand("bench", "Build, trace the standard rays, validate, report MRays/s");
  cmd->add_option("scene", o->scene, "Scene file or builtin:NAME[:N]")->required();
  add_structure_options(cmd, o->structure);
  cmd->add_option("--compare", o->compare,
                  "Structures to run on the same rays, e.g. irregular,embree,two-level,uniform "
                  "(NAME@BACKEND picks a backend; 'all': every structure but brute); ratios are to "
                  "the first");
  cmd->add_option("--kinds", o->kinds, "Ray kinds, comma-separated")->capture_default_str();
  cmd->add_option("--views", o->views, "View indices, comma-separated (default: all)");
  cmd->add_option("--views-file", o->views_file, "views.json to take the cameras from");
  cmd->add_option("--spp", o->config.spp, "Secondary rays per primary hit")
      ->capture_default_str()
      ->check(CLI::Range(1, kMaxSamplesPerHit));
  cmd->add_option("--width", o->config.width, "Image width of primary rays")
      ->capture_default_str()
      ->check(whole_number(1));
  cmd->add_option("--height", o->config.height, "Image height of primary rays")
      ->check(whole_number(1))
      ->capture_default_str();
  cmd->add_option("--count", o->config.count, "Random rays (default: width x height)")
      ->check(whole_number(0));
  cmd->add_option("--seed", o->config.seed, "Random seed")->capture_default_str();
  cmd->add_option("--rays", o->rays_file, "Trace the rays of this file instead (kind 'file')");
  cmd->add_option("--format", o->format, "Format of --rays: irgrid or hagrid")
      ->capture_default_str();
  cmd->add_flag("--any-hit", o->any_hit, "With --rays: occlusion queries");
  cmd->add_flag("--hit-arrays", o->hit_arrays,
                "Also time each trace into separate t, triangle, uv and unit-normal arrays from "
                "rows of origin and direction, as Python's cast_rays makes it (checked against "
                "the Hit records)");
  cmd->add_option("--repeat", o->repeat, "Timed repetitions (median reported)")
      ->capture_default_str()
      ->check(whole_number(1));
  cmd->add_option("--build-repeat", o->build_repeat,
                  "Timed builds after the warm-up build (default: as many as --repeat; 0: report "
                  "the warm-up build)")
      ->check(whole_number(0));
  cmd->add_option("--validate", o->validate,
                  "Rays per run checked against the double reference (0: off)")
      ->capture_default_str()
      ->check(whole_number(0));
  cmd->add_option("--rebuild", o->rebuild,
                  "Instead of tracing: rebuild each structure (default: irregular and embree) "
                  "over this many frames of a twisting, rippling animation of the scene and "
                  "print each frame's rebuild time")
      ->check(CLI::Range(1, 100000));
  cmd->add_flag(
      "--exact", o->exact,
      "Validate against the exact oracle (GMP rationals) instead of the double reference");
  cmd->add_option("--json", o->json, "Write results as JSON to this file");
  cmd->add_flag("--paper-table", o->paper_table,
                "Also print the paper's table (Markdown): build ms, memory and MRays/s of primary, "
                "ao and random rays (the default --kinds here) for --compare (default "
                "irregular,cwbvh; e.g. irregular@cuda,cwbvh@cuda), with the paper's 2017 GPU "
                "figures for Sponza, Conference and Crown");
  cmd->callback([o] {
    const int code = run_bench(*o);
    if (code != 0) throw CLI::RuntimeError(code);
  });
}

}  // namespace irgrid::cli
