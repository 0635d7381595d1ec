// tools/irgrid/progress.h: progress of long work on a terminal (silent in CI logs and pipes).
#pragma once

#include <chrono>
#include <cstdint>
#include <string>

namespace irgrid::cli {

/// Shows "label: 42% (elapsed)" on stderr when stderr is a terminal and CI is unset, updated at
/// most ten times a second, and clears the line when done or destroyed.
class Progress {
 public:
  Progress(std::string label, std::uint64_t total);
  ~Progress();
  Progress(const Progress&) = delete;
  Progress& operator=(const Progress&) = delete;

  void advance(std::uint64_t amount);
  void done();

 private:
  std::string label_;
  std::uint64_t total_, current_ = 0;
  bool enabled_;
  bool shown_ = false;
  std::chrono::steady_clock::time_point start_, last_draw_;
};

}  // namespace irgrid::cli
