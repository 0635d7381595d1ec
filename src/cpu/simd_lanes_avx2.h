// cpu/simd_lanes_avx2.h: the lane operations of the SIMD walk (cpu/simd_walk_lanes.h) on the
// 8 lanes of AVX2 registers. A lane mask is a register with all bits set in its lanes.
//
// Include only where AVX2 code is compiled (cpu/simd_walk_avx2.cpp, after its target pragma).
#pragma once

#include <immintrin.h>

#include <cstdint>

namespace irgrid::simd {

/// The operations the SIMD walk needs, for 8 lanes of AVX2. Minimum and maximum return their
/// second operand when either is not a number, as min_fast(a, b) = a < b ? a : b does.
struct Avx2Lanes {
  static constexpr int kLanes = 8;
  using F = __m256;   ///< 8 floats
  using I = __m256i;  ///< 8 32-bit integers
  using M = __m256i;  ///< a lane mask: all bits set in the lanes it holds

  static F load(const float* p) { return _mm256_load_ps(p); }
  static I load(const std::int32_t* p) { return _mm256_load_si256(reinterpret_cast<const I*>(p)); }
  static void store(float* p, F v) { _mm256_store_ps(p, v); }
  static void store(std::int32_t* p, I v) { _mm256_store_si256(reinterpret_cast<I*>(p), v); }
  static void store_unaligned(std::int32_t* p, I v) {
    _mm256_storeu_si256(reinterpret_cast<I*>(p), v);
  }
  /// p[k] in the lanes of `valid`, 0 elsewhere; nothing is read outside `valid`.
  static I load_lanes(const std::uint32_t* p, M valid) {
    return _mm256_maskload_epi32(reinterpret_cast<const int*>(p), valid);
  }

  static F splat(float x) { return _mm256_set1_ps(x); }
  static I splat(std::int32_t x) { return _mm256_set1_epi32(x); }
  static I lane_index() { return _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7); }

  static F add(F a, F b) { return _mm256_add_ps(a, b); }
  static F sub(F a, F b) { return _mm256_sub_ps(a, b); }
  static F mul(F a, F b) { return _mm256_mul_ps(a, b); }
  static F div(F a, F b) { return _mm256_div_ps(a, b); }
  static F min(F a, F b) { return _mm256_min_ps(a, b); }
  static F max(F a, F b) { return _mm256_max_ps(a, b); }
  static F abs(F a) { return _mm256_andnot_ps(_mm256_set1_ps(-0.f), a); }
  static I add(I a, I b) { return _mm256_add_epi32(a, b); }
  static I sub(I a, I b) { return _mm256_sub_epi32(a, b); }
  static I mul(I a, I b) { return _mm256_mullo_epi32(a, b); }
  static I bit_and(I a, I b) { return _mm256_and_si256(a, b); }
  /// ~a & b
  static I bit_and_not(I a, I b) { return _mm256_andnot_si256(a, b); }
  static I bit_or(I a, I b) { return _mm256_or_si256(a, b); }
  template <int kBits>
  static I shift_right_logical(I a) {
    return _mm256_srli_epi32(a, kBits);
  }
  template <int kBits>
  static I shift_left(I a) {
    return _mm256_slli_epi32(a, kBits);
  }
  static I shift_right(I a, int bits) { return _mm256_sra_epi32(a, _mm_cvtsi32_si128(bits)); }
  static I shift_right(I a, I bits) { return _mm256_srav_epi32(a, bits); }
  static I shift_left(I a, I bits) { return _mm256_sllv_epi32(a, bits); }
  static F to_float(I a) { return _mm256_cvtepi32_ps(a); }
  static I truncate(F a) { return _mm256_cvttps_epi32(a); }

  template <int kPredicate>
  static M compare(F a, F b) {
    return _mm256_castps_si256(_mm256_cmp_ps(a, b, kPredicate));
  }
  static M less(F a, F b) { return compare<_CMP_LT_OQ>(a, b); }
  static M less_equal(F a, F b) { return compare<_CMP_LE_OQ>(a, b); }
  static M equal(I a, I b) { return _mm256_cmpeq_epi32(a, b); }
  static M greater(I a, I b) { return _mm256_cmpgt_epi32(a, b); }
  /// The lanes of an as_int value: those that hold -1.
  static M as_mask(I a) { return a; }

  static M both(M a, M b) { return _mm256_and_si256(a, b); }
  static M either(M a, M b) { return _mm256_or_si256(a, b); }
  /// The lanes of b that are not in a.
  static M but_not(M a, M b) { return _mm256_andnot_si256(a, b); }
  static M all_lanes() { return _mm256_set1_epi32(-1); }
  static M no_lanes() { return _mm256_setzero_si256(); }
  static bool any(M m) { return !_mm256_testz_si256(m, m); }
  /// Bit l set for lane l of m.
  static std::uint32_t bits(M m) {
    return std::uint32_t(_mm256_movemask_ps(_mm256_castsi256_ps(m)));
  }
  /// The lanes whose bit is set in `b`.
  static M lanes(std::uint32_t b) {
    const I bit = _mm256_setr_epi32(1, 2, 4, 8, 16, 32, 64, 128);
    return _mm256_cmpeq_epi32(_mm256_and_si256(_mm256_set1_epi32(int(b)), bit), bit);
  }
  /// The lanes of m as integers: -1 in them, 0 elsewhere (and back with nonzero).
  static I as_int(M m) { return m; }
  /// a in the lanes of m, 0 elsewhere.
  static I keep(M m, I a) { return _mm256_and_si256(m, a); }

  /// Per lane: a where m is clear, b where it is set.
  static F select(M m, F a, F b) { return _mm256_blendv_ps(a, b, _mm256_castsi256_ps(m)); }
  static I select(M m, I a, I b) { return _mm256_blendv_epi8(a, b, m); }

  /// base[index] (scaled by kScale bytes) in the lanes of m, `fallback` elsewhere.
  template <int kScale>
  static I gather(I fallback, const void* base, I index, M m) {
    return _mm256_mask_i32gather_epi32(fallback, static_cast<const int*>(base), index, m, kScale);
  }
  static F gather(const float* base, I index, M m) {
    return _mm256_mask_i32gather_ps(_mm256_setzero_ps(), base, index, _mm256_castsi256_ps(m), 4);
  }
  /// Per lane of `takers`, the lane of `givers` it pairs with: the k-th lowest taker with the
  /// k-th lowest giver (both hold as many lanes); other lanes hold 0. Built as 4-bit fields of
  /// one integer, so that nothing goes through memory.
  static I pair_lanes(std::uint32_t takers, std::uint32_t givers) {
    std::uint32_t packed = 0;
    for (; takers != 0; takers &= takers - 1, givers &= givers - 1)
      packed |= std::uint32_t(__builtin_ctz(givers)) << (4 * __builtin_ctz(takers));
    const I shifts = _mm256_setr_epi32(0, 4, 8, 12, 16, 20, 24, 28);
    return _mm256_and_si256(_mm256_srlv_epi32(_mm256_set1_epi32(int(packed)), shifts),
                            _mm256_set1_epi32(15));
  }
  /// v[index[l]] in lane l.
  static F permute(F v, I index) { return _mm256_permutevar8x32_ps(v, index); }
  static I permute(I v, I index) { return _mm256_permutevar8x32_epi32(v, index); }
};

}  // namespace irgrid::simd
