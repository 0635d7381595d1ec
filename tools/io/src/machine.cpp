// The machine description (CPU model, threads, walk) for `irgrid info` and benchmark JSON.
#include <algorithm>
#include <fstream>
#include <string>
#include <thread>

#include <tbb/global_control.h>
#include <tbb/info.h>
#include <tbb/task_arena.h>

#include "irgrid/io/machine.h"
#include "irgrid/system.h"

namespace irgrid {

namespace {

std::string cpu_model_name() {
  std::ifstream cpuinfo("/proc/cpuinfo");
  std::string line;
  while (std::getline(cpuinfo, line)) {
    if (line.rfind("model name", 0) != 0) continue;
    const auto colon = line.find(':');
    if (colon == std::string::npos) break;
    const auto start = line.find_first_not_of(" \t", colon + 1);
    return start == std::string::npos ? std::string() : line.substr(start);
  }
  return "unknown CPU";
}

std::string first_line(const char* path) {
  std::ifstream file(path);
  std::string line;
  std::getline(file, line);
  return line;
}

}  // namespace

MachineInfo machine_info(CpuWalk walk) {
  MachineInfo info;
  info.cpu_model = cpu_model_name();
  info.hardware_threads = int(std::thread::hardware_concurrency());
  // The arena's size ignores a global_control cap (irgrid --threads): report the smaller one.
  info.tbb_threads = int(std::min<std::size_t>(
      std::size_t(tbb::this_task_arena::max_concurrency()),
      tbb::global_control::active_value(tbb::global_control::max_allowed_parallelism)));
  const auto cuda = cuda_status();
  if (!cuda.gpus.empty()) info.gpu = cuda.gpus.front().name;
  info.cpu_walk = cpu_walk_in_use(walk);
  info.gather_data_sampling =
      first_line("/sys/devices/system/cpu/vulnerabilities/gather_data_sampling");
  return info;
}

}  // namespace irgrid
