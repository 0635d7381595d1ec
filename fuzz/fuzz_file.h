// fuzz/fuzz_file.h: the readers take paths, so each input is written to a file of this process.
#pragma once

#include <unistd.h>

#include <cstdint>
#include <cstdio>
#include <set>
#include <string>

#include "irgrid/error.h"
#include "irgrid/io/scene.h"

namespace irgrid::fuzz {

/// The folder of the input files: /dev/shm where it is a writable directory (memory), else /tmp.
/// On a disk-backed /tmp (ext4 mounted with discard, as on the VMs these ran on) rewriting the
/// file for every input kept the fuzzers in the kernel half of their time.
inline const std::string& input_folder() {
  static const std::string folder = ::access("/dev/shm", W_OK | X_OK) == 0 ? "/dev/shm" : "/tmp";
  return folder;
}

/// The input files this process wrote, removed when it exits normally (libFuzzer ends a timed
/// run with exit()), so that runs do not leave one file per target in /dev/shm.
class InputFiles {
 public:
  InputFiles() = default;
  InputFiles(const InputFiles&) = delete;
  InputFiles& operator=(const InputFiles&) = delete;
  ~InputFiles() {
    for (const std::string& path : paths_)
      std::remove(path.c_str());
  }
  void add(const std::string& path) { paths_.insert(path); }

 private:
  std::set<std::string> paths_;
};

/// Writes `data` to a file named after this process and `suffix` (which picks the reader),
/// returning its path; the file is reused by every input and removed at exit.
inline std::string write_input(const std::uint8_t* data, std::size_t size, const char* suffix) {
  static InputFiles written;
  const std::string path = input_folder() + "/irgrid-fuzz-" + std::to_string(::getpid()) + suffix;
  written.add(path);
  std::FILE* file = std::fopen(path.c_str(), "wb");
  if (file == nullptr) __builtin_trap();
  if (size > 0 && std::fwrite(data, 1, size, file) != size) __builtin_trap();
  std::fclose(file);
  return path;
}

/// One input to a scene loader (the suffix picks OBJ or PLY): it loads or throws irgrid::Error,
/// and every triangle it keeps names a vertex it read; anything else traps.
inline int fuzz_scene_loader(const std::uint8_t* data, std::size_t size, const char* suffix) {
  const std::string path = write_input(data, size, suffix);
  try {
    const Scene scene = load_scene(path);
    for (const auto& t : scene.triangles)
      for (std::uint32_t v : t)
        if (v >= scene.vertices.size()) __builtin_trap();
  } catch (const Error&) {
  }
  return 0;
}

}  // namespace irgrid::fuzz
