// fuzz/fuzz_file.h: the readers take paths, so each input is written to a file of this process.
#pragma once

#include <unistd.h>

#include <cstdint>
#include <cstdio>
#include <string>

namespace irgrid::fuzz {

/// Writes `data` to a file named after this process and `suffix` (which picks the reader),
/// returning its path; the file is reused by every input.
inline std::string write_input(const std::uint8_t* data, std::size_t size, const char* suffix) {
  const std::string path = "/tmp/irgrid-fuzz-" + std::to_string(::getpid()) + suffix;
  std::FILE* file = std::fopen(path.c_str(), "wb");
  if (file == nullptr) __builtin_trap();
  if (size > 0 && std::fwrite(data, 1, size, file) != size) __builtin_trap();
  std::fclose(file);
  return path;
}

}  // namespace irgrid::fuzz
