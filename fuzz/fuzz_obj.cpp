// Fuzzes the OBJ loader: any bytes load or throw irgrid::Error, nothing else.
#include <cstdint>

#include "fuzz_file.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  return irgrid::fuzz::fuzz_scene_loader(data, size, ".obj");
}
