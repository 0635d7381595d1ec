// Fuzzes the views.json reader: any bytes give cameras or throw irgrid::Error.
#include <cstdint>

#include "fuzz_file.h"
#include "irgrid/error.h"
#include "irgrid/io/camera.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string path = irgrid::fuzz::write_input(data, size, ".json");
  try {
    irgrid::read_views(path, "x");
  } catch (const irgrid::Error&) {
  }
  return 0;
}
