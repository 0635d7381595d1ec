// Scene loading, building and tracing with reports and progress, shared by the subcommands.
#include "common.h"

#include <charconv>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string_view>

#include <fmt/format.h>

#include "irgrid/error.h"
#include "irgrid/io/camera.h"
#include "progress.h"

namespace irgrid::cli {

double milliseconds_since(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start)
      .count();
}

void check_writable(const std::string& path) {
  std::error_code ignored;
  const bool existed = std::filesystem::exists(path, ignored);
  if (!std::ofstream(path, std::ios::app))
    throw Error(ErrorCode::io, fmt::format("{}: cannot create", path));
  // A failed command should not leave an empty file behind.
  if (!existed) std::filesystem::remove(path, ignored);
}

Scene load_scene_reporting(const std::string& spec) {
  const auto start = std::chrono::steady_clock::now();
  Scene scene = load_scene(spec);
  for (const auto& warning : scene.report.warnings)
    fmt::print(stderr, "warning: {}\n", warning);
  fmt::print(stderr, "loaded {}: {} triangles", spec, scene.triangle_count());
  if (scene.report.dropped() > 0) fmt::print(stderr, " ({} dropped)", scene.report.dropped());
  fmt::print(stderr, " in {:.2f} s\n", milliseconds_since(start) / 1000);
  if (scene.triangles.empty())
    throw Error(ErrorCode::invalid_argument, fmt::format("{}: no valid triangles", spec));
  return scene;
}

namespace {

/// Checks a grid option while parsing, so a bad value is reported before a large scene loads:
/// a finite number with accepts(value) true, else the error `rule`.
template <typename Accepts>
CLI::Validator finite_number(const char* rule, Accepts accepts) {
  return CLI::Validator(
      [rule, accepts](std::string& text) -> std::string {
        double value = 0;
        if (!CLI::detail::lexical_cast(text, value) || !std::isfinite(value) || !accepts(value))
          return fmt::format("{} is not {}", text, rule);
        return {};
      },
      "");
}

}  // namespace

CLI::Validator whole_number(std::uint64_t least) {
  return CLI::Validator(
      [least](std::string& text) -> std::string {
        const char* end = text.data() + text.size();
        std::uint64_t value = 0;
        const auto [stop, error] = std::from_chars(text.data(), end, value);
        if (text.empty() || error != std::errc() || stop != end || value < least)
          return fmt::format("'{}' is not a whole number{}", text,
                             least == 0 ? " >= 0" : " >= " + std::to_string(least));
        return {};
      },
      "");
}

void add_structure_options(CLI::App* command, StructureOptions& options) {
  command->add_option(
      "--structure", options.structure,
      "irregular (default), embree, embree-packets, cwbvh, two-level, uniform or brute");
  // Checked while parsing, so a missing GPU is reported before a large scene is loaded.
  command->add_option("--backend", options.backend, "cpu, cuda or auto")
      ->capture_default_str()
      ->each([](const std::string& backend) { resolve_backend(parse_backend(backend)); });
  BuildConfig& grid = options.grid;
  command->add_option("--lambda1", grid.lambda1, "Top-level density")
      ->capture_default_str()
      ->check(finite_number("a positive number", [](double v) { return v > 0; }))
      ->group("Grid");
  command->add_option("--lambda2", grid.lambda2, "Second-level (octree) density")
      ->capture_default_str()
      ->check(finite_number("a number >= 0", [](double v) { return v >= 0; }))
      ->group("Grid");
  command
      ->add_option("--min-cells", grid.min_cells,
                   "Small irregular grids raise lambda2 until the octrees aim at this many "
                   "cells (0: off)")
      ->capture_default_str()
      ->group("Grid");
  command
      ->add_option("--split-refs", grid.split_refs,
                   "Octree nodes holding more references split past their lambda2 depth (0: off)")
      ->capture_default_str()
      ->group("Grid");
  command
      ->add_option("--alpha", grid.alpha,
                   "Merging stops when a sweep keeps alpha x the cells (<= 0: off)")
      ->capture_default_str()
      ->check(finite_number("a finite number", [](double) { return true; }))
      ->group("Grid");
  command
      ->add_option("--cost-ratio", grid.cost_ratio, "Traversal step cost in triangle tests (SAH)")
      ->capture_default_str()
      ->check(finite_number("a number >= 0", [](double v) { return v >= 0; }))
      ->group("Grid");
  command
      ->add_option("--empty-aspect", grid.empty_aspect,
                   "Largest aspect ratio of merged empty cells (0: no bound)")
      ->capture_default_str()
      ->check(finite_number("0 or a number >= 1", [](double v) { return v == 0 || v >= 1; }))
      ->group("Grid");
  command
      ->add_option("--expansion-passes", grid.expansion_passes,
                   "Exit-box expansion passes (0: off)")
      ->capture_default_str()
      ->check(finite_number("a number >= 0", [](double v) { return v >= 0; }))
      ->group("Grid");
  command
      ->add_flag("--partial-expansion,!--no-partial-expansion", grid.partial_expansion,
                 "Let cells grow part-way into neighbours (default on)")
      ->group("Grid");
  command
      ->add_flag("--skip-empty,!--no-skip-empty", grid.skip_empty,
                 "Rays leap across the empty top cells ahead of them (default on)")
      ->group("Grid");
  command
      ->add_flag("--compress,!--no-compress", grid.compress,
                 "16-byte cells when they fit (default on)")
      ->group("Grid");
  command
      ->add_flag("--huge-pages,!--no-huge-pages", grid.huge_pages,
                 "CPU: move the finished grid onto huge pages, faster incoherent rays at a cost "
                 "that some VMs make seconds on large grids (default on)")
      ->group("Grid");
  command
      ->add_option_function<std::uint64_t>(
          "--memory-budget",
          [&grid](std::uint64_t mib) {
            if (mib > (std::uint64_t(1) << 40))
              throw CLI::ValidationError("--memory-budget", "at most 2^40 MiB");
            grid.memory_budget = mib << 20;
          },
          "MiB the grid's construction may use before it coarsens (0: automatic, 1 KiB per "
          "triangle + 96 MiB, at most half the free memory)")
      ->group("Grid");
}

const AcceleratorOptions& environment_options() {
  static const AcceleratorOptions options = [] {
    AcceleratorOptions out;
    if (const char* walk = std::getenv("IRGRID_CPU_WALK")) {
      try {
        out.cpu_walk = parse_cpu_walk(walk);
        if (std::string_view(cpu_walk_in_use(out.cpu_walk)) != to_string(out.cpu_walk) &&
            out.cpu_walk != CpuWalk::automatic) {
          fmt::print(stderr, "warning: IRGRID_CPU_WALK={}: this CPU has no {}; ignored\n", walk,
                     walk);
          out.cpu_walk = CpuWalk::automatic;
        }
      } catch (const Error&) {
        fmt::print(stderr,
                   "warning: IRGRID_CPU_WALK={} is not simd, avx512, avx2, single or "
                   "interleaved; ignored\n",
                   walk);
      }
    }
    if (const char* config = std::getenv("IRGRID_EMBREE_CONFIG")) out.embree_config = config;
    out.profile_primitives = std::getenv("IRGRID_PRIMITIVE_PROFILE") != nullptr;
    return out;
  }();
  return options;
}

AcceleratorOptions accelerator_options(const std::string& backend, const BuildConfig& grid) {
  AcceleratorOptions options = environment_options();
  options.backend = parse_backend(backend);
  options.grid = grid;
  return options;
}

std::unique_ptr<Accelerator> make_structure(const Scene& scene, Structure structure,
                                            const AcceleratorOptions& options) {
  auto accelerator = make_accelerator(scene, structure, options);
  for (const auto& [name, ms] : accelerator->build_stats().primitives)
    fmt::print(stderr, "  primitive {:<28} {:9.2f} ms\n", name, ms);
  return accelerator;
}

std::unique_ptr<Accelerator> build_reporting(const Scene& scene, const StructureOptions& structure,
                                             PhaseMemoryRecorder* memory) {
  AcceleratorOptions options = accelerator_options(structure.backend, structure.grid);
  const Structure chosen = structure.parsed_structure();
  Progress progress(fmt::format("building {}", to_string(chosen)), kBuildPhaseCount);
  options.on_phase = [&](BuildPhase phase) {
    if (memory) memory->phase_ended(phase);
    progress.advance(1);
  };
  auto accelerator = make_structure(scene, chosen, options);
  progress.done();
  fmt::print(stderr, "built {} on {} in {:.1f} ms\n", to_string(accelerator->structure()),
             to_string(accelerator->backend()), accelerator->build_stats().build_ms);
  warn_if_budget_limited(*accelerator);
  return accelerator;
}

void warn_if_budget_limited(const Accelerator& accelerator) {
  const auto& grid = accelerator.build_stats().grid;
  if (!grid || !grid->budget_limited) return;
  fmt::print(stderr,
             "warning: the grid reached its construction budget of {} MiB and was built with "
             "coarser cells than asked (traces correctly, more slowly; raise --memory-budget)\n",
             grid->budget_bytes >> 20);
}

void trace_with_progress(const Accelerator& accelerator, std::span<const Ray> rays,
                         std::span<Hit> hits, Query query, const std::string& label) {
  constexpr std::size_t kChunk = 1 << 16;
  Progress progress(label, rays.size());
  for (std::size_t first = 0; first < rays.size(); first += kChunk) {
    const std::size_t count = std::min(kChunk, rays.size() - first);
    accelerator.trace(rays.subspan(first, count), hits.subspan(first, count), query);
    progress.advance(count);
  }
}

std::array<float, 3> parse_vec3(const std::string& text, const std::string& option) {
  std::array<float, 3> out{};
  const auto parts = split_list(text);
  bool ok = parts.size() == 3;
  for (std::size_t i = 0; ok && i < 3; ++i) {
    const char* end = parts[i].data() + parts[i].size();
    const auto result = std::from_chars(parts[i].data(), end, out[i]);
    ok = result.ec == std::errc() && result.ptr == end && std::isfinite(out[i]);
  }
  if (!ok)
    throw Error(ErrorCode::invalid_argument,
                fmt::format("{} '{}': expected three finite numbers x,y,z", option, text));
  return out;
}

std::vector<std::string> split_list(const std::string& text) {
  std::vector<std::string> parts;
  std::size_t start = 0;
  while (start <= text.size()) {
    const std::size_t comma = std::min(text.find(',', start), text.size());
    if (comma > start) parts.push_back(text.substr(start, comma - start));
    start = comma + 1;
  }
  return parts;
}

Camera pick_view(const Scene& scene, int index, const std::string& views_file) {
  const auto views = scene_views(scene, views_file);
  if (index < 0 || std::size_t(index) >= views.size())
    throw Error(ErrorCode::invalid_argument,
                fmt::format("--view {}: scene {} has {} view(s)", index, scene.name, views.size()));
  return views[std::size_t(index)];
}

}  // namespace irgrid::cli
