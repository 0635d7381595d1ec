// tools/irgrid/process_memory.h: the process's resident memory, sampled as each build phase
// ends, so that memory outside the library's own accounting (the scene as loaded, the
// allocator's free lists) shows up beside GridStats::peak_build_bytes.
#pragma once

#include <cstdint>
#include <vector>

#include "irgrid/accelerator.h"

namespace irgrid::cli {

/// Resident bytes now and the highest since the last reset_peak_memory() (Linux VmRSS and
/// VmHWM); zeros where /proc/self/status cannot be read.
struct ProcessMemory {
  std::uint64_t resident_bytes = 0;
  std::uint64_t peak_bytes = 0;
};
ProcessMemory process_memory();

/// Sets the peak back to the resident size (Linux /proc/self/clear_refs); false where it
/// cannot, and the peak then stays the process's.
bool reset_peak_memory();

/// The process's memory at the end of one build phase: its resident bytes then, and the peak
/// during the phase.
struct PhaseMemory {
  BuildPhase phase;
  ProcessMemory memory;
};

/// Records PhaseMemory as phases end: call `phase_ended` from AcceleratorOptions::on_phase.
class PhaseMemoryRecorder {
 public:
  PhaseMemoryRecorder() { peaks_per_phase_ = reset_peak_memory(); }
  void phase_ended(BuildPhase phase) {
    phases_.push_back({phase, process_memory()});
    if (peaks_per_phase_) reset_peak_memory();
  }
  const std::vector<PhaseMemory>& phases() const { return phases_; }
  /// Whether each peak is that of its phase alone (else the process's peak so far).
  bool peaks_per_phase() const { return peaks_per_phase_; }
  /// The process's peak resident size since the recorder was made: the highest phase peak, or
  /// the peak since the last phase ended (what followed it: the build's end, the statistics).
  /// The kernel's own high-water mark restarts with every phase, so the maximum resident size
  /// that getrusage or /usr/bin/time report for this process is only that of its last phase.
  std::uint64_t whole_peak_bytes() const;

 private:
  std::vector<PhaseMemory> phases_;
  bool peaks_per_phase_ = false;
};

}  // namespace irgrid::cli
