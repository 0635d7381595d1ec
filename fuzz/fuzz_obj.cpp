// Fuzzes the OBJ loader: any bytes load or throw irgrid::Error, nothing else.
#include <cstdint>

#include "fuzz_file.h"
#include "irgrid/error.h"
#include "irgrid/io/scene.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string path = irgrid::fuzz::write_input(data, size, ".obj");
  try {
    const irgrid::Scene scene = irgrid::load_scene(path);
    for (const auto& t : scene.triangles)  // every kept triangle names a vertex
      for (std::uint32_t v : t)
        if (v >= scene.vertices.size()) __builtin_trap();
  } catch (const irgrid::Error&) {
  }
  return 0;
}
