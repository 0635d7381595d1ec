// Tables and JSON for `irgrid bench` (JSON layout documented in docs/bench-json.md).
#include "bench_report.h"

#include <algorithm>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "common.h"
#include "config_json.h"
#include "irgrid/error.h"
#include "irgrid/io/machine.h"
#include "irgrid/io/output_file.h"
#include "irgrid/system.h"

namespace irgrid::cli {

void print_bench_table(const BenchResult& r) {
  const auto machine = machine_info(environment_options().cpu_walk);
  fmt::print(
      "scene {}: {} triangles | structure {} on {} | build {:.2f} ms | memory {:.2f} MiB "
      "({:.1f} B/triangle)\n",
      r.scene, r.triangles, r.structure, r.backend, r.build.build_ms,
      r.build.memory_bytes / 1048576.0,
      r.triangles ? double(r.build.memory_bytes) / double(r.triangles) : 0.0);
  // The walk matters only to the CPU grids' runs.
  const bool cpu_grid = r.backend == "cpu" && r.grid;
  fmt::print("machine: {}, {} threads{}{}\n", machine.cpu_model, machine.tbb_threads,
             cpu_grid ? ", " + machine.cpu_walk + " walk" : "",
             machine.gpu.empty() ? "" : ", GPU " + machine.gpu);
  fmt::print("{:>4}  {:<8} {:>10} {:>10} {:>10} {:>10} {:>9} {:>10} {:>11} {:>11}\n", "view",
             "kind", "rays", "hits", "ms", "MRays/s", "checked", "mismatches", "cells/ray",
             "tests/ray");
  for (const auto& run : r.runs) {
    const auto per_ray = [](double x) {
      return x < 0 ? std::string("-") : fmt::format("{:.2f}", x);
    };
    fmt::print("{:>4}  {:<8} {:>10} {:>10} {:>10.2f} {:>10.2f} {:>9} {:>10} {:>11} {:>11}\n",
               run.view, run.kind, run.rays, run.hits, run.median_ms, run.mrays_per_s, run.checked,
               run.mismatches, per_ray(run.cells_per_ray), per_ray(run.tests_per_ray));
  }
  if (std::any_of(r.runs.begin(), r.runs.end(),
                  [](const BenchRun& run) { return run.host_mrays_per_s >= 0; })) {
    fmt::print(
        "MRays/s above: the kernel alone, rays and hits on the device; with the copies of "
        "rays and hits (trace over host arrays):\n");
    for (const auto& run : r.runs)
      fmt::print("{:>4}  {:<8} {:>10.2f} ms {:>10.2f} MRays/s\n", run.view, run.kind,
                 run.host_median_ms, run.host_mrays_per_s);
  }
  if (std::any_of(r.runs.begin(), r.runs.end(),
                  [](const BenchRun& run) { return run.arrays_mrays_per_s >= 0; })) {
    fmt::print("--hit-arrays: the trace into separate t, triangle, uv and normal arrays:\n");
    for (const auto& run : r.runs)
      fmt::print("{:>4}  {:<8} {:>10.2f} ms {:>10.2f} MRays/s\n", run.view, run.kind,
                 run.arrays_median_ms, run.arrays_mrays_per_s);
  }
  print_validation_table(r);
}

void print_validation_table(const BenchResult& r) {
  if (std::none_of(r.runs.begin(), r.runs.end(), [](const BenchRun& run) { return run.checked; }))
    return;
  fmt::print("validation:\n{:>4}  {:<8} {:>9} {:>10} {:>8} {:>9} {:>8} {:>9} {:>10} {:>10}\n",
             "view", "kind", "checked", "wrong-tri", "wrong-t", "wrong-uv", "outside", "fragile",
             "unbounded", "unlocated");
  for (const auto& run : r.runs)
    fmt::print("{:>4}  {:<8} {:>9} {:>10} {:>8} {:>9} {:>8} {:>9} {:>10} {:>10}\n", run.view,
               run.kind, run.checked, run.wrong_triangle, run.wrong_t, run.wrong_uv,
               run.outside_window, run.fragile, run.unbounded, run.unlocated);
}

void print_comparison(const std::vector<BenchResult>& results) {
  fmt::print("\ncomparison (MRays/s; ratio to {}):\n{:>4}  {:<8}", results.front().structure,
             "view", "kind");
  for (const auto& r : results)
    fmt::print(" {:>16}", r.structure + "@" + r.backend);
  fmt::print("\n");
  for (std::size_t i = 0; i < results.front().runs.size(); ++i) {
    const auto& first = results.front().runs[i];
    fmt::print("{:>4}  {:<8}", first.view, first.kind);
    for (const auto& r : results) {
      const double ratio = first.mrays_per_s > 0 ? r.runs[i].mrays_per_s / first.mrays_per_s : 0.0;
      fmt::print(" {:>9.2f} ({:.2f})", r.runs[i].mrays_per_s, ratio);
    }
    fmt::print("\n");
  }
  fmt::print("{:<14}", "build ms");
  for (const auto& r : results)
    fmt::print(" {:>16.1f}", r.build.build_ms);
  fmt::print("\n{:<14}", "memory MiB");
  for (const auto& r : results)
    fmt::print(" {:>16.2f}", r.build.memory_bytes / 1048576.0);
  fmt::print("\n");
}

namespace {

nlohmann::json result_json(const BenchResult& r) {
  nlohmann::json runs = nlohmann::json::array();
  for (const auto& run : r.runs) {
    nlohmann::json entry = {{"kind", run.kind},           {"view", run.view},
                            {"rays", run.rays},           {"hits", run.hits},
                            {"median_ms", run.median_ms}, {"mrays_per_s", run.mrays_per_s},
                            {"checked", run.checked},     {"mismatches", run.mismatches}};
    if (run.host_median_ms >= 0) {
      entry["host_median_ms"] = run.host_median_ms;
      entry["host_mrays_per_s"] = run.host_mrays_per_s;
    }
    if (run.arrays_median_ms >= 0) {
      entry["arrays_median_ms"] = run.arrays_median_ms;
      entry["arrays_mrays_per_s"] = run.arrays_mrays_per_s;
    }
    if (run.checked > 0)
      entry["validation"] = {{"wrong_triangle", run.wrong_triangle},
                             {"wrong_t", run.wrong_t},
                             {"wrong_uv", run.wrong_uv},
                             {"outside_window", run.outside_window},
                             {"fragile", run.fragile},
                             {"unbounded", run.unbounded},
                             {"unlocated", run.unlocated}};
    if (run.cells_per_ray >= 0) {
      entry["cells_per_ray"] = run.cells_per_ray;
      entry["tests_per_ray"] = run.tests_per_ray;
    }
    runs.push_back(std::move(entry));
  }
  nlohmann::json out = {{"scene", r.scene},
                        {"triangles", r.triangles},
                        {"backend", r.backend},
                        {"structure", r.structure}};
  add_build_stats_json(out, parse_structure(r.structure), r.build, r.grid);
  out["runs"] = runs;
  return out;
}

nlohmann::json settings_json(const BenchSettings& s) {
  return {{"width", s.config.width},
          {"height", s.config.height},
          {"spp", s.config.spp},
          {"random_rays", s.config.count},
          {"seed", s.config.seed},
          {"kinds", s.kinds},
          {"views", s.views},
          {"views_file", s.views_file},
          {"rays_file", s.rays_file},
          {"repeat", s.repeat},
          {"build_repeat", s.build_repeat},
          {"validate", s.validate},
          {"hit_arrays", s.hit_arrays},
          {"validate_reference", s.exact ? "exact" : "double"}};
}

}  // namespace

nlohmann::json machine_json() {
  const auto machine = machine_info(environment_options().cpu_walk);
  return {{"cpu", machine.cpu_model},
          {"threads", machine.tbb_threads},
          {"cpu_walk", machine.cpu_walk},
          {"gpu", machine.gpu.empty() ? nlohmann::json() : nlohmann::json(machine.gpu)}};
}

void write_json_file(const nlohmann::json& json, const std::string& path) {
  write_file_whole(path, json.dump(2) + '\n');
}

void write_bench_json(const std::vector<BenchResult>& results, const std::string& scene_file,
                      const BenchSettings& settings, const std::string& path) {
  nlohmann::json out = result_json(results.front());
  out["scene_file"] = scene_file;
  out["settings"] = settings_json(settings);
  out["irgrid_version"] = version();
  out["machine"] = machine_json();
  if (results.size() > 1) {
    out["compare"] = nlohmann::json::array();
    for (const auto& r : results)
      out["compare"].push_back(result_json(r));
  }
  write_json_file(out, path);
}

}  // namespace irgrid::cli
