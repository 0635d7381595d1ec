// tools/irgrid/common.h: what the subcommands share: loading, building, tracing with progress.
#pragma once

#include <array>
#include <chrono>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>

#include "irgrid/accelerator.h"
#include "irgrid/io/scene.h"
#include "process_memory.h"

namespace irgrid::cli {

/// Loads a scene and prints a one-line summary plus its warnings on stderr.
Scene load_scene_reporting(const std::string& spec);

/// Options shared by every command that builds a structure.
struct StructureOptions {
  std::string structure;  ///< empty: kDefaultStructure
  std::string backend = "cpu";
  BuildConfig grid;
  /// The structure named (kDefaultStructure when none is).
  Structure parsed_structure() const {
    return structure.empty() ? kDefaultStructure : parse_structure(structure);
  }
};

/// The library options the environment selects for every command: IRGRID_CPU_WALK
/// (simd|avx512|avx2|single|interleaved), IRGRID_EMBREE_CONFIG (Embree's device configuration)
/// and IRGRID_PRIMITIVE_PROFILE (time each primitive of a CPU grid build). Read once; an
/// unknown walk, or one this CPU lacks, is ignored with a warning on stderr.
const AcceleratorOptions& environment_options();

/// The options for building on `backend` ("cpu", "cuda" or "auto") with `grid`, the rest from
/// the environment (environment_options).
AcceleratorOptions accelerator_options(const std::string& backend, const BuildConfig& grid);

/// make_accelerator, then (with IRGRID_PRIMITIVE_PROFILE) the build's primitives on stderr.
std::unique_ptr<Accelerator> make_structure(const Scene& scene, Structure structure,
                                            const AcceleratorOptions& options);

/// Adds --structure, --backend and the grid parameters (--lambda1, ...) to a command.
void add_structure_options(CLI::App* command, StructureOptions& options);

/// Builds a structure, printing what was built and how long it took on stderr; with `memory`,
/// records the process's memory as each phase ends.
std::unique_ptr<Accelerator> build_reporting(const Scene& scene, const StructureOptions& options,
                                             PhaseMemoryRecorder* memory = nullptr);

/// A validator for whole-number options: digits only (no sign, so -1 cannot wrap to 2^64 - 1),
/// at least `least` (0 or 1). Its message names the rule, not the type's range.
CLI::Validator whole_number(std::uint64_t least);

/// Warns on stderr when the grid's construction budget made it coarser than asked.
void warn_if_budget_limited(const Accelerator& accelerator);

/// Traces in chunks so a long trace shows progress on a terminal.
void trace_with_progress(const Accelerator& accelerator, std::span<const Ray> rays,
                         std::span<Hit> hits, Query query, const std::string& label);

/// Parses "x,y,z"; throws Error{invalid_argument} naming the option and text.
std::array<float, 3> parse_vec3(const std::string& text, const std::string& option);

/// Splits "a,b,c" into its non-empty parts.
std::vector<std::string> split_list(const std::string& text);

/// Picks view `index` of the scene's views; throws Error{invalid_argument} if out of range.
Camera pick_view(const Scene& scene, int index, const std::string& views_file);

double milliseconds_since(std::chrono::steady_clock::time_point start);

/// Throws Error{io} naming `path` unless it can be written (a missing file is created to try,
/// then removed): called before long work whose results go there, so a bad path is not found
/// only at the end.
void check_writable(const std::string& path);

}  // namespace irgrid::cli
