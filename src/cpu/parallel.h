// cpu/parallel.h: the CPU code's one way into oneTBB's parallel loops, with the hand-offs that
// ThreadSanitizer cannot see made visible to it.
//
// Debian's oneTBB is not built with ThreadSanitizer, so the synchronisation between the thread
// that starts a loop and the workers that run its tasks (and back, when the loop returns)
// happens where TSan cannot see it: every result a worker wrote and the caller then read
// reported as a race. Under TSan these wrappers tell it of both edges (__tsan_release before the
// loop and at the end of each task, __tsan_acquire at the start of each task and after the
// loop); otherwise they are the plain TBB calls.
#pragma once

#include <oneapi/tbb/blocked_range.h>
#include <oneapi/tbb/parallel_for.h>
#include <oneapi/tbb/parallel_scan.h>

#if defined(__SANITIZE_THREAD__)
#define IRGRID_TSAN 1
#elif defined(__has_feature)
#if __has_feature(thread_sanitizer)
#define IRGRID_TSAN 1
#endif
#endif

#if defined(IRGRID_TSAN)
extern "C" void __tsan_acquire(void* address);
extern "C" void __tsan_release(void* address);
#endif

namespace irgrid {

#if defined(IRGRID_TSAN)
/// The two edges of one parallel call, as TSan synchronisation objects: what the caller wrote
/// before construction is visible to every task that starts; what every task wrote before it
/// ended is visible to the caller after all_tasks_ended (or destruction).
class TsanHandOff {
 public:
  TsanHandOff() { __tsan_release(&start_); }
  ~TsanHandOff() { all_tasks_ended(); }
  void task_starts() { __tsan_acquire(&start_); }
  void task_ends() { __tsan_release(&finish_); }
  void all_tasks_ended() { __tsan_acquire(&finish_); }

 private:
  char start_ = 0, finish_ = 0;
};
#else
struct TsanHandOff {
  void task_starts() {}
  void task_ends() {}
  void all_tasks_ended() {}
};
#endif

/// One task of a parallel call that an uninstrumented library makes (Embree's builder calls
/// back on its threads): starts on construction, ends on destruction; null: nothing.
class TsanTask {
 public:
  explicit TsanTask(TsanHandOff* hand_off) : hand_off_(hand_off) {
    if (hand_off_) hand_off_->task_starts();
  }
  ~TsanTask() {
    if (hand_off_) hand_off_->task_ends();
  }
  TsanTask(const TsanTask&) = delete;
  TsanTask& operator=(const TsanTask&) = delete;

 private:
  TsanHandOff* hand_off_;
};

/// tbb::parallel_for(range, body).
template <typename Range, typename Body>
void parallel_for(const Range& range, const Body& body) {
  TsanHandOff hand_off;
  tbb::parallel_for(range, [&](const Range& part) {
    hand_off.task_starts();
    body(part);
    hand_off.task_ends();
  });
}

/// tbb::parallel_scan(range, identity, scan, combine).
template <typename Range, typename T, typename Scan, typename Combine>
T parallel_scan(const Range& range, const T& identity, const Scan& scan, const Combine& combine) {
  TsanHandOff hand_off;
  return tbb::parallel_scan(
      range, identity,
      [&](const Range& part, T running, bool is_final) {
        hand_off.task_starts();
        T result = scan(part, running, is_final);
        hand_off.task_ends();
        return result;
      },
      [&](T left, T right) {
        hand_off.task_starts();
        T result = combine(left, right);
        hand_off.task_ends();
        return result;
      });
}

}  // namespace irgrid
