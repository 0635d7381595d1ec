// The structure factory: picks a structure and backend by name.
#include <fmt/format.h>
#include <fmt/ranges.h>

#include <map>

#include "cpu/structures.h"
#include "irgrid/error.h"
#include "irgrid/system.h"

namespace irgrid {

void check_trace_spans(std::span<const Ray> rays, std::span<Hit> hits) {
  if (rays.size() != hits.size())
    throw Error(ErrorCode::invalid_argument,
                fmt::format("trace: {} rays but room for {} hits", rays.size(), hits.size()));
}

void Accelerator::trace_counted(std::span<const Ray>, std::span<Hit>, std::span<RayWork>,
                                Query) const {
  throw Error(ErrorCode::invalid_argument,
              fmt::format("structure '{}' does not count its work per ray", structure()));
}

std::vector<std::string> available_structures() {
  std::vector<std::string> names;
  names.push_back("irregular");
#if IRGRID_HAS_EMBREE
  names.push_back("embree");
  names.push_back("embree-packets");
#endif
  names.push_back("two-level");
  names.push_back("uniform");
  names.push_back("brute");
  return names;
}

std::string default_structure() {
  return available_structures().front();
}

std::string resolve_backend(const std::string& backend) {
  if (backend == "cpu") return backend;
  if (backend != "cuda" && backend != "auto")
    throw Error(ErrorCode::invalid_argument,
                fmt::format("unknown backend '{}' (expected cpu, cuda or auto)", backend));
  const auto cuda = cuda_status();
  if (!cuda.gpus.empty()) return "cuda";
  if (backend == "auto") return "cpu";
  throw Error(ErrorCode::no_device, fmt::format("backend cuda: {}", cuda.status));
}

std::unique_ptr<Accelerator> make_accelerator(const Scene& scene, const std::string& structure,
                                              const AcceleratorOptions& options) {
  const auto backend = resolve_backend(options.backend);
  check_scene(scene);
  if (structure == "brute") {
#if IRGRID_HAS_CUDA
    if (backend == "cuda") return make_brute_force_cuda(scene);
#endif
    return make_brute_force_cpu(scene);
  }
  const std::map<std::string, BuildConfig::Shape> grids = {
      {"irregular", BuildConfig::Shape::irregular},
      {"two-level", BuildConfig::Shape::two_level},
      {"uniform", BuildConfig::Shape::uniform}};
  if (const auto grid = grids.find(structure); grid != grids.end()) {
    BuildConfig config = options.grid;
    config.shape = grid->second;
#if IRGRID_HAS_CUDA
    if (backend == "cuda") return make_grid_cuda(scene, config, options.on_phase);
#endif
    return make_grid_cpu(scene, config, options.on_phase);
  }
#if IRGRID_HAS_EMBREE
  if (structure == "embree" || structure == "embree-packets") {
    if (backend == "cuda" && options.backend == "cuda")
      throw Error(ErrorCode::invalid_argument,
                  fmt::format("structure '{}' runs on the cpu backend only", structure));
    return make_embree_cpu(scene, structure == "embree-packets");
  }
#endif
  throw Error(ErrorCode::invalid_argument,
              fmt::format("unknown structure '{}' (this build has: {})", structure,
                          fmt::join(available_structures(), ", ")));
}

}  // namespace irgrid
