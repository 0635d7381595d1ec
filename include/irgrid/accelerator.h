// irgrid/accelerator.h: the coarse backend seam: build a structure over a scene, trace batches.
#pragma once

#include <functional>
#include <iterator>
#include <map>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "irgrid/build_config.h"
#include "irgrid/ray.h"
#include "irgrid/scene.h"

namespace irgrid {

/// Figures a structure reports about its build.
struct BuildInfo {
  double build_ms = 0;                      ///< wall time of the build, allocation included
  std::map<std::string, double> phases_ms;  ///< per-phase wall times (keys sorted by name)
  std::uint64_t memory_bytes = 0;           ///< bytes of the final structure (triangles included)
  /// Structure-specific counts (cells, references, ...).
  std::map<std::string, std::uint64_t> counts;
  /// Bytes of each array of the final structure.
  std::map<std::string, std::uint64_t> bytes;
};

/// Work done for each ray (heat maps, statistics).
struct RayWork {
  std::uint32_t cells = 0;      ///< cells (or nodes) visited
  std::uint32_t triangles = 0;  ///< ray/triangle tests
};

/// A built acceleration structure over one scene on one backend. Tracing is one call per batch
/// of rays (no virtual call per ray); a structure may be traced from several threads at once.
/// The scene must outlive the structure.
class Accelerator {
 public:
  virtual ~Accelerator() = default;
  /// Structure name as accepted by make_accelerator ("brute", "embree", ...).
  virtual std::string structure() const = 0;
  /// Backend name: "cpu" or "cuda".
  virtual std::string backend() const = 0;
  /// Traces rays[i] into hits[i] for every i; rays.size() must equal hits.size().
  virtual void trace(std::span<const Ray> rays, std::span<Hit> hits, Query query) const = 0;
  /// Whether trace_counted works (the grids); brute force and Embree do not count.
  virtual bool counts_work() const { return false; }
  /// Like trace, and also counts the work per ray into work[i]. Throws Error{invalid_argument}
  /// for structures that cannot count (counts_work() false).
  virtual void trace_counted(std::span<const Ray> rays, std::span<Hit> hits,
                             std::span<RayWork> work, Query query) const;
  virtual const BuildInfo& build_info() const = 0;
};

/// Called by a build each time one of its phases ends, with the phase's name (for progress
/// output; grids only). Runs on the calling thread.
using PhaseObserver = std::function<void(const char* phase)>;

/// The phases a grid build reports (BuildInfo::phases_ms), in the order they run: "empty space"
/// only for irregular grids that skip empty space, "compress" only with compressed cells.
inline constexpr const char* kGridBuildPhaseNames[] = {"top grid",
                                                       "top-level references",
                                                       "octree levels",
                                                       "empty space",
                                                       "cells and references",
                                                       "merge",
                                                       "voxel map",
                                                       "expansion",
                                                       "compress"};

/// How many phases a grid build reports at most.
inline constexpr int kGridBuildPhases = int(std::size(kGridBuildPhaseNames));

/// Options for make_accelerator; more fields arrive with more structures.
struct AcceleratorOptions {
  std::string backend = "cpu";  ///< "cpu", "cuda" or "auto" (CUDA when a GPU is visible)
  BuildConfig grid;             ///< parameters of the grid structures
  PhaseObserver on_phase;       ///< optional: told when each build phase ends
};

/// Builds `structure` over `scene`. Throws Error{invalid_argument} naming the structure when it is
/// unknown or not compiled in, Error{no_device} when the backend is unavailable.
std::unique_ptr<Accelerator> make_accelerator(const Scene& scene, const std::string& structure,
                                              const AcceleratorOptions& options = {});

/// The backend that `backend` ("cpu", "cuda" or "auto") runs on: "cpu" or "cuda". Throws
/// Error{no_device} (with the reason: no driver, driver too old, no GPU) for "cuda" without a
/// usable GPU, Error{invalid_argument} for other names.
std::string resolve_backend(const std::string& backend);

/// Structures compiled into this build, fastest first.
std::vector<std::string> available_structures();

/// The fastest structure compiled in: what rendering and secondary-ray generation use.
std::string default_structure();

/// Brute force over all triangles in double precision, watertight: the trusted reference that
/// tests and `bench --validate` compare against. Slow; meant for subsets of rays.
void trace_reference_double(const Scene& scene, std::span<const Ray> rays, std::span<Hit> hits,
                            Query query);

}  // namespace irgrid
