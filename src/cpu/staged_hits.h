// cpu/staged_hits.h: the SIMD walk's hits, staged as records and written into the caller's
// arrays (HitArrays) in ray order.
//
// The walk's rays end out of order, and writing each hit's four or five fields where it ends
// took 8-10 ms per million rays more than one 16-byte Hit store on Sponza (Intel Xeon VM): the
// scattered stores to lines not yet in the cache hold the store buffer. Staged, each hit is
// one store into a ring that stays in the L1 / L2, and the fields are written a few thousand
// rays at a time, in order, into lines the hardware prefetches.
#pragma once

#include <bit>
#include <cstddef>
#include <cstdint>
#include <memory>

#include "cpu/ray_fields.h"
#include "irgrid/ray.h"

namespace irgrid {

/// Hits written as Hit records where each ray ends: StagedHits's interface, for the walk's
/// copy that writes records.
struct RecordHits {
  Hit* records;
  void make_room(std::size_t, std::size_t) {}
  void write(std::size_t ray, std::uint32_t prim, float t, float u, float v) {
    records[ray] = hit_record(prim, t, u, v);
  }
};

/// Hits of rays [0, count) that begin in order and end in any order, into `out`. Hit records
/// are written at once; fields go through a ring of up to kSlots records. A ray still walking
/// when its slot is needed (a long walk among short ones) writes its fields itself when it ends.
class StagedHits {
 public:
  static constexpr std::size_t kSlots = 4096;

  StagedHits(const HitFields& out, std::size_t count)
      : out_(out),
        slots_(out.records ? 0 : std::bit_ceil(count < kSlots ? count : kSlots)),
        ring_(slots_ ? new Staged[slots_] : nullptr),
        done_(slots_ ? new bool[slots_]() : nullptr) {}

  /// Call before rays [first, first + n) begin: makes room for them, writing the hits of the
  /// oldest rays out.
  void make_room(std::size_t first, std::size_t n) {
    if (slots_ == 0 || first + n <= written_ + slots_) return;
    const std::size_t needed = first + n - slots_;
    while (written_ < needed) {
      const std::size_t slot = written_ & (slots_ - 1);
      if (done_[slot]) out_.write(written_, ring_[slot].hit, ring_[slot].normal);
      done_[slot] = false;  // else the ray is still walking: it writes its own fields
      ++written_;
    }
  }

  /// The hit of `ray`, which has begun.
  void write(std::size_t ray, std::uint32_t prim, float t, float u, float v) {
    if (slots_ == 0 || ray < written_) {
      out_.write(ray, prim, t, u, v);
      return;
    }
    const std::size_t slot = ray & (slots_ - 1);
    ring_[slot].hit = hit_record(prim, t, u, v);
    // Now, while the walk has the triangle in the cache (it just tested it).
    if (out_.normal) ring_[slot].normal = out_.normal_of(prim);
    done_[slot] = true;
  }

  /// Writes out every hit still staged; call once all `end` rays have ended.
  void finish(std::size_t end) { make_room(end + slots_, 0); }

 private:
  struct Staged {
    Hit hit;
    Vec3<float> normal;
  };
  HitFields out_;
  std::size_t slots_;  // 0: records, written at once
  std::unique_ptr<Staged[]> ring_;
  std::unique_ptr<bool[]> done_;
  std::size_t written_ = 0;  // rays before this one are written out
};

}  // namespace irgrid
