// Fuzzes the gzip and xz readers: any bytes decompress (within the bomb limit) or throw
// irgrid::Error. The first byte picks the suffix.
#include <cstdint>

#include "fuzz_file.h"
#include "irgrid/error.h"
#include "irgrid/io/scene.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size == 0) return 0;
  const std::string path =
      irgrid::fuzz::write_input(data + 1, size - 1, data[0] & 1 ? ".obj.xz" : ".obj.gz");
  try {
    irgrid::load_scene(path);
  } catch (const irgrid::Error&) {
  }
  return 0;
}
