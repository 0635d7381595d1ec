// irgrid/accelerator.h: the coarse backend seam: build a structure over a mesh, trace batches.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "irgrid/build_config.h"
#include "irgrid/kernel/grid_traverse.h"
#include "irgrid/mesh.h"
#include "irgrid/ray.h"

/// The CUDA runtime's stream type is `CUstream_st*` (cudaStream_t); declared here so that this
/// header needs no CUDA headers.
struct CUstream_st;

namespace irgrid {

/// The acceleration structures. The grids are built from the same phases: the irregular grid
/// (Pérard-Gayot et al. 2017), the two-level grid (Kalojanov et al. 2011) and the uniform grid
/// are irgrid's own; brute force tests every triangle; embree and embree_packets are Embree 3's
/// BVH (one ray at a time, or packets of 8), when this build has Embree. cwbvh is the compressed
/// 8-wide BVH of Ylitie, Karras and Laine (HPG 2017), built with Embree's BVH builder (so only
/// in builds with Embree) and traversed by irgrid's own code on the CPU and the GPU, with the
/// grid's triangle test: the GPU baseline of the paper's comparison.
enum class Structure { irregular, two_level, uniform, brute, embree, embree_packets, cwbvh };

/// "irregular", "two-level", "uniform", "brute", "embree", "embree-packets", "cwbvh".
const char* to_string(Structure structure) noexcept;
/// The structure of that name (as to_string spells it). Throws Error{invalid_argument} naming
/// the value and the structures of this build.
Structure parse_structure(std::string_view name);
/// Whether `structure` is one of the grids (which report GridStats and count their work).
bool is_grid(Structure structure) noexcept;

/// Where a structure is built and traversed. `automatic` is CUDA when a usable GPU is visible,
/// else the CPU.
enum class Backend { cpu, cuda, automatic };

/// "cpu", "cuda", "auto".
const char* to_string(Backend backend) noexcept;
/// "cpu", "cuda" or "auto"; throws Error{invalid_argument} naming the value.
Backend parse_backend(std::string_view name);

/// How the CPU backend walks rays through a grid. The hits are the same whichever it is.
/// `automatic`: 16 AVX-512 or 8 AVX2 lanes where the CPU has them (walking coherent rays, such
/// as camera rays in image order, as packets on grids of up to 64 MiB), else one ray at a time for
/// coherent rays on a cache-sized grid and interleaved walks otherwise. The others force one
/// way, to compare them; a SIMD walk the CPU lacks makes make_accelerator throw.
enum class CpuWalk { automatic, avx512, avx2, single, interleaved };

/// "auto", "avx512", "avx2", "single", "interleaved".
const char* to_string(CpuWalk walk) noexcept;
/// The walk of that name (to_string's spelling, or "simd" for automatic); throws
/// Error{invalid_argument} naming the value.
CpuWalk parse_cpu_walk(std::string_view name);
/// The walk `walk` takes on this CPU for grids that fit the SIMD walk: "avx512", "avx2",
/// "single", "interleaved", or "scalar" (automatic on a CPU without AVX2).
const char* cpu_walk_in_use(CpuWalk walk);

/// The phases of a build, in the order they run: a grid's (Pérard-Gayot et al. 2017, §3-§5), then
/// the CWBVH's (Embree's build, the compression, and on CUDA the upload of the host-built
/// arrays).
enum class BuildPhase {
  top_grid,
  top_level_references,
  octree_levels,
  empty_space,  ///< irregular grids with BuildConfig::skip_empty only
  cells_and_references,
  merge,
  voxel_map,
  expansion,
  compress,      ///< with BuildConfig::compress only
  bvh_build,     ///< cwbvh: Embree's 8-wide SAH build with spatial splits (on the CPU)
  bvh_compress,  ///< cwbvh: conversion to the compressed 80-byte nodes (on the CPU)
  upload,        ///< cwbvh on CUDA: copying the host-built arrays to the device
};
inline constexpr std::size_t kBuildPhaseCount = 12;
/// "top grid", "top-level references", "octree levels", "empty space", "cells and references",
/// "merge", "voxel map", "expansion", "compress", "bvh build", "bvh compress", "upload".
const char* to_string(BuildPhase phase) noexcept;

/// Wall time of each grid build phase that ran, indexed by BuildPhase.
using PhaseTimes = std::array<std::optional<double>, kBuildPhaseCount>;

/// Bytes per grid build phase that ran, indexed by BuildPhase.
using PhaseBytes = std::array<std::optional<std::uint64_t>, kBuildPhaseCount>;

/// What a grid build made (zero for structures that are not grids).
struct GridStats {
  std::uint64_t top_level_references = 0;   ///< (top cell, triangle) pairs
  std::uint64_t cells = 0;                  ///< cells after merging
  std::uint64_t references = 0;             ///< triangle references of all cells
  std::uint64_t voxel_map_entries = 0;      ///< entries of the voxel map
  std::array<std::uint32_t, 3> top_dims{};  ///< top grid resolution
  std::uint32_t depth = 0;        ///< octree levels below the top grid (the virtual grid's shift)
  bool compressed_cells = false;  ///< 16-byte cells (BuildConfig::compress)
  double lambda2_used = 0;        ///< the λ2 the octrees used (effective_lambda2)
  /// Bytes of each array of the final grid; memory_bytes is their sum.
  std::uint64_t cells_bytes = 0, references_bytes = 0, voxel_map_bytes = 0, triangles_bytes = 0,
                empty_radii_bytes = 0;
  /// The most memory the build held at once beyond what it started with (host memory of the
  /// build's buffers on the CPU, the device memory pool's peak on CUDA).
  std::uint64_t peak_build_bytes = 0;
  /// The same peak within each build phase that ran: peak_build_bytes is their largest.
  PhaseBytes phase_peak_bytes{};
  /// Blocks of the build's buffers that this build took from the system (the CUDA driver, the
  /// host allocator) rather than from the memory pool that earlier builds of the same
  /// accelerator filled: 0 when a rebuild reused them all.
  std::uint64_t fresh_allocations = 0;
  /// The construction budget this build had (BuildConfig::memory_budget, resolved).
  std::uint64_t budget_bytes = 0;
  /// The budget made the grid coarser than its parameters ask (a coarser top grid, octrees
  /// cut short): it still traces correctly, more slowly. Callers may warn.
  bool budget_limited = false;
};

/// What a CWBVH build made (Structure::cwbvh).
struct BvhStats {
  std::uint64_t nodes = 0;       ///< 80-byte compressed 8-wide nodes
  std::uint64_t references = 0;  ///< triangle references of the leaves (spatial splits repeat some)
  std::uint32_t depth = 0;       ///< node levels
  /// Bytes of each array; BuildStats::memory_bytes is their sum.
  std::uint64_t nodes_bytes = 0, references_bytes = 0, triangles_bytes = 0;
};

/// Time spent in one parallel primitive of a CPU grid build (AcceleratorOptions::
/// profile_primitives), summed over its calls.
struct PrimitiveTime {
  std::string name;
  double ms = 0;
};

/// Figures a structure reports about its last build (or rebuild).
struct BuildStats {
  double build_ms = 0;  ///< wall time of the build, allocation included
  /// Wall time of each build phase that ran, indexed by BuildPhase; empty for the phases that
  /// did not run and for structures that report none (brute force, embree).
  PhaseTimes phase_ms{};
  std::uint64_t memory_bytes = 0;  ///< bytes of the final structure (its triangles included)
  std::optional<GridStats> grid;   ///< grids only
  /// With AcceleratorOptions::profile_primitives on the CPU: each primitive, longest first.
  std::vector<PrimitiveTime> primitives;
  std::optional<BvhStats> bvh;  ///< cwbvh only
};

/// Work done for each ray (heat maps, statistics).
struct RayWork {
  std::uint32_t cells = 0;      ///< cells (or nodes) visited
  std::uint32_t triangles = 0;  ///< ray/triangle tests
};

/// Called by a grid build each time one of its phases ends (progress output). Runs on the
/// thread that called make_accelerator or rebuild.
using PhaseObserver = std::function<void(BuildPhase phase)>;

/// Options for make_accelerator; fields are added at the end so that existing code keeps
/// compiling.
struct AcceleratorOptions {
  Backend backend = Backend::cpu;         ///< where to build and trace
  BuildConfig grid;                       ///< parameters of the grid structures
  CpuWalk cpu_walk = CpuWalk::automatic;  ///< grids on the CPU backend
  /// Embree's device configuration string (rtcNewDevice), e.g. "isa=avx2"; embree structures.
  std::string embree_config;
  /// Time every parallel primitive of a CPU grid build into BuildStats::primitives.
  bool profile_primitives = false;
  PhaseObserver on_phase;  ///< optional: told when each build phase ends
};

/// A built acceleration structure over one mesh on one backend. Tracing is one call per batch
/// of rays (no virtual call per ray). trace, trace_counted and trace_device may be called from
/// many threads at once on one accelerator; rebuild may not run while any of them does.
class Accelerator {
 public:
  virtual ~Accelerator() = default;
  virtual Structure structure() const = 0;
  /// Backend::cpu or Backend::cuda (never automatic).
  virtual Backend backend() const = 0;

  /// Traces rays[i] into hits[i] for every i (host memory on every backend); rays.size() must
  /// equal hits.size(). Returns when the hits are written.
  virtual void trace(std::span<const Ray> rays, std::span<Hit> hits, Query query) const = 0;

  /// Traces ray i of `rays` into element i of each array of `hits` that is set, for every i: the
  /// caller's own layouts, read and written in place (host memory on every backend). The hits
  /// are those of trace for the same rays, and `hits.normal` gets the unit geometric normal of
  /// the triangle hit. The grids on the CPU walk the arrays themselves; the other structures
  /// and backends convert them a batch at a time around trace. Throws Error{invalid_argument}
  /// for a null origins or directions with rays to trace, or a ray stride of 2^26 floats or more.
  virtual void trace(const RayArrays& rays, const HitArrays& hits, Query query) const;

  /// Whether trace_counted works (the grids); brute force and Embree do not count.
  virtual bool counts_work() const { return false; }
  /// Like trace, and also counts the work per ray into work[i]. Throws Error{invalid_argument}
  /// for structures that cannot count (counts_work() false).
  virtual void trace_counted(std::span<const Ray> rays, std::span<Hit> hits,
                             std::span<RayWork> work, Query query) const;

  /// CUDA backend: traces `count` rays at d_rays into d_hits, both in device memory, on the
  /// caller's `stream` (nullptr: the default stream). Asynchronous: no host copies and no host
  /// synchronisation; the hits are ready when the stream reaches that point. The accelerator
  /// must outlive the work queued. Throws Error{invalid_argument} on other backends. A CUDA
  /// error that the caller's own earlier calls left pending (cudaGetLastError) is thrown, and
  /// cleared, before anything is queued, its message naming it as an earlier call's.
  virtual void trace_device(const Ray* d_rays, Hit* d_hits, std::size_t count, Query query,
                            CUstream_st* stream = nullptr) const;

  /// The grid's arrays for tracing single rays from one's own code with irgrid/kernel.h: host
  /// pointers on the CPU backend, device pointers on CUDA. Valid until the accelerator is
  /// rebuilt or destroyed. Throws Error{invalid_argument} for structures that are not grids.
  virtual GridView grid_view() const;

  /// Builds the structure anew over `mesh`, which must have as many triangles as the mesh it
  /// was built over (new vertex positions of the same topology: an animation frame), with the
  /// options it was made with. Reuses the structure's memory: grids take their buffers from the
  /// pool that earlier rebuilds filled (device memory on CUDA, host memory on the CPU), so
  /// rebuilding a frame that needs no larger arrays allocates nothing (docs/api.md). Throws
  /// Error{invalid_argument} for another triangle count, as check_mesh for a bad mesh; after an
  /// exception the accelerator traces every ray as a miss until a rebuild succeeds.
  virtual void rebuild(const TriangleMesh& mesh) = 0;

  /// Figures of the last build or rebuild.
  virtual const BuildStats& build_stats() const = 0;

 protected:
  /// The mesh's triangles by index in host memory, for the normals that trace(RayArrays,
  /// HitArrays) writes when the structure converts the arrays around trace. Valid until the
  /// next rebuild; may be made on first use (a copy from device memory on CUDA).
  virtual std::span<const TriangleVertices> host_triangles() const = 0;
};

/// Counts, for every ray, the distinct distances t in [tmin, tmax] at which it meets a triangle
/// of `accelerator`'s mesh, into counts[i]: for a ray from outside a closed mesh, even means
/// outside. Watertight: a ray through a shared edge or vertex counts one crossing there, not
/// zero or two: hits closer than 2^-20 of their distance to the last one counted (and hits on
/// the last triangle again) count once. Traces closest hits repeatedly, each pass starting just
/// past the last hit, so it costs about one trace per crossing.
/// rays.size() must equal counts.size().
void count_crossings(const Accelerator& accelerator, std::span<const Ray> rays,
                     std::span<std::uint32_t> counts);

/// Builds `structure` over `mesh` on options.backend (the mesh is copied: see TriangleMesh).
/// Throws Error{invalid_argument} for a structure not compiled in, a bad mesh (check_mesh) or
/// bad options, Error{no_device} when the CUDA backend is asked for without a usable GPU,
/// Error{out_of_memory} or Error{limit_exceeded} when the structure would not fit.
std::unique_ptr<Accelerator> make_accelerator(const TriangleMesh& mesh, Structure structure,
                                              const AcceleratorOptions& options = {});

/// The backend that `backend` runs on: cpu or cuda. Throws Error{no_device} (with the reason:
/// no driver, driver too old, no GPU) for cuda without a usable GPU.
Backend resolve_backend(Backend backend);

/// Structures compiled into this build, fastest first.
std::vector<Structure> available_structures();

/// The fastest structure compiled in (the irregular grid).
inline constexpr Structure kDefaultStructure = Structure::irregular;

}  // namespace irgrid
